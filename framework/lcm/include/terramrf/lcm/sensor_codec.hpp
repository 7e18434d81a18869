#pragma once
// Sensor data ⇄ terramrf_msgs point_cloud_t, image_t, imu_t, gps_t, odometry_t, as encoded
// bytes. LCM-free header (see grid_codec.hpp). Every decode throws InputError (file = `source`)
// on bytes of another type, truncated bytes or inconsistent sizes.
#include <cstddef>
#include <string>

#include "terramrf/frame.hpp"
#include "terramrf/image.hpp"
#include "terramrf/lcm/message_header.hpp"
#include "terramrf/point_cloud.hpp"

namespace terramrf {

/// Rings travel as int16 with the same bit pattern, so kUnknownRing (0xFFFF) is -1 on the wire;
/// a cloud without rings is sent with every ring -1. Per-point times are sent only if present.
/// Throws std::invalid_argument if the attribute arrays differ in length.
MessageBytes encodePointCloud(const PointCloud& cloud, const MessageHeader& header);

struct DecodedPointCloud {
  MessageHeader header;
  PointCloud cloud;  ///< ring always filled (kUnknownRing where unknown); time_s only if sent
};
DecodedPointCloud decodePointCloud(const void* data, std::size_t size,
                                   const std::string& source = "point_cloud_t");

/// 1-channel images go as "mono8", 3-channel as "rgb8". Throws std::invalid_argument for other
/// channel counts or a data size that does not match width × height × channels.
MessageBytes encodeImage(const Image& image, const std::string& camera,
                         const MessageHeader& header);

struct DecodedImage {
  MessageHeader header;  ///< coordinate_frame is not carried by image_t and stays default
  std::string camera;
  Image image;
};
DecodedImage decodeImage(const void* data, std::size_t size, const std::string& source = "image_t");

MessageBytes encodeImu(const ImuSample& sample);
ImuSample decodeImu(const void* data, std::size_t size, const std::string& source = "imu_t");

MessageBytes encodeGps(const GpsSample& sample);
GpsSample decodeGps(const void* data, std::size_t size, const std::string& source = "gps_t");

MessageBytes encodeOdometry(const OdometrySample& sample);
OdometrySample decodeOdometry(const void* data, std::size_t size,
                              const std::string& source = "odometry_t");

}  // namespace terramrf
