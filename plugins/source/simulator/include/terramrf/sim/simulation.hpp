#pragma once
// The whole simulator behind the "simulator" source plugin: configuration → world, trajectory,
// LiDAR, camera and motion sensors, and frame i. Other modules (e.g. meshing, tests) build a
// Simulation from the same parameters as a pipeline's `source: {type: simulator, params: ...}`
// and get the identical world for ground-truth queries.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "terramrf/frame.hpp"
#include "terramrf/params.hpp"
#include "terramrf/sim/camera.hpp"
#include "terramrf/sim/lidar.hpp"
#include "terramrf/sim/sensors.hpp"
#include "terramrf/sim/trajectory.hpp"
#include "terramrf/sim/world.hpp"

namespace terramrf::sim {

/// Every parameter of the simulator plugin (defaults = the plugin's defaults).
struct SimulationConfig {
  int64_t seed = 1;
  int64_t frames = 100;
  double scene_length_m = 300;
  double scene_width_m = 160;
  double speed_m_s = 9.0;
  double frame_rate_hz = 10.0;
  double obstacle_density = 1.0;
  double hill_height_m = 2.0;
  double rough_noise_m = 0.04;
  double road_width_m = 6.5;
  double ditch_depth_m = 1.0;
  double ditch_width_m = 1.5;
  // LiDAR
  double lidar_height_m = 1.73;
  double azimuth_step_deg = 0.09;
  double min_range_m = 1.0;
  double max_range_m = 100.0;
  double range_noise_m = 0.02;
  double dropout_prob = 0.01;
  double grass_depth_m = 0.0;
  double gravel_depth_m = 0.0;
  double intensity_noise = 0.02;
  bool motion_distortion = false;
  std::string point_order = "column";
  // camera
  bool enable_camera = true;
  int camera_width = 640;
  int camera_height = 256;
  double camera_fx = 370.0;
  double camera_pitch_deg = 0.0;
  /// One camera per entry, turned this far to the left of straight ahead [deg]; named image_2,
  /// image_3 in this order (KITTI's calibration holds two colour cameras, P2 and P3).
  std::vector<double> camera_yaws_deg{0.0};
  double camera_far_m = 200.0;
  double pixel_noise = 2.0;
  // IMU / GPS / odometry
  double imu_rate_hz = 100;
  double gyro_noise_rad_s = 0.002;
  double gyro_bias_rad_s = 0.001;
  double accel_noise_m_s2 = 0.05;
  double accel_bias_m_s2 = 0.05;
  double gps_rate_hz = 2;
  double gps_sigma_m = 1.5;
  double odometry_rate_hz = 20;
  double odometry_scale_error = 0.02;
  double odometry_speed_noise_m_s = 0.05;
  double odometry_yaw_rate_noise_rad_s = 0.005;
};

/// Binds every field of `c` as a parameter (names, docs, units, ranges) — the plugin's declare().
void declareSimulationParams(ParamDecl& d, SimulationConfig& c);

/// Parses a YAML flow map of simulator parameters (e.g. the `params:` of a pipeline's source)
/// with the same checks as the plugin. Throws std::runtime_error listing the problems.
SimulationConfig parseSimulationConfig(const std::string& yaml_map);

class Simulation {
 public:
  /// Builds the world (~0.1 s). Throws ParamError(param, why) for inconsistent settings.
  explicit Simulation(const SimulationConfig& config);
  ~Simulation();

  const SimulationConfig& config() const { return c_; }
  std::size_t size() const { return std::size_t(c_.frames); }
  double frameTime(std::size_t i) const { return double(i) / c_.frame_rate_hz; }
  /// Frame i: points + truth, camera, IMU/GPS/odometry since frame i−1, pose and truth_pose (both
  /// the trajectory's pose at the frame's time). Deterministic and independent of call order (all
  /// noise derives from seed and i). Thread-safe (const).
  Frame frame(std::size_t i) const;

  const World& world() const { return *world_; }
  const Trajectory& trajectory() const { return *trajectory_; }
  const LidarModel& lidar() const { return *lidar_; }
  /// One per camera_yaws_deg entry; empty when enable_camera is false.
  const std::vector<std::unique_ptr<CameraRenderer>>& cameras() const { return cameras_; }
  const SensorModel& sensors() const { return *sensors_; }

 private:
  SimulationConfig c_;
  std::unique_ptr<World> world_;
  std::unique_ptr<Trajectory> trajectory_;
  std::unique_ptr<LidarModel> lidar_;
  std::vector<std::unique_ptr<CameraRenderer>> cameras_;
  std::unique_ptr<SensorModel> sensors_;
};

}  // namespace terramrf::sim
