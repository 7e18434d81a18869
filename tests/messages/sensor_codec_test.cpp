#include "terramrf/lcm/sensor_codec.hpp"

#include <gtest/gtest.h>

#include <terramrf_msgs/image_t.hpp>
#include <terramrf_msgs/point_cloud_t.hpp>

#include "terramrf/errors.hpp"

namespace terramrf {
namespace {

template <class Msg>
MessageBytes encodeRaw(const Msg& m) {
  MessageBytes b(m.getEncodedSize());
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

TEST(PointCloudCodec, RoundTripWithRingsAndTimes) {
  PointCloud c;
  c.push_back(1.f, -2.f, 0.5f, 0.01f, 0);
  c.push_back(3.5f, 4.f, -1.f, 0.2f, 63);
  c.push_back(-7.f, 0.f, 2.f, 0.f, kUnknownRing);
  c.time_s = {0.f, 0.05f, 0.099f};
  const MessageBytes b = encodePointCloud(c, {"000003", "lidar", 2.0});

  terramrf_msgs::point_cloud_t m;
  ASSERT_GT(m.decode(b.data(), 0, static_cast<int>(b.size())), 0);
  EXPECT_EQ(m.num_points, 3);
  EXPECT_EQ(m.ring, (std::vector<int16_t>{0, 63, -1}));  // unknown ring is -1 on the wire
  EXPECT_EQ(m.num_times, 3);
  EXPECT_EQ(m.utime, 2000000);

  const DecodedPointCloud d = decodePointCloud(b.data(), b.size());
  EXPECT_EQ(d.header.frame_id, "000003");
  EXPECT_DOUBLE_EQ(d.header.timestamp_s, 2.0);
  EXPECT_EQ(d.cloud.x, c.x);
  EXPECT_EQ(d.cloud.y, c.y);
  EXPECT_EQ(d.cloud.z, c.z);
  EXPECT_EQ(d.cloud.intensity, c.intensity);
  EXPECT_EQ(d.cloud.ring, c.ring);
  EXPECT_EQ(d.cloud.time_s, c.time_s);
}

TEST(PointCloudCodec, CloudWithoutRingsOrTimes) {
  PointCloud c;
  c.x = {1.f, 2.f};
  c.y = {0.f, 0.f};
  c.z = {0.f, 0.f};
  c.intensity = {0.f, 0.f};
  const MessageBytes b = encodePointCloud(c, {});
  const DecodedPointCloud d = decodePointCloud(b.data(), b.size());
  // Sent as -1 each, received as no rings (not as rings all unknown, which made roughness skip
  // every point instead of saying the scan has none).
  EXPECT_FALSE(d.cloud.hasRing());
  EXPECT_FALSE(d.cloud.hasTime());
  // Some rings known: the unknown ones stay unknown.
  c.ring = {kUnknownRing, 3};
  EXPECT_EQ(
      decodePointCloud(encodePointCloud(c, {}).data(), encodePointCloud(c, {}).size()).cloud.ring,
      (std::vector<uint16_t>{kUnknownRing, 3}));
  c.ring.clear();
  c.z.pop_back();
  EXPECT_THROW(encodePointCloud(c, {}), std::invalid_argument);
  // Empty cloud is a valid message.
  EXPECT_TRUE(decodePointCloud(encodePointCloud(PointCloud{}, {}).data(),
                               encodePointCloud(PointCloud{}, {}).size())
                  .cloud.empty());
}

TEST(PointCloudCodec, RejectsTimesOfWrongLength) {
  terramrf_msgs::point_cloud_t m{};
  m.num_points = 1;
  m.x = m.y = m.z = m.intensity = {0.f};
  m.ring = {0};
  m.num_times = 2;
  m.time = {0.f, 0.f};
  const MessageBytes b = encodeRaw(m);
  EXPECT_THROW(decodePointCloud(b.data(), b.size(), "PTS"), InputError);
}

// Lengths that lcm-gen 1.3's decoders trusted (messages/harden_decoders.cmake): a string length
// of 0 read SIZE_MAX bytes (SIGSEGV, found by fuzzing a damaged log), a negative one moved the
// read position back, and a huge point count allocated before the buffer was checked. Each is
// now an InputError naming the source.
TEST(PointCloudCodec, MalformedLengthsAreErrorsNotCrashes) {
  PointCloud c;
  c.push_back(1, 2, 3, 4, 5);
  const MessageBytes good = encodePointCloud(c, {"a", "lidar", 0});
  // hash (8), utime (8), frame_id: length (4) = 2, "a\0"; coordinate_frame: length (4) = 6,
  // "lidar\0"; num_points (4).
  auto withInt32 = [&](std::size_t at, std::int32_t v) {
    MessageBytes b = good;
    for (int k = 0; k < 4; ++k) b[at + k] = static_cast<std::uint8_t>(std::uint32_t(v) >> (24 - 8 * k));
    return b;
  };
  ASSERT_EQ(good[19], 2);
  ASSERT_EQ(good[35], 1);
  for (const auto& [at, v] : std::vector<std::pair<std::size_t, std::int32_t>>{
           {16, 0}, {16, -7}, {22, 0}, {32, -1}, {32, 0x7fffffff}}) {
    const MessageBytes b = withInt32(at, v);
    try {
      decodePointCloud(b.data(), b.size(), "log event 3 (PTS)");
      ADD_FAILURE() << "decoded with " << v << " at byte " << at;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("log event 3 (PTS)"), std::string::npos) << e.what();
    }
  }
}

TEST(ImageCodec, RoundTripRgbAndMono) {
  Image rgb(3, 2, 3);
  for (std::size_t i = 0; i < rgb.data.size(); ++i) rgb.data[i] = static_cast<uint8_t>(i * 7);
  const MessageBytes b = encodeImage(rgb, "image_2", {"000001", "", 0.25});
  const DecodedImage d = decodeImage(b.data(), b.size());
  EXPECT_EQ(d.camera, "image_2");
  EXPECT_EQ(d.header.frame_id, "000001");
  EXPECT_EQ(d.image.width, 3);
  EXPECT_EQ(d.image.height, 2);
  EXPECT_EQ(d.image.channels, 3);
  EXPECT_EQ(d.image.data, rgb.data);

  terramrf_msgs::image_t m;
  ASSERT_GT(m.decode(b.data(), 0, static_cast<int>(b.size())), 0);
  EXPECT_EQ(m.encoding, "rgb8");

  Image mono(2, 2, 1);
  mono.data = {1, 2, 3, 4};
  const MessageBytes bm = encodeImage(mono, "truth", {});
  EXPECT_EQ(decodeImage(bm.data(), bm.size()).image.data, mono.data);
  Image bad(2, 2, 4);
  EXPECT_THROW(encodeImage(bad, "x", {}), std::invalid_argument);
}

TEST(ImageCodec, Bgr8IsConvertedAndUnknownEncodingRejected) {
  terramrf_msgs::image_t m{};
  m.width = 1;
  m.height = 1;
  m.channels = 3;
  m.encoding = "bgr8";
  m.size = 3;
  m.data = {10, 20, 30};
  MessageBytes b = encodeRaw(m);
  EXPECT_EQ(decodeImage(b.data(), b.size()).image.data, (std::vector<uint8_t>{30, 20, 10}));
  m.encoding = "jpeg";
  b = encodeRaw(m);
  try {
    decodeImage(b.data(), b.size(), "CAM");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("jpeg"), std::string::npos);
  }
  m.encoding = "rgb8";
  m.width = 2;  // 3 bytes for 2 x 1 x 3
  b = encodeRaw(m);
  EXPECT_THROW(decodeImage(b.data(), b.size()), InputError);
  m.width = 3;
  m.channels = 1;  // 3 bytes for 3 x 1 x 1, but rgb8 has three channels
  b = encodeRaw(m);
  try {
    decodeImage(b.data(), b.size(), "CAM");
    FAIL() << "rgb8 with one channel was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("image_t: encoding rgb8 needs 3 channels, message says 1"),
              std::string::npos)
        << e.what();
  }
}

TEST(SampleCodecs, ImuGpsOdometryRoundTrip) {
  ImuSample imu;
  imu.t_s = 100.000001;
  imu.gyro_rad_s = {0.1, -0.2, 0.3};
  imu.accel_m_s2 = {0.0, 0.5, 9.81};
  const MessageBytes bi = encodeImu(imu);
  const ImuSample i2 = decodeImu(bi.data(), bi.size());
  EXPECT_NEAR(i2.t_s, imu.t_s, 1e-9);
  EXPECT_EQ(i2.gyro_rad_s, imu.gyro_rad_s);
  EXPECT_EQ(i2.accel_m_s2, imu.accel_m_s2);

  GpsSample gps;
  gps.t_s = 3;
  gps.position_m = {10, -20, 1.5};
  gps.sigma_m = 2.5;
  const MessageBytes bg = encodeGps(gps);
  const GpsSample g2 = decodeGps(bg.data(), bg.size());
  EXPECT_EQ(g2.position_m, gps.position_m);
  EXPECT_EQ(g2.sigma_m, 2.5);
  gps.sigma_m = 0;
  const MessageBytes bad = encodeGps(gps);
  EXPECT_THROW(decodeGps(bad.data(), bad.size()), InputError);

  OdometrySample o;
  o.t_s = 4;
  o.speed_m_s = 3.25;
  o.yaw_rate_rad_s = -0.125;
  const MessageBytes bo = encodeOdometry(o);
  const OdometrySample o2 = decodeOdometry(bo.data(), bo.size());
  EXPECT_EQ(o2.speed_m_s, 3.25);
  EXPECT_EQ(o2.yaw_rate_rad_s, -0.125);
  EXPECT_DOUBLE_EQ(o2.t_s, 4.0);
  // Bytes of one type are refused by another's decoder.
  EXPECT_THROW(decodeImu(bo.data(), bo.size()), InputError);
}

}  // namespace
}  // namespace terramrf
