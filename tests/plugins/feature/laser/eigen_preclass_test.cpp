#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "plugin_harness.hpp"

namespace terramrf {

namespace {
// Points on a plane z = z0 + sx·x + sy·y over [x0,x1)×[y0,y1) with Gaussian noise along z.
void addPlane(PointCloud& pc, double x0, double x1, double y0, double y1, double z0, double sx,
              double sy, double noise, unsigned seed, double step = 0.05) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0, noise);
  for (double x = x0; x < x1; x += step)
    for (double y = y0; y < y1; y += step)
      pc.push_back(float(x), float(y), float(z0 + sx * x + sy * y + n(rng)), 0.5f);
}
}  // namespace

TEST(EigenPreclass, FlatPlaneIsFlatWithNoiseVarianceAsEigenvalue) {
  test::StageHarness h;
  addPlane(h.frame.points, 0, 0.5, 0, 0.5, -1.7, 0, 0, 0.01, 1);
  h.bin();
  h.make("eigen_preclass")->process(h.ctx);
  // λ along the normal = variance of the noise: 0.01² = 1e-4 m².
  EXPECT_NEAR(h.at("normal_eigenvalue", 0.25, 0.25), 1e-4, 3e-5);
  EXPECT_EQ(h.at("preclass", 0.25, 0.25), 1.f);
}

TEST(EigenPreclass, SteepSlopeStaysFlat) {
  // 30° slope: the variance along the tilted normal stays tiny although height varies by 29 cm.
  test::StageHarness h;
  addPlane(h.frame.points, 0, 0.5, 0, 0.5, -1.7, std::tan(M_PI / 6), 0, 0.0, 2);
  h.bin();
  h.make("eigen_preclass")->process(h.ctx);
  EXPECT_LT(h.at("normal_eigenvalue", 0.25, 0.25), 1e-8);
  EXPECT_EQ(h.at("preclass", 0.25, 0.25), 1.f);
}

TEST(EigenPreclass, VerticalWallIsObstacleAndSparseCellUnknown) {
  test::StageHarness h;
  // A wall x = 2.2, y in [0, 0.5), z in [-1.7, 0.3): the most vertical eigenvector lies in the
  // wall, along which the spread is large.
  for (double y = 0; y < 0.5; y += 0.05)
    for (double z = -1.7; z < 0.3; z += 0.05) h.frame.points.push_back(2.2f, float(y), float(z), 0);
  h.frame.points.push_back(5.1f, 5.1f, -1.7f, 0);  // one point alone in its cell
  h.bin();
  h.make("eigen_preclass", "{threshold_m2: 0.01}")->process(h.ctx);
  EXPECT_NEAR(h.at("normal_eigenvalue", 2.2, 0.25), 4.0 / 12, 0.02);  // uniform over 2 m: L²/12
  EXPECT_EQ(h.at("preclass", 2.2, 0.25), 2.f);
  EXPECT_TRUE(std::isnan(h.at("normal_eigenvalue", 5.1, 5.1)));
  EXPECT_EQ(h.at("preclass", 5.1, 5.1), 0.f);
  EXPECT_GE(h.ctx.metrics.at("eigen_preclass.obstacle_cells"), 1);
}

}  // namespace terramrf
