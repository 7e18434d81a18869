#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <random>
#include <string>
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
  // Alternating ±2 cm along the ring, 1.7 m below the sensor: with window 1 the residual is the
  // difference of the 3D ranges, √(8.02² + 1.7²) − √(7.98² + 1.7²) = 8.19820 − 8.15907 =
  // 0.03913 m (4 cm horizontally).
  addRing(h.frame.points, 20, 8.0, 2000, {0.02, -0.02});
  h.bin();
  h.make("roughness", "{window: 1}")->process(h.ctx);
  EXPECT_LT(h.at("roughness", 4.9, 0.05), 1e-4);
  EXPECT_NEAR(h.at("roughness", 7.9, 0.05), 0.03913, 1e-4);
  EXPECT_TRUE(std::isnan(h.at("roughness", 2.0, 2.0)));
  EXPECT_EQ(h.ctx.metrics.at("roughness.points_without_ring"), 0);
}

// Points whose ring is unknown take no part in the filter and are counted in the run's metrics.
TEST(Roughness, PointsWithoutRingAreLeftOutAndCounted) {
  test::StageHarness h;
  addRing(h.frame.points, 20, 8.0, 2000, {0.02, -0.02});
  // A ring of the same points marked unknown, 1 m further out: no roughness there.
  addRing(h.frame.points, kUnknownRing, 9.0, 1500, {0.0});
  h.bin();
  h.make("roughness", "{window: 1}")->process(h.ctx);
  EXPECT_NEAR(h.at("roughness", 7.9, 0.05), 0.03913, 1e-4);  // as above
  EXPECT_TRUE(std::isnan(h.at("roughness", 8.9, 0.05)));
  EXPECT_EQ(h.ctx.metrics.at("roughness.points_without_ring"), 1500);
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
  for (std::size_t i = 0; i < dr.size(); ++i)
    dr[i] = 2.0 * std::sin(2 * M_PI * i / dr.size()) + noise(rng);
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
  for (std::size_t i : perm)
    shuffled.frame.points.push_back(src.x[i], src.y[i], src.z[i], 0, src.ring[i]);
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
  std::size_t valued = 0;
  for (float v : l)
    if (!std::isnan(v)) {
      EXPECT_LT(v, 1e-4);
      ++valued;
    }
  EXPECT_GT(valued, 10u);  // the ring's cells have a value: an all-NaN layer would pass the above
}

// A full ring's first and last points are one revolution apart in time: on a moving car their
// ranges differ (here 0.3 m, the car's motion, within max_jump_m). The ring is not closed there,
// so the seam reads as smooth as the rest; closed, its two cells would read about 0.03 m.
TEST(Roughness, RingIsNotClosedAtItsSeam) {
  test::StageHarness h;
  const int n = 2000;
  std::vector<double> dr(n);
  for (int i = 0; i < n; ++i) dr[i] = -0.3 * i / n;  // a steady drift: no residual inside
  addRing(h.frame.points, 5, 8.0, n, dr);
  h.bin();
  h.make("roughness", "{window: 2, max_jump_m: 0.5}")->process(h.ctx);
  EXPECT_LT(h.at("roughness", 7.95, 0.01), 1e-3);   // the ring's first points
  EXPECT_LT(h.at("roughness", 7.75, -0.01), 1e-3);  // its last points (0.3 m shorter)
  EXPECT_LT(h.at("roughness", 0.0, 7.85), 1e-4);    // a quarter of the way round
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

namespace terramrf {

namespace {
// The filter of roughness.cpp's file comment written out point by point, with the plugin's float
// operations in the plugin's order: the reference for the four- (SSE2) and eight-points-at-a-time
// (AVX2) paths.
struct ReferenceRoughness {
  std::vector<float> layer;
  double passed_over_per_point = 0;
};
ReferenceRoughness referenceRoughness(const PointCloud& pc, const TerrainGrid& g, int window,
                                      double max_jump_m, double max_elev_step_deg, bool vertical,
                                      int min_points) {
  const bool elev = max_elev_step_deg > 0;
  const int span = elev ? 4 * window : window;
  const float jump = float(max_jump_m), max_dsin = float(std::sin(max_elev_step_deg * M_PI / 180));
  std::vector<std::vector<uint32_t>> rings;
  for (std::size_t i = 0; i < pc.size(); ++i) {
    if (pc.ring[i] == kUnknownRing) continue;
    if (pc.ring[i] >= rings.size()) rings.resize(pc.ring[i] + 1);
    rings[pc.ring[i]].push_back(uint32_t(i));
  }
  std::vector<float> sum(g.cells(), 0.f);
  std::vector<uint32_t> cnt(g.cells(), 0);
  std::size_t passed = 0, residuals = 0;
  for (const auto& ring : rings) {
    const int e = int(ring.size());
    std::vector<float> range(e), sin_el(e);
    for (int k = 0; k < e; ++k) {
      const uint32_t i = ring[k];
      range[k] = std::sqrt(pc.x[i] * pc.x[i] + pc.y[i] * pc.y[i] + pc.z[i] * pc.z[i]);
      sin_el[k] = pc.z[i] / std::max(range[k], 1e-3f);
    }
    for (int k = 0; k < e; ++k) {
      const int cell = g.cellOfPoint()[ring[k]];
      if (cell < 0) continue;
      float s = 0;
      int m = 0, left = 0;
      for (int dir : {-1, +1}) {
        for (int d = 1, got = 0; d <= span && got < window; ++d) {
          const int j = k + dir * d;
          if (j < 0 || j >= e) break;
          if (elev && std::abs(sin_el[j] - sin_el[k]) > max_dsin) {
            ++passed;
            continue;
          }
          if (std::abs(range[j] - range[k]) > jump) break;
          s += range[j], ++m, ++got;
        }
        if (dir < 0) left = m;
      }
      if (left == 0 || m == left) continue;
      const float res = vertical ? (range[k] - s / m) * std::abs(sin_el[k]) : range[k] - s / m;
      sum[cell] += res * res;
      ++cnt[cell];
      ++residuals;
    }
  }
  ReferenceRoughness out;
  out.layer.assign(g.cells(), std::numeric_limits<float>::quiet_NaN());
  for (std::size_t c = 0; c < g.cells(); ++c)
    if (cnt[c] >= uint32_t(min_points)) out.layer[c] = std::sqrt(sum[c] / cnt[c]);
  out.passed_over_per_point = residuals ? double(passed) / residuals : 0.0;
  return out;
}
}  // namespace

// Rings of every length from 1 to 13 points and longer ones, stored interleaved, running in and
// out of the grid, with range jumps (edges) and points of another laser (passed over) at random
// places: the plugin's layer and passed-over metric must equal the definition's bit for bit,
// whatever the window, so the SSE2 path's lanes, ring ends and masks are checked.
TEST(Roughness, VectorGroupsEqualTheDefinitionBitForBit) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<std::vector<std::array<float, 3>>> rings;
  for (int r = 0; r < 40; ++r) {
    const int n = r < 13 ? r + 1 : 30 + int(u(rng) * 400);
    const double el = -(2 + 0.4 * r) * M_PI / 180, a0 = u(rng) * 2 * M_PI;
    const double base = 2 + u(rng) * 14;  // up to 16 m: the 20 m grid ends at 10 m
    std::vector<std::array<float, 3>> pts;
    for (int i = 0; i < n; ++i) {
      double range = base + 0.02 * (u(rng) - 0.5), e = el;
      if (u(rng) < 0.08) range += 0.3 + u(rng);                           // an edge
      if (u(rng) < 0.1) e += (u(rng) < 0.5 ? -1 : 1) * 0.5 * M_PI / 180;  // another laser
      const double a = a0 + 0.003 * i;
      pts.push_back({float(range * std::cos(e) * std::cos(a)),
                     float(range * std::cos(e) * std::sin(a)), float(range * std::sin(e))});
    }
    rings.push_back(pts);
  }
  // Interleaved in storage, each ring in its own order, a few points without a ring: runs of
  // 0-5 points of a ring (the counting sort walks runs), or one point per ring in turn as drivers
  // deliver firing order (it walks points). Or ring after ring with every point on a ring, as
  // KITTI stores them (the points are read where they lie).
  for (const char* layout : {"runs of points", "firing order", "ring after ring"}) {
    SCOPED_TRACE(layout);
    const bool firing_order = std::string(layout) == "firing order";
    test::StageHarness h;
    std::vector<std::size_t> next(rings.size(), 0);
    if (std::string(layout) == "ring after ring")
      for (std::size_t r = 0; r < rings.size(); ++r)
        for (const auto& p : rings[r]) h.frame.points.push_back(p[0], p[1], p[2], 0, uint16_t(r));
    for (std::size_t left = h.frame.points.empty(); left;) {
      left = 0;
      for (std::size_t r = 0; r < rings.size(); ++r) {
        const int take = firing_order ? 1 : int(u(rng) * 6);
        for (int t = 0; t < take && next[r] < rings[r].size(); ++t, ++next[r]) {
          const auto& p = rings[r][next[r]];
          h.frame.points.push_back(p[0], p[1], p[2], 0, uint16_t(r));
        }
        left += rings[r].size() - next[r];
      }
      if (u(rng) < 0.3) h.frame.points.push_back(1.f, 1.f, -1.f, 0, kUnknownRing);
    }
    h.bin();
    struct Case {
      std::string params;
      int window;
      double jump, elev;
      bool vertical;
      int min_points;
    };
    for (const Case& c : std::vector<Case>{
             {"{}", 2, 0.5, 0.15, false, 1},
             {"{window: 1}", 1, 0.5, 0.15, false, 1},
             {"{window: 3, max_elevation_step_deg: 0}", 3, 0.5, 0, false, 1},
             {"{window: 5, residual: vertical, max_jump_m: 0.3}", 5, 0.3, 0.15, true, 1},
             {"{window: 7, max_elevation_step_deg: 0.3, min_points: 2}", 7, 0.5, 0.3, false, 2},
             {"{window: 2, residual: vertical, max_elevation_step_deg: 0}", 2, 0.5, 0, true, 1}}) {
      SCOPED_TRACE(c.params);
      // Eight-point groups (AVX2) where the CPU has them, and the four-point SSE2 groups.
      for (const bool sse2 : {false, true}) {
        SCOPED_TRACE(sse2 ? "SSE2" : "widest vectors of this CPU");
        std::optional<test::ScopedEnv> env;
        if (sse2) env.emplace("TERRAMRF_SIMD", "sse2");
        h.bin();
        auto p = h.make("roughness", c.params.substr(0, c.params.size() - 1) +
                                         (c.params == "{}" ? "" : ", ") + "azimuth_order: scan}");
        p->process(h.ctx);
        const ReferenceRoughness ref = referenceRoughness(h.frame.points, h.grid, c.window, c.jump,
                                                          c.elev, c.vertical, c.min_points);
        const auto& got = h.grid.layer("roughness");
        int valid = 0, differ = 0;
        for (std::size_t i = 0; i < got.size(); ++i) {
          valid += !std::isnan(ref.layer[i]);
          const bool both_nan = std::isnan(got[i]) && std::isnan(ref.layer[i]);
          differ += !both_nan && std::memcmp(&got[i], &ref.layer[i], sizeof(float)) != 0;
        }
        EXPECT_EQ(differ, 0) << "of " << valid << " valid cells";
        EXPECT_GT(valid, 30);
        EXPECT_EQ(h.ctx.metrics.at("roughness.passed_over_per_point"), ref.passed_over_per_point);
      }
    }
  }
}

}  // namespace terramrf
