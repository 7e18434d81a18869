#pragma once
#include <Eigen/Geometry>
#include <array>
#include <optional>
#include <string>

#include "terramrf/image.hpp"

namespace terramrf {

/// Pinhole camera with optional radial-tangential distortion.
///
/// Projection of a LiDAR point X: x_c = T_camera_lidar · X; if x_c.z <= 0 it is behind the camera;
/// undistorted pixel = P · [x_c; 1] (homogeneous). P is 3×4 so KITTI's rectified P2 (which carries
/// the stereo baseline in its last column) is represented exactly; for a plain camera P = K [I | 0].
struct CameraModel {
  std::string name;                     ///< e.g. "image_2"
  int width = 0;                        ///< [px]
  int height = 0;                       ///< [px]
  Eigen::Matrix<double, 3, 4> P = Eigen::Matrix<double, 3, 4>::Zero();
  /// k1, k2, p1, p2, k3 (OpenCV order); all zero = no distortion. Applied in normalised coordinates
  /// of K = P.leftCols<3>() before the intrinsics. A point projects nowhere if, on its way out from
  /// the optical axis, the distortion stops pushing it outward: where the radial polynomial stops
  /// growing, or where the tangential terms (which grow with r², e.g. p2 = 0.001 turns the −x ray
  /// back at r = 167, 89.7° off axis) outweigh it. Beyond such a fold a point far outside the
  /// field of view would land inside the image and take the colour of pixels it never saw.
  std::array<double, 5> distortion{0, 0, 0, 0, 0};
  /// LiDAR → camera (for KITTI: R0_rect · Tr_velo_to_cam).
  Eigen::Isometry3d T_camera_lidar = Eigen::Isometry3d::Identity();
  /// Where P and T_camera_lidar came from, in the dataset's own terms, so a bad-calibration error
  /// can name it: the file(s) and the entries used, e.g. ".../calib/000000.txt (P2, R0_rect,
  /// Tr_velo_to_cam)". Empty for a camera not read from files (the simulator's, a test's).
  std::string calibration;

  /// Pixel (u, v) [px] of a LiDAR-frame point, or nullopt if behind the camera or outside the image.
  std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& p_lidar) const;
  /// Same without the image-bounds check (for rays and debugging).
  std::optional<Eigen::Vector2d> projectUnbounded(const Eigen::Vector3d& p_lidar) const;
};

struct CameraImage {
  CameraModel model;
  ImagePtr image;          ///< shared, never copied between stages
  ImagePtr truth;          ///< optional per-pixel ground truth: 1 channel, project LabelId values
  std::string source_path; ///< where it was read from (for messages)
};

}  // namespace terramrf
