#include "terramrf/lcm/camera_codec.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <terramrf_msgs/camera_info_t.hpp>

#include "terramrf/errors.hpp"
#include "terramrf/lcm/message_peek.hpp"
#include "terramrf/lcm/sensor_codec.hpp"

namespace terramrf {
namespace {

CameraModel someCamera() {
  CameraModel c;
  c.name = "image_2";
  c.width = 1242;
  c.height = 375;
  c.P << 721.5377, 0, 609.5593, 44.85728, 0, 721.5377, 172.854, 0.2163791, 0, 0, 1, 0.002745884;
  c.distortion = {0.1, -0.2, 0.001, 0.002, 0.03};
  c.T_camera_lidar = Eigen::Translation3d(0.27, -0.08, -0.06) *
                     Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 0.9, -0.4).normalized());
  c.calibration = "calib/000000.txt (P2, R0_rect, Tr_velo_to_cam)";
  return c;
}

// Every number to the bit: a replayed scan projects its points to the same pixels.
TEST(CameraCodec, RoundTripIsExact) {
  const CameraModel c = someCamera();
  const MessageBytes b = encodeCameraInfo(c, {"000007", "lidar", 0.7});
  const DecodedCameraInfo d = decodeCameraInfo(b.data(), b.size());
  EXPECT_EQ(d.header.frame_id, "000007");
  EXPECT_EQ(d.model.name, "image_2");
  EXPECT_EQ(d.model.width, 1242);
  EXPECT_EQ(d.model.height, 375);
  EXPECT_EQ(d.model.P, c.P);
  EXPECT_EQ(d.model.distortion, c.distortion);
  EXPECT_EQ(d.model.T_camera_lidar.matrix(), c.T_camera_lidar.matrix());
  EXPECT_EQ(d.model.calibration, c.calibration);
  const auto stamp = peekMessageStamp(b.data(), b.size());
  ASSERT_TRUE(stamp);
  EXPECT_EQ(stamp->type, "camera_info_t");
  EXPECT_EQ(stamp->frame_id, "000007");
  EXPECT_EQ(stamp->camera, "image_2");
}

TEST(CameraCodec, PeekNamesTheCameraOfAnImage) {
  Image img;
  img.width = 2;
  img.height = 1;
  img.channels = 3;
  img.data.assign(6, 7);
  const MessageBytes b = encodeImage(img, "left", {"9", "lidar", 0});
  const auto stamp = peekMessageStamp(b.data(), b.size());
  ASSERT_TRUE(stamp);
  EXPECT_EQ(stamp->type, "image_t");
  EXPECT_EQ(stamp->camera, "left");
}

// Encoded as the message is, without encodeCameraInfo's own check, so the decoder's is tested.
MessageBytes rawCameraInfo(const CameraModel& c) {
  terramrf_msgs::camera_info_t m;
  m.utime = 0;
  m.frame_id = "1";
  m.camera = c.name;
  m.width = c.width;
  m.height = c.height;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 4; ++k) {
      m.P[4 * r + k] = c.P(r, k);
      m.T_camera_lidar[4 * r + k] = c.T_camera_lidar.matrix()(r, k);
    }
  for (int i = 0; i < 5; ++i) m.distortion[i] = c.distortion[i];
  m.calibration = c.calibration;
  MessageBytes b(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

TEST(CameraCodec, BadCalibrationsAreRefused) {
  const auto refused = [](CameraModel c, const std::string& expect) {
    const MessageBytes b = rawCameraInfo(c);
    try {
      decodeCameraInfo(b.data(), b.size(), "chan");
      ADD_FAILURE() << "accepted; expected: " << expect;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), "chan");
      EXPECT_NE(std::string(e.what()).find(expect), std::string::npos) << e.what();
    }
  };
  CameraModel c = someCamera();
  c.width = 0;
  refused(c, "is 0 x 375 px; expected a positive size");
  c = someCamera();
  c.P(0, 0) = std::numeric_limits<double>::quiet_NaN();
  refused(c, "a non-finite number");
  c = someCamera();
  c.T_camera_lidar.matrix()(0, 0) = 2;  // a scale, not a rotation
  refused(c, "is not a rotation");
  c = someCamera();
  c.T_camera_lidar.matrix().topLeftCorner<3, 3>() *= -1;  // a reflection
  refused(c, "is not a rotation");
  c = someCamera();
  c.P.setZero();
  refused(c, "the projection matrix P is singular");
  const MessageBytes b = encodeCameraInfo(someCamera(), {"1", "lidar", 0});
  EXPECT_THROW(decodeCameraInfo(b.data(), b.size() / 2), InputError);
}

// The readers' tolerance (1e-3 off orthonormal) records and replays; beyond it the recorder
// refuses, rather than every replayed scan.
TEST(CameraCodec, NearRotationsRoundTripAndNonRotationsAreRefusedWhenEncoding) {
  CameraModel c = someCamera();
  c.T_camera_lidar.matrix()(0, 0) += 1e-4;
  const MessageBytes b = encodeCameraInfo(c, {"1", "lidar", 0});
  EXPECT_EQ(decodeCameraInfo(b.data(), b.size()).model.T_camera_lidar.matrix(),
            c.T_camera_lidar.matrix());
  c.T_camera_lidar.matrix()(0, 0) += 0.1;
  EXPECT_THROW(encodeCameraInfo(c, {"1", "lidar", 0}), std::invalid_argument);
}

}  // namespace
}  // namespace terramrf
