#include "terramrf/lcm/sensor_codec.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <terramrf_msgs/gps_t.hpp>
#include <terramrf_msgs/image_t.hpp>
#include <terramrf_msgs/imu_t.hpp>
#include <terramrf_msgs/odometry_t.hpp>
#include <terramrf_msgs/point_cloud_t.hpp>

#include "lcm_bytes.hpp"
#include "terramrf/errors.hpp"

namespace terramrf {

// ---- point cloud --------------------------------------------------------------------------------

MessageBytes encodePointCloud(const PointCloud& cloud, const MessageHeader& header) {
  const std::size_t n = cloud.x.size();
  if (cloud.y.size() != n || cloud.z.size() != n || cloud.intensity.size() != n ||
      (!cloud.ring.empty() && cloud.ring.size() != n) ||
      (!cloud.time_s.empty() && cloud.time_s.size() != n)) {
    throw std::invalid_argument(
        "encodePointCloud: x, y, z, intensity (and ring, time_s when "
        "present) must have the same length");
  }
  if (n > static_cast<std::size_t>(std::numeric_limits<int32_t>::max())) {
    throw std::invalid_argument("encodePointCloud: too many points");
  }
  terramrf_msgs::point_cloud_t m;
  m.utime = toUtime(header.timestamp_s);
  m.frame_id = header.frame_id;
  m.coordinate_frame = header.coordinate_frame;
  m.num_points = static_cast<int32_t>(n);
  m.x = cloud.x;
  m.y = cloud.y;
  m.z = cloud.z;
  m.intensity = cloud.intensity;
  m.ring.resize(n, -1);
  // Same bit pattern: kUnknownRing 0xFFFF <-> -1.
  for (std::size_t i = 0; i < cloud.ring.size(); ++i)
    m.ring[i] = static_cast<int16_t>(cloud.ring[i]);
  m.time = cloud.time_s;
  m.num_times = static_cast<int32_t>(m.time.size());
  return lcm_detail::encodeMessage(m, "point_cloud_t");
}

DecodedPointCloud decodePointCloud(const void* data, std::size_t size, const std::string& source) {
  auto m =
      lcm_detail::decodeMessage<terramrf_msgs::point_cloud_t>(data, size, source, "point_cloud_t");
  if (m.num_points < 0) throw InputError(source, "point_cloud_t: negative num_points");
  if (m.num_times != 0 && m.num_times != m.num_points) {
    throw InputError(source, "point_cloud_t: num_times must be 0 or num_points (" +
                                 std::to_string(m.num_points) + "), got " +
                                 std::to_string(m.num_times));
  }
  DecodedPointCloud out;
  out.header.frame_id = std::move(m.frame_id);
  out.header.coordinate_frame = std::move(m.coordinate_frame);
  out.header.timestamp_s = fromUtime(m.utime);
  PointCloud& c = out.cloud;
  c.x = std::move(m.x);
  c.y = std::move(m.y);
  c.z = std::move(m.z);
  c.intensity = std::move(m.intensity);
  // Every ring -1 is how a cloud without rings is sent (the message has no "absent" form): it
  // comes back without rings, so a stage that needs them says so instead of finding every point
  // "unknown" and computing nothing.
  if (std::any_of(m.ring.begin(), m.ring.end(), [](int16_t r) { return r != -1; })) {
    c.ring.resize(m.ring.size());
    std::transform(m.ring.begin(), m.ring.end(), c.ring.begin(),
                   [](int16_t r) { return static_cast<uint16_t>(r); });
  }
  c.time_s = std::move(m.time);
  return out;
}

// ---- image --------------------------------------------------------------------------------------

MessageBytes encodeImage(const Image& image, const std::string& camera,
                         const MessageHeader& header) {
  if (image.channels != 1 && image.channels != 3) {
    throw std::invalid_argument("encodeImage: camera '" + camera + "' image has " +
                                std::to_string(image.channels) + " channels; expected 1 or 3");
  }
  const std::size_t expected = std::size_t(image.width) * image.height * image.channels;
  if (image.width < 0 || image.height < 0 || image.data.size() != expected ||
      expected > static_cast<std::size_t>(std::numeric_limits<int32_t>::max())) {
    throw std::invalid_argument("encodeImage: camera '" + camera + "' image data has " +
                                std::to_string(image.data.size()) + " bytes, expected " +
                                std::to_string(expected));
  }
  terramrf_msgs::image_t m;
  m.utime = toUtime(header.timestamp_s);
  m.frame_id = header.frame_id;
  m.camera = camera;
  m.width = image.width;
  m.height = image.height;
  m.channels = static_cast<int8_t>(image.channels);
  m.encoding = image.channels == 1 ? "mono8" : "rgb8";
  m.size = static_cast<int32_t>(expected);
  m.data = image.data;
  return lcm_detail::encodeMessage(m, "image_t");
}

DecodedImage decodeImage(const void* data, std::size_t size, const std::string& source) {
  auto m = lcm_detail::decodeMessage<terramrf_msgs::image_t>(data, size, source, "image_t");
  const int expected_channels = m.encoding == "mono8"                            ? 1
                                : (m.encoding == "rgb8" || m.encoding == "bgr8") ? 3
                                                                                 : 0;
  if (expected_channels == 0) {
    throw InputError(source, "image_t: encoding '" + m.encoding +
                                 "' is not supported; expected mono8, rgb8 or bgr8");
  }
  if (m.channels != expected_channels) {
    throw InputError(source, "image_t: encoding " + m.encoding + " needs " +
                                 std::to_string(expected_channels) + " channels, message says " +
                                 std::to_string(m.channels));
  }
  if (m.width < 0 || m.height < 0 ||
      std::size_t(m.size) != std::size_t(m.width) * m.height * m.channels) {
    throw InputError(source, "image_t: " + std::to_string(m.size) + " bytes of data for " +
                                 std::to_string(m.width) + " x " + std::to_string(m.height) +
                                 " x " + std::to_string(m.channels));
  }
  DecodedImage out;
  out.header.frame_id = std::move(m.frame_id);
  out.header.timestamp_s = fromUtime(m.utime);
  out.camera = std::move(m.camera);
  out.image.width = m.width;
  out.image.height = m.height;
  out.image.channels = m.channels;
  out.image.data = std::move(m.data);
  if (m.encoding == "bgr8") {
    for (std::size_t i = 0; i + 2 < out.image.data.size(); i += 3) {
      std::swap(out.image.data[i], out.image.data[i + 2]);
    }
  }
  return out;
}

// ---- IMU, GPS, odometry -------------------------------------------------------------------------

MessageBytes encodeImu(const ImuSample& s) {
  terramrf_msgs::imu_t m;
  m.utime = toUtime(s.t_s);
  for (int i = 0; i < 3; ++i) {
    m.gyro[i] = s.gyro_rad_s[i];
    m.accel[i] = s.accel_m_s2[i];
  }
  return lcm_detail::encodeMessage(m, "imu_t");
}

ImuSample decodeImu(const void* data, std::size_t size, const std::string& source) {
  const auto m = lcm_detail::decodeMessage<terramrf_msgs::imu_t>(data, size, source, "imu_t");
  ImuSample s;
  s.t_s = fromUtime(m.utime);
  s.gyro_rad_s = Eigen::Vector3d(m.gyro[0], m.gyro[1], m.gyro[2]);
  s.accel_m_s2 = Eigen::Vector3d(m.accel[0], m.accel[1], m.accel[2]);
  return s;
}

MessageBytes encodeGps(const GpsSample& s) {
  terramrf_msgs::gps_t m;
  m.utime = toUtime(s.t_s);
  for (int i = 0; i < 3; ++i) m.position[i] = s.position_m[i];
  m.sigma_m = s.sigma_m;
  return lcm_detail::encodeMessage(m, "gps_t");
}

GpsSample decodeGps(const void* data, std::size_t size, const std::string& source) {
  const auto m = lcm_detail::decodeMessage<terramrf_msgs::gps_t>(data, size, source, "gps_t");
  if (!(m.sigma_m > 0)) {
    throw InputError(source, "gps_t: sigma_m must be > 0, got " + std::to_string(m.sigma_m));
  }
  GpsSample s;
  s.t_s = fromUtime(m.utime);
  s.position_m = Eigen::Vector3d(m.position[0], m.position[1], m.position[2]);
  s.sigma_m = m.sigma_m;
  return s;
}

MessageBytes encodeOdometry(const OdometrySample& s) {
  terramrf_msgs::odometry_t m;
  m.utime = toUtime(s.t_s);
  m.speed = s.speed_m_s;
  m.yaw_rate = s.yaw_rate_rad_s;
  return lcm_detail::encodeMessage(m, "odometry_t");
}

OdometrySample decodeOdometry(const void* data, std::size_t size, const std::string& source) {
  const auto m =
      lcm_detail::decodeMessage<terramrf_msgs::odometry_t>(data, size, source, "odometry_t");
  OdometrySample s;
  s.t_s = fromUtime(m.utime);
  s.speed_m_s = m.speed;
  s.yaw_rate_rad_s = m.yaw_rate;
  return s;
}

}  // namespace terramrf
