#pragma once
// IMU, GPS and wheel odometry derived from the ground-truth trajectory. Sample k of a sensor is a
// pure function of (seed, k), so frames can be read in any order and still agree.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "terramrf/frame.hpp"
#include "terramrf/sim/trajectory.hpp"

namespace terramrf::sim {

struct ImuParams {
  double rate_hz = 100;
  double gyro_noise_rad_s = 0.002;  ///< white noise per sample, 1σ [rad/s]
  double gyro_bias_rad_s = 0.001;   ///< constant bias per axis drawn with this 1σ [rad/s]
  double accel_noise_m_s2 = 0.05;   ///< white noise per sample, 1σ [m/s²]
  double accel_bias_m_s2 = 0.05;    ///< constant bias per axis drawn with this 1σ [m/s²]
};

struct GpsParams {
  double rate_hz = 2;
  double sigma_m = 1.5;  ///< horizontal 1σ [m]; vertical is 1.5× this
};

struct OdometryParams {
  double rate_hz = 20;
  double scale_error = 0.02;            ///< measured speed = (1 + scale_error) · true speed [1]
  double speed_noise_m_s = 0.05;        ///< 1σ [m/s]
  double yaw_rate_noise_rad_s = 0.005;  ///< 1σ [rad/s]
};

inline constexpr double kGravity_m_s2 = 9.80665;

class SensorModel {
 public:
  SensorModel(const Trajectory& trajectory, uint64_t seed, const ImuParams& imu,
              const GpsParams& gps, const OdometryParams& odo);

  /// Samples with timestamps in (t_begin, t_end] [s].
  std::vector<ImuSample> imu(double t_begin_s, double t_end_s) const;
  std::vector<GpsSample> gps(double t_begin_s, double t_end_s) const;
  std::vector<OdometrySample> odometry(double t_begin_s, double t_end_s) const;

  /// Noise-free values (ground truth for tests).
  ImuSample trueImu(double t_s) const;
  OdometrySample trueOdometry(double t_s) const;
  const Eigen::Vector3d& gyroBias() const { return gyro_bias_; }
  const Eigen::Vector3d& accelBias() const { return accel_bias_; }

 private:
  const Trajectory* traj_;
  uint64_t seed_;
  ImuParams imu_;
  GpsParams gps_;
  OdometryParams odo_;
  Eigen::Vector3d gyro_bias_, accel_bias_;
};

}  // namespace terramrf::sim
