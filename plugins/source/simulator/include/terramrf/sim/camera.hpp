#pragma once
// Pinhole camera (forward-looking unless turned by yaw_deg) rendering the simulated world by ray
// casting, with per-pixel ground truth (project class; sky = unknown).
#include <Eigen/Geometry>
#include <string>

#include "terramrf/camera.hpp"
#include "terramrf/sim/world.hpp"

namespace terramrf::sim {

struct CameraParams {
  std::string name = "image_2";
  int width = 640;         ///< [px]
  int height = 256;        ///< [px]
  double fx = 370.0;       ///< focal length [px] (fy = fx; KITTI's 721 px scaled to 640 px width)
  double pitch_deg = 0.0;  ///< optical axis below the LiDAR's horizontal plane [deg]
  double yaw_deg = 0.0;    ///< optical axis turned left of the LiDAR's x axis [deg]
  /// Camera centre in the LiDAR frame before the yaw [m] (KITTI: ~0.27 m ahead, 0.08 m below
  /// the Velodyne); a turned camera sits as far out in its own direction.
  Eigen::Vector3d position_lidar_m{0.27, 0.0, -0.08};
  double far_m = 200.0;      ///< rays longer than this see haze/sky [m]
  double pixel_noise = 2.0;  ///< 1σ sensor noise [grey levels]
};

class CameraRenderer {
 public:
  CameraRenderer(const World& world, const CameraParams& params);

  const CameraParams& params() const { return p_; }
  /// Intrinsics (P = K [I|0], principal point at the image centre) and T_camera_lidar.
  const CameraModel& model() const { return model_; }
  /// Renders the view from the LiDAR pose T_world_lidar. `key` seeds pixel noise and foliage.
  CameraImage render(const Eigen::Isometry3d& T_world_lidar, uint64_t key) const;

 private:
  const World* world_;
  CameraParams p_;
  CameraModel model_;
  Eigen::Isometry3d T_lidar_camera_;
};

}  // namespace terramrf::sim
