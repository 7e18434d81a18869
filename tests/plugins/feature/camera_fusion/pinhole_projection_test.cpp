// camera_fusion's point → pixel lookup for cameras without distortion (projectPinhole): the four-
// points-per-vector copy must give the one-point loop's pixels and depths bit for bit, and both
// must agree with CameraModel::project, on a cloud around the camera (behind it, beside it, at
// the image border, NaN and huge coordinates) whose size is no multiple of four.
#include "pinhole_projection.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "plugins/feature/camera_fusion/fusion_test_frame.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

struct Cloud {
  std::vector<float> x, y, z;
  void add(double a, double b, double c) {
    x.push_back(float(a)), y.push_back(float(b)), z.push_back(float(c));
  }
};

/// KITTI's image_2 calibration of object frame 000000 (P2 · R0_rect · Tr_velo_to_cam), 1242 × 375.
CameraModel kittiCamera() {
  CameraModel m;
  m.width = 1242, m.height = 375;
  m.P << 721.5377, 0, 609.5593, 44.85728,  //
      0, 721.5377, 172.854, 0.2163791,     //
      0, 0, 1, 0.002745884;
  Eigen::Matrix4d R0 = Eigen::Matrix4d::Identity(), Tr = Eigen::Matrix4d::Identity();
  R0.topLeftCorner<3, 3>() << 0.9999239, 0.00983776, -0.007445048, -0.009869795, 0.9999421,
      -0.004278459, 0.007402527, 0.004351614, 0.9999631;
  Tr.topRows<3>() << 0.007533745, -0.9999714, -0.000616602, -0.004069766, 0.01480249, 0.0007280733,
      -0.9998902, -0.07631618, 0.9998621, 0.007523790, 0.01480755, -0.2717806;
  m.T_camera_lidar = Eigen::Isometry3d(R0 * Tr);
  return m;
}

Cloud cloudAround(const CameraModel& m, unsigned seed) {
  Cloud c;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> coord(-40, 40), h(-3, 3);
  for (int i = 0; i < 20001; ++i) c.add(coord(rng), coord(rng), h(rng));
  // Exactly on the borders of the image and half a pixel around them: the points whose pixel
  // the rounding decides.
  const Eigen::Isometry3d lidar_camera = m.T_camera_lidar.inverse();
  const Eigen::Matrix3d K = m.P.leftCols<3>();
  for (double u : {-0.5, -0.5 + 1e-9, 0.0, m.width - 0.5 - 1e-9, m.width - 0.5, m.width - 1.0})
    for (double v : {-0.5, 0.49999, 0.5, m.height - 0.5 - 1e-9, m.height - 0.5, 100.0})
      for (double depth : {0.5, 7.0, 60.0}) {
        const Eigen::Vector3d ray = K.inverse() * Eigen::Vector3d(u, v, 1);
        const Eigen::Vector3d p = lidar_camera * (depth * ray);
        c.add(p.x(), p.y(), p.z());
      }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  c.add(nan, 1, 1), c.add(10, nan, 0), c.add(1e30, 0, 0), c.add(-1e30, 0, 0), c.add(0, 0, 0);
  c.add(0.27, 0, 0);  // at the camera centre's depth
  return c;
}

struct Result {
  std::vector<int32_t> pix;
  std::vector<float> depth;
  std::size_t visible = 0;
};

Result project(const CameraModel& m, const Cloud& c, bool with_depth) {
  const Eigen::Matrix<double, 3, 4> M = m.P * m.T_camera_lidar.matrix();
  PinholeScan s;
  s.x = c.x.data(), s.y = c.y.data(), s.z = c.z.data(), s.n = c.x.size();
  for (int j = 0; j < 4; ++j) {
    s.zc[j] = m.T_camera_lidar.matrix()(2, j);
    for (int r = 0; r < 3; ++r) s.M[r][j] = M(r, j);
  }
  s.width = m.width, s.height = m.height;
  Result out;
  out.pix.assign(s.n, 12345);  // every entry must be written
  out.depth.assign(with_depth ? s.n : 0, 12345.f);
  s.pix = out.pix.data();
  s.depth = with_depth ? out.depth.data() : nullptr;
  out.visible = projectPinhole(s);
  return out;
}

/// A 128 × 64 camera looking along the LiDAR's x axis with power-of-two intrinsics: points on a
/// pixel border project onto it exactly (u = 64·(−y/x) + 64, v = 64·(−z/x) + 32).
CameraModel dyadicCamera() {
  CameraModel m = test::forwardCamera();
  m.width = 128, m.height = 64;
  m.P << 64, 0, 64, 0,  //
      0, 64, 32, 0,     //
      0, 0, 1, 0;
  return m;
}

TEST(PinholeProjection, ImageBordersExactly) {
  // u = −0.5 and v = −0.5 belong to pixel 0; u = width − 0.5 and v = height − 0.5 to none.
  const CameraModel m = dyadicCamera();
  Cloud c;
  c.add(1, 64.5 / 64, -0.0);         // u = −0.5, v = 32
  c.add(1, 0, 32.5 / 64);            // u = 64, v = −0.5
  c.add(1, 64.5 / 64, 32.5 / 64);    // the corner (−0.5, −0.5)
  c.add(1, -63.5 / 64, 0);           // u = 127.5
  c.add(1, 0, -31.5 / 64);           // v = 63.5
  c.add(1, -63.0 / 64, -31.0 / 64);  // (127, 63): the last pixel
  c.add(2, 130.0 / 64, 0);           // u = −1
  for (const bool plain : {false, true}) {
    test::ScopedEnv simd("TERRAMRF_SIMD", plain ? "sse2" : "auto");
    const Result r = project(m, c, true);
    EXPECT_EQ(r.pix, (std::vector<int32_t>{32 * 128 + 0, 64, 0, -1, -1, 63 * 128 + 127, -1}));
    EXPECT_EQ(r.depth, (std::vector<float>{1, 1, 1, 0, 0, 1, 0}));
    EXPECT_EQ(r.visible, 4u);
  }
}

TEST(PinholeProjection, VectorAndOnePointLoopsGiveTheSameBits) {
  for (const CameraModel& m : {kittiCamera(), test::forwardCamera()}) {
    const Cloud c = cloudAround(m, 5);
    for (const bool with_depth : {true, false}) {
      const Result best = project(m, c, with_depth);
      test::ScopedEnv sse2("TERRAMRF_SIMD", "sse2");
      const Result plain = project(m, c, with_depth);
      EXPECT_EQ(best.visible, plain.visible);
      EXPECT_EQ(best.pix, plain.pix);
      ASSERT_EQ(best.depth.size(), plain.depth.size());
      for (std::size_t i = 0; i < best.depth.size(); ++i)
        ASSERT_EQ(std::memcmp(&best.depth[i], &plain.depth[i], sizeof(float)), 0) << i;
    }
  }
}

TEST(PinholeProjection, AgreesWithCameraModelProject) {
  for (const bool plain : {false, true}) {
    test::ScopedEnv simd("TERRAMRF_SIMD", plain ? "sse2" : "auto");
    const CameraModel m = kittiCamera();
    const Cloud c = cloudAround(m, 8);
    const Result r = project(m, c, true);
    const Eigen::Matrix<double, 3, 4> M = m.P * m.T_camera_lidar.matrix();
    std::size_t visible = 0, near_border = 0;
    for (std::size_t i = 0; i < c.x.size(); ++i) {
      const Eigen::Vector3d p(c.x[i], c.y[i], c.z[i]);
      const auto uv = m.project(p);
      int32_t expect = -1;
      if (uv) {
        const int iu = int(uv->x() + 0.5), iv = int(uv->y() + 0.5);
        if (iu < m.width && iv < m.height) expect = iv * m.width + iu;
      }
      if (expect != r.pix[i]) {
        // project() multiplies P and T_camera_lidar the other way round: the two may round apart
        // only for a point within a hair of a pixel border.
        ASSERT_TRUE(uv) << i;
        const double du = uv->x() + 0.5 - std::round(uv->x() + 0.5);
        const double dv = uv->y() + 0.5 - std::round(uv->y() + 0.5);
        EXPECT_LT(std::min(std::abs(du), std::abs(dv)), 1e-6) << i;
        ++near_border;
        continue;
      }
      if (expect < 0) {
        EXPECT_EQ(r.depth[i], 0.f) << i;
        continue;
      }
      ++visible;
      EXPECT_FLOAT_EQ(r.depth[i], float(M.row(2).head<3>().dot(p) + M(2, 3))) << i;
    }
    EXPECT_GT(visible, 1000u);
    EXPECT_LE(near_border, 10u);
    EXPECT_EQ(r.visible, std::size_t(std::count_if(r.pix.begin(), r.pix.end(),
                                                   [](int32_t x) { return x >= 0; })));
  }
}

}  // namespace
}  // namespace terramrf
