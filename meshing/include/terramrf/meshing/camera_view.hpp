#pragma once
// One camera image of one frame placed in the world: projection of world points (eq. 7–8), back
// projection of pixels to rays, and a LiDAR depth map for visibility (a mesh vertex hidden behind
// a nearer surface must not take that surface's pixel label).
#include <Eigen/Geometry>
#include <optional>
#include <vector>

#include "terramrf/camera.hpp"
#include "terramrf/point_cloud.hpp"

namespace terramrf::meshing {

class CameraView {
 public:
  /// `depth_dilate_px`: radius of the min filter that closes the gaps between LiDAR rows.
  CameraView(const CameraModel& cam, const Eigen::Isometry3d& T_world_lidar, const PointCloud& points,
             int depth_dilate_px = 3);

  const CameraModel& camera() const { return cam_; }
  int width() const { return cam_.width; }
  int height() const { return cam_.height; }
  /// Camera centre in the world [m].
  const Eigen::Vector3d& centre() const { return centre_w_; }

  /// Pixel of a world point and its depth along the optical axis [m]; nullopt outside the image
  /// or behind the camera.
  std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& p_world, double* depth = nullptr) const;
  /// World ray direction (unit) through pixel (u, v) (distortion ignored).
  Eigen::Vector3d ray(double u, double v) const;
  /// Nearest LiDAR depth around pixel (u, v) [m]; +inf where no point projects nearby.
  float lidarDepth(int u, int v) const { return depth_[std::size_t(v) * cam_.width + u]; }
  /// True unless a LiDAR surface clearly nearer than `depth` covers pixel (u, v).
  bool visible(int u, int v, double depth, double tolerance_m = 0.6) const {
    return lidarDepth(u, v) >= depth - tolerance_m - 0.03 * depth;
  }
  /// Like visible(), but a return covers only the pixels beside and below it (up to the
  /// dilation): the gaps between LiDAR rows on a wall still close, while the nearer ground just
  /// below a pixel, which is not in front of it, no longer counts as an occluder. visible()'s
  /// square window does that on ground seen at a grazing angle (at 24 m, 3 rows lower is ~3 m
  /// nearer): texture baking with it lost 40 % of the textured vertices of the demo.
  bool unoccluded(int u, int v, double depth, double tolerance_m = 0.6) const {
    return depth_above_[std::size_t(v) * cam_.width + u] >= depth - tolerance_m - 0.03 * depth;
  }

 private:
  CameraModel cam_;
  Eigen::Isometry3d T_lidar_world_, T_world_lidar_;
  Eigen::Matrix3d M_inv_;  // (K·R_cl)⁻¹ for back projection in the LiDAR frame
  Eigen::Vector3d centre_w_;
  std::vector<float> depth_;
  std::vector<float> depth_above_;  ///< min over the returns beside and up to `dilate` rows above
};

}  // namespace terramrf::meshing
