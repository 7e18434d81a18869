#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "../../../../plugins/feature/eigen_preclass/normal_eigenvalue.hpp"
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

// The eigenvalue-only path (eigenvector–eigenvalue identity) picks the same λ as the full
// eigendecomposition on the covariances cells produce: planes at any tilt, walls, poles, blobs,
// and the degenerate ones (isotropic, two equal spreads, collinear points) where it defers to the
// solver.
TEST(EigenPreclass, NormalEigenvalueMatchesTheFullSolver) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  std::uniform_real_distribution<double> logscale(-6, 0);
  int compared = 0, deferred = 0;
  auto check = [&](const Eigen::Matrix3d& C) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
    es.computeDirect(C);
    const Eigen::Vector3d l = es.eigenvalues();
    const Eigen::Matrix3d& E = es.eigenvectors();
    const double got = normalEigenvalue(C), want = normalEigenvalueBySolver(C);
    // Where two eigenvectors are (nearly) equally vertical either eigenvalue is λ_k.
    double z[3];
    for (int i = 0; i < 3; ++i) z[i] = std::abs(E(2, i));
    std::sort(z, z + 3);
    const double scale = std::max(std::abs(l(0)), std::abs(l(2)));
    if (std::min(l(1) - l(0), l(2) - l(1)) <= kNormalEigenvalueMinGap * scale) ++deferred;
    if (z[2] - z[1] < 1e-6) return;
    ++compared;
    EXPECT_EQ(got, want) << C;
  };
  for (int t = 0; t < 20000; ++t) {
    // Random orientation, spreads over six decades (a 1 mm-noise plane to a 1 m blob).
    const Eigen::Matrix3d R =
        Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized().toRotationMatrix();
    Eigen::Vector3d s(std::pow(10, logscale(rng)), std::pow(10, logscale(rng)),
                      std::pow(10, logscale(rng)));
    if (t % 5 == 1) s(1) = s(0);         // two equal spreads (a round pole, a disc)
    if (t % 5 == 2) s(1) = s(2) = s(0);  // isotropic
    if (t % 5 == 3) s(1) = s(2) = 0;     // collinear points
    check(R * s.asDiagonal() * R.transpose());
  }
  // Axis-aligned cases cells often are: level ground, a wall, a vertical pole.
  check(Eigen::Vector3d(0.02, 0.02, 1e-5).asDiagonal().toDenseMatrix());
  check(Eigen::Vector3d(1e-5, 0.02, 0.33).asDiagonal().toDenseMatrix());
  check(Eigen::Vector3d(1e-4, 1e-4, 0.5).asDiagonal().toDenseMatrix());
  EXPECT_GT(compared, 19000);
  EXPECT_GT(deferred, 10000);  // the degenerate cases did reach the fallback
}

}  // namespace terramrf
