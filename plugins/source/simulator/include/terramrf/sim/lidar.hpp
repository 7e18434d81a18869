#pragma once
// Velodyne HDL-64E-like spinning LiDAR over the simulated world.
#include <Eigen/Geometry>
#include <array>
#include <functional>

#include "terramrf/frame.hpp"
#include "terramrf/sim/world.hpp"

namespace terramrf::sim {

/// Elevation of each laser [deg], ring 0 = top beam: upper block +2.0 … −8.33 in 1/3° steps,
/// lower block −8.83 … −24.33 in 1/2° steps (the nominal HDL-64E layout).
const std::array<double, 64>& hdl64ElevationsDeg();

enum class PointOrder {
  kColumn,  ///< firing order: azimuth column by column, rings 0..63 within a column
  kRing,    ///< KITTI .bin order: ring by ring, each ring from azimuth 0 counter-clockwise
};

struct LidarParams {
  double azimuth_step_deg = 0.09;  ///< [deg]; columns per revolution = round(360 / step)
  double min_range_m = 1.0;
  double max_range_m = 100.0;
  double range_noise_m = 0.02;    ///< 1σ along the beam [m]
  double dropout_prob = 0.01;     ///< chance a beam returns nothing [1]
  /// Grass canopy height [m]: a beam on grass returns from a blade at a uniform height in
  /// [0, this] above the soil, i.e. that height / sin(incidence) earlier along the beam (capped at
  /// 10×), as real scans of grass show (no single surface; scatter grows at grazing incidence).
  /// 0 = returns from the soil surface.
  double grass_depth_m = 0.0;
  /// The same for gravel [m]: returns from the top of a stone up to this above the bed.
  double gravel_depth_m = 0.0;
  double intensity_noise = 0.02;  ///< 1σ [intensity units, 0..1 scale]
  double sweep_period_s = 0.1;    ///< one revolution [s]
  /// If true, each column is fired from the pose at its own time and reported in that
  /// instantaneous sensor frame (like a real sensor's raw, not deskewed, output).
  bool motion_distortion = false;
  PointOrder order = PointOrder::kColumn;
};

class LidarModel {
 public:
  LidarModel(const World& world, const LidarParams& params);

  const LidarParams& params() const { return p_; }
  int columns() const { return columns_; }
  /// Azimuth of column c [rad], atan2(y, x) in the sensor frame. The head spins clockwise seen
  /// from above (as the HDL-64E does), starting at the rear: column 0 looks backwards.
  double columnAzimuth(int c) const;
  /// Time of column c within the sweep [s].
  double columnTime(int c) const { return c * p_.sweep_period_s / columns_; }

  /// Simulates one sweep starting at the time of pose_at(0); pose_at(τ) gives T_world_lidar at
  /// offset τ [s] (called once per column only with motion_distortion). Fills frame.points
  /// (x, y, z, intensity, ring, time_s) and frame.truth (label, raw). `key` seeds all noise.
  void scan(const std::function<Eigen::Isometry3d(double)>& pose_at, uint64_t key,
            Frame& frame) const;

 private:
  /// How far a canopy/grain return at `hit` moves back along the beam `dir` (unit, world frame):
  /// `shift_m`, or less where its material ends before that [m].
  double canopyShift(const RayHit& hit, const Eigen::Vector3d& dir, double shift_m) const;

  const World* world_;
  LidarParams p_;
  int columns_ = 0;
  std::array<double, 64> cos_el_{}, sin_el_{};
};

}  // namespace terramrf::sim
