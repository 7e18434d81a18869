#pragma once
// What a terramrf_msgs message is and which scan it belongs to, read from its first bytes
// without decoding it: enough to index a log of large messages. LCM-free header.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

namespace terramrf {

struct MessageStamp {
  std::string type;        ///< e.g. "point_cloud_t"
  std::int64_t utime = 0;  ///< the message's own time [µs]
  /// Scan id; empty for the types that carry none (imu_t, gps_t, odometry_t).
  std::string frame_id;
  /// The camera's name, for image_t and camera_info_t; empty for the other types.
  std::string camera;
};

/// nullopt if the bytes are not one of the terramrf_msgs types (by fingerprint) or are too short
/// for its time and scan id. Every type starts with `utime`, and those tied to a scan carry
/// `frame_id` right after it (messages/*.lcm), so the rest of the message is not read: a message
/// damaged further on still fails when it is decoded.
std::optional<MessageStamp> peekMessageStamp(const void* data, std::size_t size);

/// True if the bytes start with the fingerprint of one of the terramrf_msgs types (8 bytes are
/// enough): peekMessageStamp may then need more of the message, never otherwise.
bool knownMessageType(const void* data, std::size_t size);

}  // namespace terramrf
