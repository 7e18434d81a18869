#include "terramrf/sim/sensors.hpp"

#include <cmath>

#include "terramrf/sim/random.hpp"

namespace terramrf::sim {

namespace {
/// Sample indices k with k / rate in (t0, t1]; the small tolerance keeps adjacent frames
/// partitioning the samples exactly despite rounding of t = i / frame_rate.
template <class F>
void forSamples(double rate, double t0, double t1, F&& f) {
  if (rate <= 0) return;
  const long long k0 = (long long)std::floor(t0 * rate + 1e-7) + 1;
  const long long k1 = (long long)std::floor(t1 * rate + 1e-7);
  for (long long k = k0; k <= k1; ++k) f(k, double(k) / rate);
}
Eigen::Vector3d normal3(Rng& r) { return {r.normal(), r.normal(), r.normal()}; }
}  // namespace

SensorModel::SensorModel(const Trajectory& trajectory, uint64_t seed, const ImuParams& imu,
                         const GpsParams& gps, const OdometryParams& odo)
    : traj_(&trajectory), seed_(seed), imu_(imu), gps_(gps), odo_(odo) {
  Rng rng(hashKeys(seed, uint64_t(Stream::kBias)));
  gyro_bias_ = normal3(rng) * imu_.gyro_bias_rad_s;
  accel_bias_ = normal3(rng) * imu_.accel_bias_m_s2;
}

ImuSample SensorModel::trueImu(double t) const {
  ImuSample s;
  s.t_s = t;
  const Eigen::Matrix3d R = traj_->pose(t).linear();
  s.gyro_rad_s = traj_->angularVelocityBody(t);
  // Specific force: what an accelerometer at rest reads is +g upwards.
  s.accel_m_s2 = R.transpose() * (traj_->acceleration(t) + Eigen::Vector3d(0, 0, kGravity_m_s2));
  return s;
}

OdometrySample SensorModel::trueOdometry(double t) const {
  OdometrySample s;
  s.t_s = t;
  s.speed_m_s = traj_->speed(t);
  const Eigen::Matrix3d R = traj_->pose(t).linear();
  s.yaw_rate_rad_s = (R * traj_->angularVelocityBody(t)).z();
  return s;
}

std::vector<ImuSample> SensorModel::imu(double t0, double t1) const {
  std::vector<ImuSample> out;
  forSamples(imu_.rate_hz, t0, t1, [&](long long k, double t) {
    ImuSample s = trueImu(t);
    Rng rng(hashKeys(seed_, uint64_t(Stream::kImu), uint64_t(k)));
    s.gyro_rad_s += gyro_bias_ + imu_.gyro_noise_rad_s * normal3(rng);
    s.accel_m_s2 += accel_bias_ + imu_.accel_noise_m_s2 * normal3(rng);
    out.push_back(s);
  });
  return out;
}

std::vector<GpsSample> SensorModel::gps(double t0, double t1) const {
  std::vector<GpsSample> out;
  forSamples(gps_.rate_hz, t0, t1, [&](long long k, double t) {
    Rng rng(hashKeys(seed_, uint64_t(Stream::kGps), uint64_t(k)));
    GpsSample s;
    s.t_s = t;
    s.sigma_m = gps_.sigma_m;
    const Eigen::Vector3d e(rng.normal(), rng.normal(), 1.5 * rng.normal());
    s.position_m = traj_->pose(t).translation() + gps_.sigma_m * e;
    out.push_back(s);
  });
  return out;
}

std::vector<OdometrySample> SensorModel::odometry(double t0, double t1) const {
  std::vector<OdometrySample> out;
  forSamples(odo_.rate_hz, t0, t1, [&](long long k, double t) {
    OdometrySample s = trueOdometry(t);
    Rng rng(hashKeys(seed_, uint64_t(Stream::kOdometry), uint64_t(k)));
    s.speed_m_s = (1.0 + odo_.scale_error) * s.speed_m_s + odo_.speed_noise_m_s * rng.normal();
    s.yaw_rate_rad_s += odo_.yaw_rate_noise_rad_s * rng.normal();
    out.push_back(s);
  });
  return out;
}

}  // namespace terramrf::sim
