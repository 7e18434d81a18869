#pragma once
// Rigid pose with optional covariance ⇄ terramrf_msgs::pose_t. LCM-free header.
#include <Eigen/Geometry>
#include <cstddef>
#include <optional>
#include <string>

#include "terramrf/lcm/message_header.hpp"

namespace terramrf {

struct PoseMessage {
  MessageHeader header;  ///< coordinate_frame = parent frame (e.g. "world")
  std::string child_frame = "lidar";
  /// Maps child-frame points into the parent frame (e.g. Frame::pose). Its rotation travels as a
  /// unit quaternion (w, x, y, z).
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  /// Over (x, y, z, roll, pitch, yaw) [m², rad²], when known.
  std::optional<Eigen::Matrix<double, 6, 6>> covariance;
};

MessageBytes encodePose(const PoseMessage& pose);
/// Throws InputError (file = `source`) on foreign or truncated bytes, a non-finite position or a
/// quaternion that is far from unit length (|q| outside [0.9, 1.1]); near-unit ones are
/// normalised.
PoseMessage decodePose(const void* data, std::size_t size, const std::string& source = "pose_t");

}  // namespace terramrf
