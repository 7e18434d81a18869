#include "terramrf/lcm/pose_codec.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <terramrf_msgs/pose_t.hpp>

#include "terramrf/errors.hpp"

namespace terramrf {
namespace {

TEST(PoseCodec, RoundTripWithAndWithoutCovariance) {
  PoseMessage p;
  p.header = {"000010", "world", 7.0};
  p.child_frame = "lidar";
  p.pose = Eigen::Translation3d(1, 2, 3) * Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ());
  const MessageBytes b = encodePose(p);

  terramrf_msgs::pose_t m;
  ASSERT_GT(m.decode(b.data(), 0, static_cast<int>(b.size())), 0);
  EXPECT_NEAR(m.orientation[0], std::sqrt(0.5), 1e-12);  // w
  EXPECT_NEAR(m.orientation[3], std::sqrt(0.5), 1e-12);  // z
  EXPECT_EQ(m.num_covariance, 0);
  EXPECT_EQ(m.position[2], 3.0);

  PoseMessage d = decodePose(b.data(), b.size());
  EXPECT_EQ(d.header.coordinate_frame, "world");
  EXPECT_EQ(d.child_frame, "lidar");
  EXPECT_FALSE(d.covariance.has_value());
  EXPECT_TRUE(d.pose.isApprox(p.pose, 1e-12));
  // +x of the child maps to +y of the parent after a 90° yaw.
  EXPECT_TRUE((d.pose * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d(1, 3, 3), 1e-12));

  Eigen::Matrix<double, 6, 6> cov = Eigen::Matrix<double, 6, 6>::Zero();
  for (int i = 0; i < 6; ++i) cov(i, i) = 0.1 * (i + 1);
  cov(0, 5) = cov(5, 0) = 0.01;
  p.covariance = cov;
  const MessageBytes bc = encodePose(p);
  d = decodePose(bc.data(), bc.size());
  ASSERT_TRUE(d.covariance.has_value());
  EXPECT_EQ(*d.covariance, cov);
}

// A frame's pose and its covariance go out as one pose_t and come back as they were; the
// covariance's order (x, y, z, roll, pitch, yaw) is the same on both sides, so each entry keeps
// its place. The truth pose is no part of it.
TEST(PoseCodec, FramePoseAndCovarianceRoundTrip) {
  Frame f;
  f.id = "000042";
  f.timestamp_s = 4.2;
  f.pose = Eigen::Translation3d(5, -2, 0.3) * Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ());
  f.truth_pose = Eigen::Isometry3d(Eigen::Translation3d(5, -2, 0.3));
  Eigen::Matrix<double, 6, 6> cov;
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) cov(r, c) = r == c ? 0.01 * (r + 1) : 0.001 * (r + c);
  f.pose_covariance = cov;

  const std::optional<PoseMessage> m = framePoseMessage(f);
  ASSERT_TRUE(m.has_value());
  EXPECT_EQ(m->header.frame_id, "000042");
  EXPECT_EQ(m->header.coordinate_frame, "world");
  EXPECT_EQ(m->child_frame, "lidar");
  const MessageBytes b = encodePose(*m);
  terramrf_msgs::pose_t raw;
  ASSERT_GT(raw.decode(b.data(), 0, static_cast<int>(b.size())), 0);
  ASSERT_EQ(raw.num_covariance, 36);
  EXPECT_EQ(raw.covariance[0 * 6 + 5], cov(0, 5));  // x–yaw, row-major
  EXPECT_EQ(raw.covariance[5 * 6 + 5], cov(5, 5));  // yaw

  Frame g;
  g.truth_pose = Eigen::Isometry3d(Eigen::Translation3d(9, 9, 9));
  setFramePose(g, decodePose(b.data(), b.size()));
  ASSERT_TRUE(g.pose && g.pose_covariance);
  EXPECT_TRUE(g.pose->isApprox(*f.pose, 1e-12));
  EXPECT_EQ(*g.pose_covariance, cov);
  EXPECT_EQ(g.truth_pose->translation(), Eigen::Vector3d(9, 9, 9));  // left alone

  // Without a covariance none is sent, and one the frame held is cleared: it was another pose's.
  f.pose_covariance.reset();
  const MessageBytes bn = encodePose(*framePoseMessage(f));
  ASSERT_GT(raw.decode(bn.data(), 0, static_cast<int>(bn.size())), 0);
  EXPECT_EQ(raw.num_covariance, 0);
  setFramePose(g, decodePose(bn.data(), bn.size()));
  EXPECT_FALSE(g.pose_covariance.has_value());

  // No pose, no message; and a pose of another child frame is not the scan's.
  EXPECT_FALSE(framePoseMessage(Frame{}).has_value());
  PoseMessage cam = *m;
  cam.child_frame = "camera";
  try {
    setFramePose(g, cam, "POSE");
    FAIL() << "a camera's pose was taken for the LiDAR's";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "POSE");
    EXPECT_NE(std::string(e.what()).find("child_frame is 'camera'"), std::string::npos) << e.what();
  }
}

TEST(PoseCodec, RejectsNonUnitQuaternion) {
  terramrf_msgs::pose_t m{};
  m.orientation[0] = 0.2;
  m.num_covariance = 0;
  MessageBytes b(m.getEncodedSize());
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  EXPECT_THROW(decodePose(b.data(), b.size(), "POSE"), InputError);
}

TEST(PoseCodec, RejectsACovarianceThatIsNot6By6) {
  terramrf_msgs::pose_t m{};
  m.orientation[0] = 1;
  m.num_covariance = 5;
  m.covariance = {1, 0, 0, 0, 1};
  MessageBytes b(m.getEncodedSize());
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  try {
    decodePose(b.data(), b.size(), "POSE");
    FAIL() << "a 5-value covariance was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "POSE");
    EXPECT_NE(std::string(e.what()).find("pose_t: num_covariance must be 0 or 36, got 5"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace terramrf
