#include "terramrf/lcm/message_peek.hpp"

#include <terramrf_msgs/camera_info_t.hpp>
#include <terramrf_msgs/gps_t.hpp>
#include <terramrf_msgs/image_t.hpp>
#include <terramrf_msgs/imu_t.hpp>
#include <terramrf_msgs/layer_origins_t.hpp>
#include <terramrf_msgs/odometry_t.hpp>
#include <terramrf_msgs/point_cloud_t.hpp>
#include <terramrf_msgs/point_labels_t.hpp>
#include <terramrf_msgs/pose_t.hpp>
#include <terramrf_msgs/terrain_grid_t.hpp>
#include <vector>

namespace terramrf {
namespace {

struct Known {
  std::int64_t hash;
  const char* name;
  bool has_frame_id;
};

template <class Msg>
Known known(const char* name, bool has_frame_id) {
  return {Msg::getHash(), name, has_frame_id};
}

// LCM encodes integers big-endian.
std::uint64_t readBigEndian(const std::uint8_t* p, int bytes) {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | p[i];
  return v;
}

}  // namespace

static const std::vector<Known>& knownTypes() {
  static const std::vector<Known> kKnown = {
      known<terramrf_msgs::point_cloud_t>("point_cloud_t", true),
      known<terramrf_msgs::point_labels_t>("point_labels_t", true),
      known<terramrf_msgs::pose_t>("pose_t", true),
      known<terramrf_msgs::image_t>("image_t", true),
      known<terramrf_msgs::camera_info_t>("camera_info_t", true),
      known<terramrf_msgs::terrain_grid_t>("terrain_grid_t", true),
      known<terramrf_msgs::layer_origins_t>("layer_origins_t", true),
      known<terramrf_msgs::imu_t>("imu_t", false),
      known<terramrf_msgs::gps_t>("gps_t", false),
      known<terramrf_msgs::odometry_t>("odometry_t", false),
  };
  return kKnown;
}

bool knownMessageType(const void* data, std::size_t size) {
  if (!data || size < 8) return false;
  const auto hash =
      static_cast<std::int64_t>(readBigEndian(static_cast<const std::uint8_t*>(data), 8));
  for (const Known& k : knownTypes())
    if (k.hash == hash) return true;
  return false;
}

std::optional<MessageStamp> peekMessageStamp(const void* data, std::size_t size) {
  const auto* p = static_cast<const std::uint8_t*>(data);
  if (!p || size < 16) return std::nullopt;
  const auto hash = static_cast<std::int64_t>(readBigEndian(p, 8));
  for (const Known& k : knownTypes()) {
    if (k.hash != hash) continue;
    MessageStamp s;
    s.type = k.name;
    s.utime = static_cast<std::int64_t>(readBigEndian(p + 8, 8));
    if (!k.has_frame_id) return s;
    // An LCM string: int32 length counting the terminating NUL, then the bytes and the NUL.
    if (size < 20) return std::nullopt;
    const auto len = static_cast<std::int32_t>(readBigEndian(p + 16, 4));
    if (len < 1 || static_cast<std::size_t>(len) > size - 20 || p[20 + len - 1] != 0)
      return std::nullopt;
    s.frame_id.assign(reinterpret_cast<const char*>(p + 20), static_cast<std::size_t>(len - 1));
    if (s.type == "image_t" || s.type == "camera_info_t") {
      // Both carry the camera's name right after the scan id. One that cannot be read leaves
      // `camera` empty: the message is still this type's, and decoding it says what is wrong.
      const std::size_t at = 20 + static_cast<std::size_t>(len);
      if (size >= at + 4) {
        const auto clen = static_cast<std::int32_t>(readBigEndian(p + at, 4));
        if (clen >= 1 && static_cast<std::size_t>(clen) <= size - at - 4 &&
            p[at + 4 + clen - 1] == 0)
          s.camera.assign(reinterpret_cast<const char*>(p + at + 4),
                          static_cast<std::size_t>(clen - 1));
      }
    }
    return s;
  }
  return std::nullopt;
}

}  // namespace terramrf
