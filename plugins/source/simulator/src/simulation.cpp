#include "terramrf/sim/simulation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "terramrf/errors.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/plugin.hpp"
#include "terramrf/sim/random.hpp"

namespace terramrf::sim {

namespace {
/// A number for an error message: up to 3 significant decimals, no trailing zeros.
std::string fmt(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3g", v);
  return b;
}
}  // namespace

void declareSimulationParams(ParamDecl& d, SimulationConfig& c) {
  d.add("seed", c.seed, "seed of the world and of all sensor noise").unit("1").min(0);
  d.add("frames", c.frames, "number of frames (sweeps)").unit("frames").range(1, 1e6);
  d.add("scene_length_m", c.scene_length_m,
        "minimum length of the generated road strip; extended to cover the drive plus the view "
        "distance at both ends")
      .unit("m")
      .range(50, 1e5);
  d.add("scene_width_m", c.scene_width_m,
        "width of the strip around the road holding objects (at least 60 m: the landmark building "
        "near the start reaches up to 29 m from the road)")
      .unit("m")
      .range(60, 1000);
  d.add("speed_m_s", c.speed_m_s, "mean driving speed (varies ±8% slowly)")
      .unit("m/s")
      .range(0.5, 40);
  d.add("frame_rate_hz", c.frame_rate_hz, "sweeps per second (HDL-64E: 10)")
      .unit("Hz")
      .range(1, 50);
  d.add("obstacle_density", c.obstacle_density,
        "scales the number of buildings, trees, rocks, cars")
      .unit("1")
      .range(0, 5);
  d.add("hill_height_m", c.hill_height_m,
        "amplitude of the terrain's hills; the road's grade can reach 6.98 % per metre of it and "
        "is limited to 20 %, so at most 2.86 m")
      .unit("m")
      .range(0, 20);
  d.add("rough_noise_m", c.rough_noise_m, "max small-scale height noise of grass/gravel")
      .unit("m")
      .range(0, 0.3);
  d.add("road_width_m", c.road_width_m, "asphalt width (two lanes)").unit("m").range(3, 20);
  d.add("ditch_depth_m", c.ditch_depth_m, "depth of the ditch beside the road")
      .unit("m")
      .range(0, 5);
  d.add("ditch_width_m", c.ditch_width_m, "top width of the ditch (> 0.5)").unit("m").range(0.6, 5);
  d.add("lidar_height_m", c.lidar_height_m, "LiDAR origin above the road (KITTI: 1.73)")
      .unit("m")
      .range(0.3, 5);
  d.add("azimuth_step_deg", c.azimuth_step_deg,
        "horizontal angle between firings (0.09 ≈ 4000 "
        "columns per turn)")
      .unit("deg")
      .range(0.05, 5);
  d.add("min_range_m", c.min_range_m, "returns closer than this are discarded")
      .unit("m")
      .range(0, 10);
  d.add("max_range_m", c.max_range_m, "no return beyond this").unit("m").range(5, 300);
  d.add("range_noise_m", c.range_noise_m, "1σ range noise along the beam").unit("m").range(0, 1);
  d.add("grass_depth_m", c.grass_depth_m,
        "grass canopy height: beams on grass return from a blade at a uniform height up to this "
        "above the soil (0: from the soil surface)")
      .unit("m")
      .range(0, 1);
  d.add("gravel_depth_m", c.gravel_depth_m,
        "gravel grain: beams on gravel return from a stone top up to this above the bed (0: from "
        "the bed surface)")
      .unit("m")
      .range(0, 1);
  d.add("dropout_prob", c.dropout_prob, "probability that a beam returns nothing")
      .unit("1")
      .range(0, 0.95);
  d.add("intensity_noise", c.intensity_noise, "1σ intensity noise (intensity in [0, 1])")
      .unit("1")
      .range(0, 0.5);
  d.add("motion_distortion", c.motion_distortion,
        "fire each column from the pose at its own time (raw, not deskewed, sweeps)");
  d.add("point_order", c.point_order,
        "column: firing order (azimuth column, then ring 0..63); ring: KITTI .bin order (ring by "
        "ring, each from azimuth 0 counter-clockwise)")
      .choices({"column", "ring"});
  d.add("enable_camera", c.enable_camera,
        "render the cameras (image_2, and image_3 with a second yaw) and their pixel truth");
  d.add("camera_width", c.camera_width, "image width").unit("px").range(64, 4096);
  d.add("camera_height", c.camera_height, "image height").unit("px").range(64, 4096);
  d.add("camera_fx", c.camera_fx, "focal length (fy = fx; principal point at the image centre)")
      .unit("px")
      .range(10, 1e4);
  d.add("camera_pitch_deg", c.camera_pitch_deg, "optical axis below horizontal")
      .unit("deg")
      .range(-45, 45);
  d.add("camera_yaws_deg", c.camera_yaws_deg,
        "one camera per entry (at most two: image_2, image_3), its optical axis turned this far "
        "left of the driving direction; e.g. [0, 180] adds a rear camera")
      .unit("deg")
      .range(-180, 180);
  d.add("camera_far_m", c.camera_far_m, "view distance; beyond is haze/sky")
      .unit("m")
      .range(10, 1000);
  d.add("pixel_noise", c.pixel_noise, "1σ image noise").unit("grey levels").range(0, 50);
  d.add("imu_rate_hz", c.imu_rate_hz, "IMU sample rate").unit("Hz").range(1, 2000);
  d.add("gyro_noise_rad_s", c.gyro_noise_rad_s, "1σ gyro white noise per sample")
      .unit("rad/s")
      .range(0, 1);
  d.add("gyro_bias_rad_s", c.gyro_bias_rad_s, "1σ of the constant gyro bias per axis")
      .unit("rad/s")
      .range(0, 1);
  d.add("accel_noise_m_s2", c.accel_noise_m_s2, "1σ accelerometer white noise per sample")
      .unit("m/s^2")
      .range(0, 10);
  d.add("accel_bias_m_s2", c.accel_bias_m_s2, "1σ of the constant accelerometer bias per axis")
      .unit("m/s^2")
      .range(0, 10);
  d.add("gps_rate_hz", c.gps_rate_hz, "GPS fix rate").unit("Hz").range(0.1, 100);
  d.add("gps_sigma_m", c.gps_sigma_m, "1σ horizontal GPS error (vertical 1.5×)")
      .unit("m")
      .range(0, 100);
  d.add("odometry_rate_hz", c.odometry_rate_hz, "wheel odometry rate").unit("Hz").range(0.1, 1000);
  d.add("odometry_scale_error", c.odometry_scale_error, "measured speed = (1 + this) · true speed")
      .unit("1")
      .range(-0.5, 0.5);
  d.add("odometry_speed_noise_m_s", c.odometry_speed_noise_m_s, "1σ speed noise")
      .unit("m/s")
      .range(0, 10);
  d.add("odometry_yaw_rate_noise_rad_s", c.odometry_yaw_rate_noise_rad_s, "1σ yaw-rate noise")
      .unit("rad/s")
      .range(0, 1);
}

namespace {
/// Lets the framework's parameter parser fill a SimulationConfig outside the plugin.
class ConfigHolder : public Plugin {
 public:
  SimulationConfig config;
  void declare(ParamDecl& d) override { declareSimulationParams(d, config); }
};
}  // namespace

SimulationConfig parseSimulationConfig(const std::string& yaml_map) {
  ConfigHolder h;
  setParams(h, yaml_map, PluginContext{});
  return h.config;
}

Simulation::Simulation(const SimulationConfig& config) : c_(config) {
  if (c_.max_range_m <= c_.min_range_m)
    throw ParamError("max_range_m",
                     "must exceed min_range_m (" + std::to_string(c_.min_range_m) + " m)");
  if (c_.ditch_width_m <= 0.5 + 1e-9)
    throw ParamError("ditch_width_m", "must exceed 0.5 m (two 0.25 m walls)");
  if (c_.point_order != "column" && c_.point_order != "ring")
    throw ParamError("point_order", "expected 'column' or 'ring'");
  // The road follows the longest hills; steeper than 20 % it is no road to drive (hill_height_m
  // 20 drove a 52° slope).
  constexpr double kMaxRoadGrade = 0.20;
  const double grade = World::roadGradeBound(c_.hill_height_m);
  if (grade > kMaxRoadGrade)
    throw ParamError("hill_height_m",
                     "is " + fmt(c_.hill_height_m) +
                         " m: the road follows the two longest hills, "
                         "so its grade could reach " +
                         fmt(100 * grade) + " %; at most 20 % is allowed, i.e. hill_height_m <= " +
                         fmt(std::floor(100 * kMaxRoadGrade / World::roadGradeBound(1.0)) / 100) +
                         " m");
  const double period = 1.0 / c_.frame_rate_hz;
  TrajectoryParams tp;
  tp.speed_m_s = c_.speed_m_s;
  tp.sensor_height_m = c_.lidar_height_m;
  tp.lane_offset_m = -0.25 * c_.road_width_m;  // centre of the right lane
  // Longest distance the drive can cover (the speed varies by ±speed_variation).
  const double drive_m =
      c_.speed_m_s * (1.0 + tp.speed_variation) * (c_.frames * period + 1.0) + 5.0;
  const double view_m = std::max(c_.max_range_m, c_.enable_camera ? c_.camera_far_m : 0.0) + 30.0;

  WorldParams wp;
  wp.seed = uint64_t(c_.seed);
  wp.x_min_m = -view_m;
  wp.x_max_m = std::max(c_.scene_length_m, drive_m + view_m);
  wp.object_half_width_m = 0.5 * c_.scene_width_m;
  wp.terrain_half_width_m = std::max(wp.object_half_width_m, view_m) + 10.0;
  wp.road_width_m = c_.road_width_m;
  wp.hill_height_m = c_.hill_height_m;
  wp.rough_noise_m = c_.rough_noise_m;
  wp.ditch_depth_m = c_.ditch_depth_m;
  wp.ditch_width_m = c_.ditch_width_m;
  wp.obstacle_density = c_.obstacle_density;
  // The strip grows with the drive (~8 KB of terrain table per metre with the camera's view):
  // frames: 1000000 wanted ~8 GB and ended in std::bad_alloc, or took minutes to build.
  constexpr double kMaxTableBytes = 2e9;
  const double table_bytes = World::terrainTableBytes(wp);
  if (table_bytes > kMaxTableBytes)
    throw ParamError(
        "frames", "is " + std::to_string(c_.frames) + ": a drive of up to " + fmt(drive_m / 1000) +
                      " km needs a terrain table of " + fmt(table_bytes / 1e9) +
                      " GB (0.5 m cells over a strip " + fmt((wp.x_max_m - wp.x_min_m) / 1000) +
                      " km long and " + fmt(2 * wp.terrain_half_width_m) +
                      " m wide), more than the 2 GB allowed; lower frames or speed_m_s "
                      "(max_range_m and camera_far_m widen the strip)");
  try {
    world_ = std::make_unique<World>(wp);
  } catch (const std::invalid_argument& e) {
    throw ParamError("", e.what());
  }
  // The declared 60 m held the landmark beside every road width tried (6.5–20 m, seeds 1–60);
  // this catches a narrower strip set from C++ (and any seed that would need more).
  if (world_->landmarkWidthNeeded_m() > 0)
    throw ParamError("scene_width_m",
                     "is " + fmt(c_.scene_width_m) +
                         " m, too narrow for the landmark building (left of the road, 15-25 m "
                         "ahead of the start): beside this road it needs " +
                         fmt(std::ceil(2 * world_->landmarkWidthNeeded_m())) +
                         " m; raise scene_width_m or set obstacle_density: 0");
  trajectory_ = std::make_unique<Trajectory>(*world_, tp);
  if (trajectory_->endTime() < c_.frames * period)
    throw ParamError("frames", "the drive leaves the generated world; lower frames or speed_m_s");

  LidarParams lp;
  lp.azimuth_step_deg = c_.azimuth_step_deg;
  lp.min_range_m = c_.min_range_m;
  lp.max_range_m = c_.max_range_m;
  lp.range_noise_m = c_.range_noise_m;
  lp.dropout_prob = c_.dropout_prob;
  lp.grass_depth_m = c_.grass_depth_m;
  lp.gravel_depth_m = c_.gravel_depth_m;
  lp.intensity_noise = c_.intensity_noise;
  lp.sweep_period_s = period;
  lp.motion_distortion = c_.motion_distortion;
  lp.order = c_.point_order == "ring" ? PointOrder::kRing : PointOrder::kColumn;
  try {
    lidar_ = std::make_unique<LidarModel>(*world_, lp);
  } catch (const std::invalid_argument& e) {
    throw ParamError("azimuth_step_deg", e.what());
  }
  if (c_.enable_camera) {
    if (c_.camera_yaws_deg.empty() || c_.camera_yaws_deg.size() > 2)
      throw ParamError("camera_yaws_deg",
                       "has " + std::to_string(c_.camera_yaws_deg.size()) +
                           " entries; expected one or two (image_2, image_3), or enable_camera: "
                           "false for none");
    for (std::size_t k = 0; k < c_.camera_yaws_deg.size(); ++k) {
      CameraParams cp;
      cp.name = "image_" + std::to_string(2 + k);
      cp.width = c_.camera_width;
      cp.height = c_.camera_height;
      cp.fx = c_.camera_fx;
      cp.pitch_deg = c_.camera_pitch_deg;
      cp.yaw_deg = c_.camera_yaws_deg[k];
      cp.far_m = c_.camera_far_m;
      cp.pixel_noise = c_.pixel_noise;
      cameras_.push_back(std::make_unique<CameraRenderer>(*world_, cp));
    }
  }
  const ImuParams ip{c_.imu_rate_hz, c_.gyro_noise_rad_s, c_.gyro_bias_rad_s, c_.accel_noise_m_s2,
                     c_.accel_bias_m_s2};
  const GpsParams gp{c_.gps_rate_hz, c_.gps_sigma_m};
  const OdometryParams op{c_.odometry_rate_hz, c_.odometry_scale_error, c_.odometry_speed_noise_m_s,
                          c_.odometry_yaw_rate_noise_rad_s};
  sensors_ = std::make_unique<SensorModel>(*trajectory_, uint64_t(c_.seed), ip, gp, op);
}

Simulation::~Simulation() = default;

Frame Simulation::frame(std::size_t i) const {
  if (i >= size())
    throw std::out_of_range("simulator: frame " + std::to_string(i) + " requested, " +
                            std::to_string(size()) + " configured");
  const double period = 1.0 / c_.frame_rate_hz;
  const double t = frameTime(i);
  const uint64_t seed = uint64_t(c_.seed);
  Frame f;
  char id[32];
  std::snprintf(id, sizeof id, "%06zu", i);
  f.id = id;
  f.source_path = "simulator(seed=" + std::to_string(c_.seed) + ")/" + f.id;
  f.timestamp_s = t;
  const Trajectory& traj = *trajectory_;
  lidar_->scan([&](double tau) { return traj.pose(t + tau); },
               hashKeys(seed, uint64_t(Stream::kLidar), i), f);
  // The trajectory the scan was taken from is the truth; `pose` starts as it too, so that runs
  // without an egomotion stage place the scan exactly, and one with it is scored against it.
  f.truth_pose = traj.pose(t);
  f.pose = f.truth_pose;
  for (std::size_t k = 0; k < cameras_.size(); ++k)  // k = 0: the key of the one-camera rig
    f.cameras.push_back(
        cameras_[k]->render(*f.pose, hashKeys(seed, uint64_t(Stream::kCamera), i, k)));
  f.imu = sensors_->imu(t - period, t);
  f.gps = sensors_->gps(t - period, t);
  f.odometry = sensors_->odometry(t - period, t);
  return f;
}

}  // namespace terramrf::sim
