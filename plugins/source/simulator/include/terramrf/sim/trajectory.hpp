#pragma once
// The vehicle's ground-truth motion: it drives along the road's right lane with a slowly varying
// speed. Everything is a smooth function of time, so IMU rates and accelerations come from the
// same function as the poses (central differences) and any time can be evaluated independently.
#include <Eigen/Geometry>
#include <vector>

#include "terramrf/sim/world.hpp"

namespace terramrf::sim {

struct TrajectoryParams {
  double start_x_m = 0;           ///< x of the vehicle at t = 0 [m]
  double speed_m_s = 9.0;         ///< mean forward speed [m/s]
  double speed_variation = 0.08;  ///< relative amplitude of the slow speed change [1]
  double speed_period_s = 15;     ///< period of the speed change [s]
  double lane_offset_m = -1.625;  ///< lateral offset from the road centre, left positive [m]
  double sensor_height_m = 1.73;  ///< LiDAR origin above the road surface [m]
};

class Trajectory {
 public:
  Trajectory(const World& world, const TrajectoryParams& params);

  const TrajectoryParams& params() const { return p_; }
  /// Forward speed of the vehicle on the road surface [m/s] and distance driven since t = 0 [m].
  double speed(double t_s) const;
  double distance(double t_s) const;
  /// LiDAR pose in the world (x forward, y left, z up; no roll) at time t [s].
  Eigen::Isometry3d pose(double t_s) const;
  /// Velocity and acceleration of the LiDAR origin in the world [m/s], [m/s²].
  Eigen::Vector3d velocity(double t_s) const;
  Eigen::Vector3d acceleration(double t_s) const;
  /// Angular velocity in the LiDAR/body frame [rad/s].
  Eigen::Vector3d angularVelocityBody(double t_s) const;
  /// Time [s] after which the vehicle would leave the world's tabulated strip.
  double endTime() const { return end_time_s_; }

 private:
  Eigen::Vector2d pathPoint(double x) const;
  double pathSpeed(double x) const;  ///< |d(P, z)/dx| along the road surface
  double arcFromNode(int node, double x) const;
  double nodeX(int node) const;
  double xAtArc(double s) const;
  double roadZ(const Eigen::Vector2d& p) const;

  const World* world_;
  TrajectoryParams p_;
  double node_x0_ = 0, node_dx_ = 1.0;  ///< x of the start node, node spacing [m]
  int node_start_ = 0;                  ///< index of the start node
  std::vector<double> node_s_;          ///< arc length from the start at table nodes [m]
  double end_time_s_ = 0;
};

}  // namespace terramrf::sim
