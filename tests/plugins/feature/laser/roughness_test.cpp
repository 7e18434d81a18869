#include <gtest/gtest.h>

#include <cmath>
#include <algorithm>
#include <random>
#include <utility>
#include <vector>

#include "plugin_harness.hpp"

namespace terramrf {

namespace {
// One ring on flat ground around the sensor: points at range r with per-point range offsets.
void addRing(PointCloud& pc, uint16_t ring, double r, int n, const std::vector<double>& dr) {
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    const double rr = r + dr[i % dr.size()];
    pc.push_back(float(rr * std::cos(a)), float(rr * std::sin(a)), -1.7f, 0, ring);
  }
}
}  // namespace

TEST(Roughness, SmoothRingIsZeroAndAlternatingRingKnown) {
  test::StageHarness h;
  addRing(h.frame.points, 10, 5.0, 2000, {0.0});
  // Alternating ±2 cm along the ring: with window 1 the residual is ±(2 − (−2)) = ±4 cm.
  addRing(h.frame.points, 20, 8.0, 2000, {0.02, -0.02});
  h.bin();
  h.make("roughness", "{window: 1}")->process(h.ctx);
  EXPECT_LT(h.at("roughness", 4.9, 0.05), 1e-4);
  EXPECT_NEAR(h.at("roughness", 7.9, 0.05), 0.04, 1e-3);
  EXPECT_TRUE(std::isnan(h.at("roughness", 2.0, 2.0)));
}

// A cloud stored out of scan order (shuffled, as the Open3D-ML scans are): 'auto' finds the rings
// whose order is not an azimuth sweep and sorts them, giving the ordered cloud's roughness;
// 'scan' trusts the order and compares points from anywhere on the ring.
TEST(Roughness, ShuffledRingsAreSortedByAzimuth) {
  // Ranges that vary smoothly around the ring (a sensor off the centre of a round clearing),
  // plus 1 cm noise; and a second ring with 0.3 m steps.
  std::vector<double> dr(2000);
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.01);
  for (std::size_t i = 0; i < dr.size(); ++i) dr[i] = 2.0 * std::sin(2 * M_PI * i / dr.size()) + noise(rng);
  test::StageHarness ordered;
  addRing(ordered.frame.points, 20, 8.0, 2000, dr);
  addRing(ordered.frame.points, 30, 12.0, 3000, {0.0, 0.3});
  ordered.bin();
  ordered.make("roughness")->process(ordered.ctx);

  test::StageHarness shuffled;
  PointCloud& src = ordered.frame.points;
  std::vector<std::size_t> perm(src.size());
  for (std::size_t i = 0; i < perm.size(); ++i) perm[i] = i;
  std::shuffle(perm.begin(), perm.end(), rng);
  for (std::size_t i : perm) shuffled.frame.points.push_back(src.x[i], src.y[i], src.z[i], 0, src.ring[i]);
  shuffled.bin();
  shuffled.make("roughness")->process(shuffled.ctx);
  // Cells away from azimuth 0 and ±180°, where the ordered and the sorted ring start (a ring's
  // first and last points have a neighbour on one side only).
  int compared = 0;
  for (std::size_t c = 0; c < ordered.grid.cells(); ++c) {
    const Eigen::Vector2d p = ordered.grid.geometry().cellCentre(int(c) / ordered.grid.cols(),
                                                                 int(c) % ordered.grid.cols());
    if (std::abs(p.y()) < 1.0) continue;
    const float a = ordered.grid.layer("roughness")[c], b = shuffled.grid.layer("roughness")[c];
    if (std::isnan(a)) continue;
    EXPECT_NEAR(b, a, 1e-6) << p.transpose();
    ++compared;
  }
  EXPECT_GT(compared, 50);
  EXPECT_EQ(shuffled.ctx.metrics.at("roughness.sorted_rings"), 2);
  EXPECT_EQ(ordered.ctx.metrics.at("roughness.sorted_rings"), 0);

  // Trusting the shuffled order compares points from anywhere on the ring: most cells change
  // (or lose every neighbour to the edge rule and become no-data).
  shuffled.make("roughness", "{azimuth_order: scan}")->process(shuffled.ctx);
  int changed = 0, valid = 0;
  for (std::size_t c = 0; c < ordered.grid.cells(); ++c) {
    const float a = ordered.grid.layer("roughness")[c], b = shuffled.grid.layer("roughness")[c];
    if (std::isnan(a)) continue;
    ++valid;
    changed += std::isnan(b) || std::abs(b - a) > 0.005f;
  }
  EXPECT_GT(changed * 2, valid) << changed << " of " << valid;
}

TEST(Roughness, EdgesAreNotRoughness) {
  test::StageHarness h;
  // A range jump of 3 m (an object edge) inside a ring: beyond max_jump_m, so ignored.
  std::vector<double> dr(2000, 0.0);
  for (int i = 0; i < 1000; ++i) dr[i] = 3.0;
  addRing(h.frame.points, 5, 6.0, 2000, dr);
  h.bin();
  h.make("roughness", "{window: 2, max_jump_m: 0.5}")->process(h.ctx);
  const auto& l = h.grid.layer("roughness");
  for (float v : l)
    if (!std::isnan(v)) EXPECT_LT(v, 1e-4);
}

TEST(Roughness, WithoutRingsIsAnInputError) {
  test::StageHarness h;
  h.frame.source_path = "scan.bin";
  h.frame.points.x = {1.f};
  h.frame.points.y = {1.f};
  h.frame.points.z = {1.f};
  h.frame.points.intensity = {0.f};
  h.bin();
  try {
    h.make("roughness")->process(h.ctx);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("scan.bin"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("ring"), std::string::npos);
  }
}

}  // namespace terramrf

namespace terramrf {

// Rings recovered by elevation from a voxel-thinned cloud: two lasers, hitting flat ground 4.0 m
// and 4.3 m away (1.7 m below the sensor), end up interleaved under one ring index. Each laser
// alone sees a smooth circle; compared with the other laser's points the asphalt reads 0.14 m
// rough. Neighbours whose beam elevation differs (here by 1.4°) are passed over.
TEST(Roughness, NeighboursFromAnotherLaserArePassedOver) {
  test::StageHarness h;
  const int n = 4000;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n, r = i % 2 ? 4.3 : 4.0;
    h.frame.points.push_back(float(r * std::cos(a)), float(r * std::sin(a)), -1.7f, 0, 7);
  }
  h.bin();
  h.make("roughness")->process(h.ctx);
  // Cells at azimuth ≈ 16° holding one laser each (4.3 m and 4.0 m). Window 2: each point's two
  // neighbours of its own laser on each side are 2 and 4 positions away, at its own range.
  EXPECT_LT(h.at("roughness", 4.1, 1.2), 1e-4);
  EXPECT_LT(h.at("roughness", 3.8, 1.2), 1e-4);
  EXPECT_GT(h.ctx.metrics.at("roughness.passed_over_per_point"), 1.5);
  // Off: the window takes both lasers, two of each: residual ±(r_b − r_a) / 2 in 3D range.
  h.make("roughness", "{max_elevation_step_deg: 0}")->process(h.ctx);
  const double half_step = (std::hypot(4.3, 1.7) - std::hypot(4.0, 1.7)) / 2;  // 0.139 m
  EXPECT_NEAR(h.at("roughness", 4.1, 1.2), half_step, 1e-3);
  EXPECT_NEAR(h.at("roughness", 3.8, 1.2), half_step, 1e-3);
}

// Ground 1.7 m below the sensor whose height alternates by ±1 cm along each ring, seen by a
// laser 15° and one 5° down (6.3 m and 19.4 m away). The range jitter is the height change over
// sin(elevation), three times larger on the far ring; `residual: vertical` scales it back by
// |sin elevation| and both rings read alike.
TEST(Roughness, VerticalResidualReadsTheSameReliefAtEveryRange) {
  test::StageHarness h(50);  // ±25 m
  const int n = 6000;
  const double deg = M_PI / 180;
  for (const auto& [ring, el] : {std::pair<uint16_t, double>{3, 15 * deg}, {9, 5 * deg}}) {
    for (int i = 0; i < n; ++i) {
      const double a = 2 * M_PI * i / n, dz = i % 2 ? 0.01 : -0.01;
      const double r = (1.7 - dz) / std::sin(el);  // raised ground is hit nearer
      h.frame.points.push_back(float(r * std::cos(el) * std::cos(a)),
                               float(r * std::cos(el) * std::sin(a)), float(-r * std::sin(el)), 0,
                               ring);
    }
  }
  h.bin();
  const double near_x = 1.7 / std::tan(15 * deg), far_x = 1.7 / std::tan(5 * deg);
  h.make("roughness", "{window: 1, max_elevation_step_deg: 0}")->process(h.ctx);
  const double near_range = h.at("roughness", near_x, 0.05),
               far_range = h.at("roughness", far_x, 0.05);
  // Window 1: residual ±(δr − (−δr)) = ±2 · 0.01 / sin(elevation).
  EXPECT_NEAR(near_range, 0.02 / std::sin(15 * deg), 2e-3);
  EXPECT_NEAR(far_range, 0.02 / std::sin(5 * deg), 5e-3);
  h.make("roughness", "{window: 1, max_elevation_step_deg: 0, residual: vertical}")->process(h.ctx);
  EXPECT_NEAR(h.at("roughness", near_x, 0.05), 0.02, 1e-3);
  EXPECT_NEAR(h.at("roughness", far_x, 0.05), 0.02, 1e-3);
}

}  // namespace terramrf
