#include "terramrf/sim/trajectory.hpp"

#include <algorithm>
#include <cmath>

namespace terramrf::sim {

namespace {
constexpr double kTwoPi = 6.283185307179586;
// 5-point Gauss–Legendre nodes/weights on [-1, 1].
constexpr double kGlX[5] = {-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831,
                            0.9061798459386640};
constexpr double kGlW[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889,
                            0.4786286704993665, 0.2369268850561891};
}  // namespace

Trajectory::Trajectory(const World& world, const TrajectoryParams& params)
    : world_(&world), p_(params) {
  const WorldParams& wp = world.params();
  // Arc-length nodes every node_dx_ on a lattice anchored at the start, integrated outwards from
  // it: the same start gives bit-identical poses whatever the world's extent.
  const double sx = std::clamp(p_.start_x_m, wp.x_min_m, wp.x_max_m);
  const int back = int(std::floor((sx - wp.x_min_m) / node_dx_));
  const int ahead = int(std::floor((wp.x_max_m - sx) / node_dx_));
  node_start_ = back;
  node_x0_ = sx;
  node_s_.assign(back + ahead + 1, 0.0);
  for (int i = back + 1; i < int(node_s_.size()); ++i)
    node_s_[i] = node_s_[i - 1] + arcFromNode(i - 1, nodeX(i));
  for (int i = back - 1; i >= 0; --i) node_s_[i] = node_s_[i + 1] - arcFromNode(i, nodeX(i + 1));
  // Leave 1 m of margin before the table's end; bisection on the monotonic distance().
  const double s_end = node_s_.back() - 1.0;
  double lo = 0, hi = 1;
  while (distance(hi) < s_end && hi < 1e7) hi *= 2;
  for (int it = 0; it < 60; ++it) {
    const double m = 0.5 * (lo + hi);
    (distance(m) < s_end ? lo : hi) = m;
  }
  end_time_s_ = lo;
}

double Trajectory::nodeX(int i) const { return node_x0_ + double(i - node_start_) * node_dx_; }

Eigen::Vector2d Trajectory::pathPoint(double x) const {
  const double s = world_->roadCentreSlope(x), inv = 1.0 / std::sqrt(1.0 + s * s);
  return {x - p_.lane_offset_m * s * inv, world_->roadCentreY(x) + p_.lane_offset_m * inv};
}

double Trajectory::pathSpeed(double x) const {
  // 3D: the wheels roll along the road surface, so distance includes the climb.
  constexpr double h = 1e-3;
  const Eigen::Vector2d a = pathPoint(x - h), b = pathPoint(x + h);
  return Eigen::Vector3d(b.x() - a.x(), b.y() - a.y(), roadZ(b) - roadZ(a)).norm() / (2 * h);
}

double Trajectory::arcFromNode(int node, double x) const {
  const double a = nodeX(node);
  const double half = 0.5 * (x - a), mid = 0.5 * (x + a);
  double s = 0;
  for (int k = 0; k < 5; ++k) s += kGlW[k] * pathSpeed(mid + half * kGlX[k]);
  return s * half;
}

double Trajectory::xAtArc(double s) const {
  const int n = int(node_s_.size());
  int k = int(std::upper_bound(node_s_.begin(), node_s_.end(), s) - node_s_.begin()) - 1;
  k = std::clamp(k, 0, n - 2);
  const double a = nodeX(k);
  double x = a + node_dx_ * (s - node_s_[k]) / std::max(1e-9, node_s_[k + 1] - node_s_[k]);
  for (int it = 0; it < 8; ++it) {
    const double f = node_s_[k] + arcFromNode(k, x) - s;
    x -= f / pathSpeed(x);
    if (std::abs(f) < 1e-11) break;
  }
  return x;
}

double Trajectory::speed(double t) const {
  return p_.speed_m_s * (1.0 + p_.speed_variation * std::sin(kTwoPi * t / p_.speed_period_s));
}

double Trajectory::distance(double t) const {
  const double w = kTwoPi / p_.speed_period_s;
  return p_.speed_m_s * (t + p_.speed_variation / w * (1.0 - std::cos(w * t)));
}

double Trajectory::roadZ(const Eigen::Vector2d& p) const {
  return world_->smoothHeight(p.x(), p.y());
}

Eigen::Isometry3d Trajectory::pose(double t) const {
  const double x = xAtArc(distance(t));
  const Eigen::Vector2d p = pathPoint(x);
  constexpr double h = 1e-3;
  const Eigen::Vector2d pa = pathPoint(x - h), pb = pathPoint(x + h);
  const Eigen::Vector3d fwd =
      Eigen::Vector3d(pb.x() - pa.x(), pb.y() - pa.y(), roadZ(pb) - roadZ(pa)).normalized();
  const Eigen::Vector3d left = Eigen::Vector3d::UnitZ().cross(fwd).normalized();
  const Eigen::Vector3d up = fwd.cross(left);
  Eigen::Matrix3d R;
  R << fwd, left, up;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = Eigen::Vector3d(p.x(), p.y(), roadZ(p)) + p_.sensor_height_m * up;
  return T;
}

Eigen::Vector3d Trajectory::velocity(double t) const {
  constexpr double h = 1e-3;
  return (pose(t + h).translation() - pose(t - h).translation()) / (2 * h);
}

Eigen::Vector3d Trajectory::acceleration(double t) const {
  constexpr double h = 5e-3;
  return (pose(t + h).translation() - 2 * pose(t).translation() + pose(t - h).translation()) /
         (h * h);
}

Eigen::Vector3d Trajectory::angularVelocityBody(double t) const {
  constexpr double h = 2e-3;
  const Eigen::AngleAxisd aa(pose(t - h).linear().transpose() * pose(t + h).linear());
  return aa.axis() * aa.angle() / (2 * h);
}

}  // namespace terramrf::sim
