// Trajectory, IMU, GPS and wheel odometry against the ground truth they are derived from.
#include "terramrf/sim/sensors.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "terramrf/sim/trajectory.hpp"
#include "terramrf/sim/world.hpp"

namespace terramrf::sim {
namespace {

struct Rig {
  World world;
  Trajectory traj;
  SensorModel sensors;
  Rig()
      : world([] {
          WorldParams p;
          p.seed = 3;
          p.x_min_m = -130;
          p.x_max_m = 400;
          p.terrain_half_width_m = 140;
          return p;
        }()),
        traj(world, TrajectoryParams{}),
        sensors(traj, 3, ImuParams{}, GpsParams{}, OdometryParams{}) {}
};

const Rig& rig() {
  static const Rig r;
  return r;
}

double yaw(const Eigen::Isometry3d& T) { return std::atan2(T.linear()(1, 0), T.linear()(0, 0)); }

TEST(SimTrajectory, DrivesTheRightLaneAtTheConfiguredSpeed) {
  const Rig& r = rig();
  EXPECT_GT(r.traj.endTime(), 25.0);
  for (double t = 0; t < 25; t += 0.7) {
    const Eigen::Isometry3d T = r.traj.pose(t);
    const Eigen::Vector3d p = T.translation();
    // Lane centre (3.25 m lane, right of the centre line) and mounting height.
    const Eigen::Vector3d base = p - 1.73 * T.linear().col(2);
    EXPECT_NEAR(r.world.lateralOffset(base.x(), base.y()), -1.625, 0.02) << t;
    EXPECT_NEAR(base.z(), r.world.terrainHeight(base.x(), base.y()), 0.01) << t;
    EXPECT_NEAR(p.z() - r.world.terrainHeight(p.x(), p.y()), 1.73, 0.05) << t;
    // Speed 9 m/s ± 8 % on the road surface, matching the derivative of the poses.
    auto baseAt = [&](double tt) {
      const Eigen::Isometry3d B = r.traj.pose(tt);
      return Eigen::Vector3d(B.translation() - 1.73 * B.linear().col(2));
    };
    const double v = (baseAt(t + 0.005) - baseAt(t - 0.005)).norm() / 0.01;
    EXPECT_NEAR(v, r.traj.speed(t), 0.01);
    EXPECT_GT(v, 9 * 0.91);
    EXPECT_LT(v, 9 * 1.09);
    // No roll; heading follows the motion.
    EXPECT_NEAR(T.linear()(2, 1), 0.0, 1e-9);
    const Eigen::Vector3d vel = r.traj.velocity(t);
    EXPECT_GT(vel.normalized().dot(T.linear().col(0)), 0.9999);
  }
}

TEST(SimSensors, ImuMatchesTruthWithConfiguredNoiseAndBias) {
  const Rig& r = rig();
  const std::vector<ImuSample> s = r.sensors.imu(0.0, 20.0);
  ASSERT_EQ(s.size(), 2000u);  // 100 Hz
  Eigen::Vector3d gm = Eigen::Vector3d::Zero(), am = Eigen::Vector3d::Zero();
  Eigen::Vector3d g2 = Eigen::Vector3d::Zero(), a2 = Eigen::Vector3d::Zero();
  for (const ImuSample& m : s) {
    const ImuSample t = r.sensors.trueImu(m.t_s);
    const Eigen::Vector3d eg = m.gyro_rad_s - t.gyro_rad_s, ea = m.accel_m_s2 - t.accel_m_s2;
    gm += eg;
    am += ea;
    g2 += eg.cwiseProduct(eg);
    a2 += ea.cwiseProduct(ea);
  }
  const double n = double(s.size());
  gm /= n;
  am /= n;
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(gm[k], r.sensors.gyroBias()[k], 3 * 0.002 / std::sqrt(n));
    EXPECT_NEAR(am[k], r.sensors.accelBias()[k], 3 * 0.05 / std::sqrt(n));
    EXPECT_NEAR(std::sqrt(g2[k] / n - gm[k] * gm[k]), 0.002, 0.0003);
    EXPECT_NEAR(std::sqrt(a2[k] / n - am[k] * am[k]), 0.05, 0.006);
  }
  EXPECT_GT(r.sensors.gyroBias().norm(), 0.0);
  // Truth is physical: at ~constant speed on gentle terrain the accelerometer reads ~+g up, and
  // the gyro's yaw rate matches the heading change of the poses.
  const ImuSample t5 = r.sensors.trueImu(5.0);
  EXPECT_NEAR(t5.accel_m_s2.z(), 9.81, 0.5);
  const double dyaw = yaw(r.traj.pose(5.05)) - yaw(r.traj.pose(4.95));
  EXPECT_NEAR((r.traj.pose(5.0).linear() * t5.gyro_rad_s).z(), dyaw / 0.1, 1e-3);
  // Forward specific force = d(speed)/dt + g·(forward axis)_z (uphill adds gravity).
  const double dv = (r.traj.speed(5.01) - r.traj.speed(4.99)) / 0.02;
  const double fwd_z = r.traj.pose(5.0).linear()(2, 0);
  EXPECT_NEAR(t5.accel_m_s2.x(), dv + 9.80665 * fwd_z, 0.1);
}

TEST(SimSensors, GpsAndOdometry) {
  const Rig& r = rig();
  const std::vector<GpsSample> g = r.sensors.gps(0.0, 25.0);
  ASSERT_EQ(g.size(), 50u);  // 2 Hz
  double ex = 0, ey = 0;
  for (const GpsSample& s : g) {
    const Eigen::Vector3d e = s.position_m - r.traj.pose(s.t_s).translation();
    ex += e.x() * e.x();
    ey += e.y() * e.y();
    EXPECT_EQ(s.sigma_m, 1.5);
    EXPECT_LT(e.head<2>().norm(), 8.0);
  }
  const double sigma = std::sqrt((ex + ey) / (2 * g.size()));
  EXPECT_GT(sigma, 1.0);
  EXPECT_LT(sigma, 2.1);
  const std::vector<OdometrySample> o = r.sensors.odometry(0.0, 25.0);
  ASSERT_EQ(o.size(), 500u);  // 20 Hz
  double ratio = 0;
  for (const OdometrySample& s : o) {
    ratio += s.speed_m_s / r.traj.speed(s.t_s);
    EXPECT_NEAR(s.yaw_rate_rad_s, r.sensors.trueOdometry(s.t_s).yaw_rate_rad_s, 0.03);
  }
  EXPECT_NEAR(ratio / o.size(), 1.02, 0.002) << "scale error";
}

TEST(SimSensors, SamplesPartitionTimeAndAreOrderIndependent) {
  const Rig& r = rig();
  std::size_t total = 0;
  for (int i = 0; i < 30; ++i) {
    const double t0 = (i - 1) / 10.0, t1 = i / 10.0;
    const auto s = r.sensors.imu(t0, t1);
    EXPECT_EQ(s.size(), 10u);
    for (const auto& m : s) {
      EXPECT_GT(m.t_s, t0 + 1e-9);
      EXPECT_LE(m.t_s, t1 + 1e-9);
    }
    total += r.sensors.gps(t0, t1).size();
  }
  EXPECT_EQ(total, 6u);  // 2 Hz over (−0.1, 2.9] s
  const auto a = r.sensors.imu(0.4, 0.5), b = r.sensors.imu(0.4, 0.5);
  EXPECT_EQ(a.back().gyro_rad_s, b.back().gyro_rad_s);
  EXPECT_EQ(a.back().accel_m_s2, r.sensors.imu(0.0, 0.5).back().accel_m_s2);
}

}  // namespace
}  // namespace terramrf::sim
