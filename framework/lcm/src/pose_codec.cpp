#include "terramrf/lcm/pose_codec.hpp"

#include <cmath>
#include <terramrf_msgs/pose_t.hpp>

#include "lcm_bytes.hpp"
#include "terramrf/errors.hpp"

namespace terramrf {

MessageBytes encodePose(const PoseMessage& p) {
  terramrf_msgs::pose_t m;
  m.utime = toUtime(p.header.timestamp_s);
  m.frame_id = p.header.frame_id;
  m.coordinate_frame = p.header.coordinate_frame;
  m.child_frame = p.child_frame;
  const Eigen::Vector3d t = p.pose.translation();
  // rotation() (polar decomposition) rather than linear() so a slightly non-orthonormal matrix
  // still gives a unit quaternion.
  const Eigen::Quaterniond q = Eigen::Quaterniond(p.pose.rotation()).normalized();
  for (int i = 0; i < 3; ++i) m.position[i] = t[i];
  m.orientation[0] = q.w();
  m.orientation[1] = q.x();
  m.orientation[2] = q.y();
  m.orientation[3] = q.z();
  if (p.covariance) {
    m.covariance.resize(36);
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) m.covariance[r * 6 + c] = (*p.covariance)(r, c);
  }
  m.num_covariance = static_cast<int8_t>(m.covariance.size());
  return lcm_detail::encodeMessage(m, "pose_t");
}

PoseMessage decodePose(const void* data, std::size_t size, const std::string& source) {
  const auto m = lcm_detail::decodeMessage<terramrf_msgs::pose_t>(data, size, source, "pose_t");
  if (m.num_covariance != 0 && m.num_covariance != 36) {
    throw InputError(
        source, "pose_t: num_covariance must be 0 or 36, got " + std::to_string(m.num_covariance));
  }
  const Eigen::Vector3d t(m.position[0], m.position[1], m.position[2]);
  Eigen::Quaterniond q(m.orientation[0], m.orientation[1], m.orientation[2], m.orientation[3]);
  const double norm = q.norm();
  if (!t.allFinite() || !std::isfinite(norm) || norm < 0.9 || norm > 1.1) {
    throw InputError(source,
                     "pose_t: position must be finite and orientation a unit quaternion "
                     "(w, x, y, z); |q| = " +
                         std::to_string(norm));
  }
  q.normalize();
  PoseMessage p;
  p.header.frame_id = m.frame_id;
  p.header.coordinate_frame = m.coordinate_frame;
  p.header.timestamp_s = fromUtime(m.utime);
  p.child_frame = m.child_frame;
  p.pose = Eigen::Isometry3d::Identity();
  p.pose.linear() = q.toRotationMatrix();
  p.pose.translation() = t;
  if (m.num_covariance == 36) {
    Eigen::Matrix<double, 6, 6> cov;
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) cov(r, c) = m.covariance[r * 6 + c];
    p.covariance = cov;
  }
  return p;
}

std::optional<PoseMessage> framePoseMessage(const Frame& frame) {
  if (!frame.pose) return std::nullopt;
  PoseMessage m;
  m.header = {frame.id, "world", frame.timestamp_s};
  m.child_frame = "lidar";
  m.pose = *frame.pose;
  m.covariance = frame.pose_covariance;
  return m;
}

void setFramePose(Frame& frame, const PoseMessage& pose, const std::string& source) {
  if (pose.child_frame != "lidar")
    throw InputError(source, "pose_t: child_frame is '" + pose.child_frame +
                                 "'; a scan's pose is the LiDAR's (child_frame \"lidar\")");
  frame.pose = pose.pose;
  frame.pose_covariance = pose.covariance;
}

}  // namespace terramrf
