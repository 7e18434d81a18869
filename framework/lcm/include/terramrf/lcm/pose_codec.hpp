#pragma once
// Rigid pose with optional covariance ⇄ terramrf_msgs::pose_t. LCM-free header.
#include <Eigen/Geometry>
#include <cstddef>
#include <optional>
#include <string>

#include "terramrf/frame.hpp"
#include "terramrf/lcm/message_header.hpp"

namespace terramrf {

struct PoseMessage {
  MessageHeader header;  ///< coordinate_frame = parent frame (e.g. "world")
  std::string child_frame = "lidar";
  /// Maps child-frame points into the parent frame (e.g. Frame::pose). Its rotation travels as a
  /// unit quaternion (w, x, y, z).
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  /// Over (x, y, z, roll, pitch, yaw) in the parent frame's axes [m², rad², m·rad], when known:
  /// the convention of Frame::pose_covariance, so the two map one to one.
  std::optional<Eigen::Matrix<double, 6, 6>> covariance;
};

MessageBytes encodePose(const PoseMessage& pose);
/// Throws InputError (file = `source`) on foreign or truncated bytes, a non-finite position or a
/// quaternion that is far from unit length (|q| outside [0.9, 1.1]); near-unit ones are
/// normalised.
PoseMessage decodePose(const void* data, std::size_t size, const std::string& source = "pose_t");

/// Frame::pose with Frame::pose_covariance as a message: child "lidar" in "world", tied to the
/// scan by its id and time. nullopt when the frame has no pose. Frame::truth_pose is not sent:
/// pose_t has one pose, and the scan's pose is the one the pipeline used.
std::optional<PoseMessage> framePoseMessage(const Frame& frame);

/// Sets Frame::pose and Frame::pose_covariance from `pose` (the covariance cleared when the
/// message has none: one left from an earlier pose would belong to another). Frame::truth_pose
/// is left as it is. Throws InputError (file = `source`) unless the message's child frame is
/// "lidar": Frame::pose is the LiDAR's.
void setFramePose(Frame& frame, const PoseMessage& pose, const std::string& source = "pose_t");

}  // namespace terramrf
