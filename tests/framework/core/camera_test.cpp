// CameraModel (framework/src/camera.cpp): the radial-tangential distortion against OpenCV's own
// cv::projectPoints, and the points the distortion would fold back into the image.
#include "terramrf/camera.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <random>
#include <vector>

namespace terramrf {
namespace {

/// KITTI-sized camera, fx 700, principal point (620, 187); the camera frame is the LiDAR frame.
CameraModel kittiSized(const std::array<double, 5>& distortion) {
  CameraModel m;
  m.width = 1242;
  m.height = 375;
  m.P << 700, 0, 620, 0,  //
      0, 700, 187, 0,     //
      0, 0, 1, 0;
  m.distortion = distortion;
  return m;
}

// The review's case: with p2 = 0.001 alone the radial polynomial is the identity, so the old
// check (the radial polynomial stops growing) passed every point; x_d = x + p2 (r² + 2x²) grows
// with x² and brings x = −333 (89.8° off axis) back to x_d = 0, the image centre.
TEST(CameraModel, TangentialTermsDoNotFoldFarPointsIntoTheImage) {
  const CameraModel m = kittiSized({0, 0, 0, 0.001, 0});
  EXPECT_FALSE(m.projectUnbounded(Eigen::Vector3d(-20, 0, 0.06)));
  EXPECT_FALSE(m.project(Eigen::Vector3d(-20, 0, 0.06)));
  // Just in front of the camera plane: on the folding side refused, on the other side (the
  // tangential term pushes outward) projected far outside the image.
  EXPECT_FALSE(m.projectUnbounded(Eigen::Vector3d(-20, 0, 1e-5)));
  const auto out = m.projectUnbounded(Eigen::Vector3d(20, 0, 1e-5));
  ASSERT_TRUE(out);
  EXPECT_GT(out->x(), 1e6);
  EXPECT_FALSE(m.project(Eigen::Vector3d(20, 0, 1e-5)));
  // Along the −x ray the radial component is f(r) = r + 3 p2 r² · cos 180°, which turns at
  // r = 1/(6 p2) = 166.7: just before it the point still projects (far outside), just after not.
  const auto before = m.projectUnbounded(Eigen::Vector3d(-160, 0, 1));
  ASSERT_TRUE(before);
  EXPECT_NEAR(before->x(), 620 + 700 * (-160 + 0.001 * 3 * 160 * 160), 1e-6);
  EXPECT_FALSE(m.projectUnbounded(Eigen::Vector3d(-170, 0, 1)));
  // p1 acts the same way along y.
  const CameraModel m1 = kittiSized({0, 0, 0.001, 0, 0});
  EXPECT_FALSE(m1.projectUnbounded(Eigen::Vector3d(0, -20, 0.06)));
  EXPECT_TRUE(m1.projectUnbounded(Eigen::Vector3d(0, -160, 1)));
  EXPECT_FALSE(m1.projectUnbounded(Eigen::Vector3d(0, -170, 1)));
  // Points in the image are unaffected.
  const auto centre = m.project(Eigen::Vector3d(0.1, 0.05, 1));
  ASSERT_TRUE(centre);
  EXPECT_NEAR(centre->x(), 620 + 700 * (0.1 + 0.001 * (0.0125 + 0.02)), 1e-9);
  EXPECT_NEAR(centre->y(), 187 + 700 * (0.05 + 2 * 0.001 * 0.1 * 0.05), 1e-9);
}

// A fold between the camera and the point: with k1 = 2e-6 and p2 = 0.001 the radial component
// along −x is f(r) = r − 0.003 r² + 2e-6 r³, whose slope 1 − 6 t + 6 t² (t = r / 1000) is
// negative for t in (0.21, 0.79) and positive again at t = 1: the point at r = 1000 would pass a
// check of the slope at the point alone, and the radial polynomial (k1 > 0) never turns.
TEST(CameraModel, AFoldBetweenTheCameraAndThePointIsFound) {
  const CameraModel m = kittiSized({2e-6, 0, 0, 0.001, 0});
  EXPECT_FALSE(m.projectUnbounded(Eigen::Vector3d(-1000, 0, 1)));
  EXPECT_FALSE(m.projectUnbounded(Eigen::Vector3d(-500, 0, 1)));
  EXPECT_TRUE(m.projectUnbounded(Eigen::Vector3d(-150, 0, 1)));  // t = 0.15: before the fold
  // With k1 = 4e-6 the slope 1 − 6 t + 12 t² never reaches zero: no fold, the point projects.
  EXPECT_TRUE(kittiSized({4e-6, 0, 0, 0.001, 0}).projectUnbounded(Eigen::Vector3d(-1000, 0, 1)));
}

// The distortion formula against an independent implementation, OpenCV's cv::projectPoints (same
// K, the same OpenCV order k1, k2, p1, p2, k3, and the extrinsic as rvec / tvec), at points spread
// over the field of view and beyond its edges, 2–60 m away.
TEST(CameraModel, ProjectionAgreesWithOpenCvProjectPoints) {
  CameraModel m;
  m.width = 1242;
  m.height = 375;
  const double fx = 721.5, fy = 718.9, cx = 609.6, cy = 172.9;
  m.P << fx, 0, cx, 0,  //
      0, fy, cy, 0,     //
      0, 0, 1, 0;
  m.distortion = {0.08, -0.03, 0.0012, -0.0007, 0.004};
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -1.0, 0.2).normalized();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(1.9, axis).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.06, -0.33, -0.27);
  m.T_camera_lidar = T;

  std::mt19937 rng(11);
  // Normalised coordinates 20 % beyond the image's edges, and depths.
  std::uniform_real_distribution<double> ux(-1.2 * cx / fx, 1.2 * (m.width - cx) / fx),
      uy(-1.2 * cy / fy, 1.2 * (m.height - cy) / fy), uz(2, 60);
  std::vector<cv::Point3d> object;
  std::vector<Eigen::Vector3d> lidar;
  for (int i = 0; i < 5000; ++i) {
    const double z = uz(rng);
    const Eigen::Vector3d pc(ux(rng) * z, uy(rng) * z, z);
    const Eigen::Vector3d pl = T.inverse() * pc;
    lidar.push_back(pl);
    object.emplace_back(pl.x(), pl.y(), pl.z());
  }
  cv::Mat R(3, 3, CV_64F), rvec;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R.at<double>(r, c) = T.linear()(r, c);
  cv::Rodrigues(R, rvec);
  const cv::Mat tvec =
      (cv::Mat_<double>(3, 1) << T.translation().x(), T.translation().y(), T.translation().z());
  const cv::Mat K = (cv::Mat_<double>(3, 3) << fx, 0, cx, 0, fy, cy, 0, 0, 1);
  const cv::Mat dist = (cv::Mat_<double>(1, 5) << m.distortion[0], m.distortion[1], m.distortion[2],
                        m.distortion[3], m.distortion[4]);
  std::vector<cv::Point2d> expected;
  cv::projectPoints(object, rvec, tvec, K, dist, expected);
  int inside = 0;
  double worst = 0;
  for (std::size_t i = 0; i < lidar.size(); ++i) {
    const auto uv = m.projectUnbounded(lidar[i]);
    ASSERT_TRUE(uv) << "point " << i;
    worst = std::max({worst, std::abs(uv->x() - expected[i].x), std::abs(uv->y() - expected[i].y)});
    inside += m.project(lidar[i]).has_value();
  }
  EXPECT_LT(worst, 1e-6);
  EXPECT_GT(inside, 2500);  // most of them inside the image, the rest around its edges
}

}  // namespace
}  // namespace terramrf
