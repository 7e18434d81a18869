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
