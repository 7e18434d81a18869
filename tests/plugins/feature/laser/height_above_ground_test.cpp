#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <random>
#include <vector>

#include "../../../../plugins/feature/height_above_ground/window_pick.hpp"
#include "plugin_harness.hpp"
#include "test_support.hpp"

namespace terramrf {

namespace {
// Ground at z = −1.7 + slope·x on a 0.1 m lattice over the 20 m grid, with a box raised by
// `box_h` over x ∈ [bx0, bx1), y ∈ [by0, by1) (a hedge: a flat top, no points under it).
void scene(test::StageHarness& h, double slope, double box_h, double bx0, double bx1, double by0,
           double by1) {
  for (double x = -10; x < 10; x += 0.1)
    for (double y = -10; y < 10; y += 0.1) {
      const double cx = x + 0.05, cy = y + 0.05;
      const bool box = cx >= bx0 && cx < bx1 && cy >= by0 && cy < by1;
      h.frame.points.push_back(float(cx), float(cy), float(-1.7 + slope * cx + (box ? box_h : 0.0)), 0);
    }
  h.bin();
}
}  // namespace

TEST(HeightAboveGround, HedgeTopIsItsHeightWhereNeighbourCellsCannotTell) {
  test::StageHarness h;
  // A 2 m wide, 0.3 m high hedge along x: inside it every neighbour of a cell is hedge too, so
  // comparing with neighbours (relative_height) sees nothing; the ground filter does.
  scene(h, 0.0, 0.3, -10, 10, 2.0, 4.0);
  h.make("height_above_ground", "{ground_layer: ground_z}")->process(h.ctx);
  h.make("relative_height", "{}")->process(h.ctx);
  EXPECT_NEAR(h.at("height_above_ground", 0.2, 3.2), 0.3, 1e-4);
  EXPECT_NEAR(h.at("relative_height", 0.2, 3.2), 0.0, 1e-4);
  EXPECT_NEAR(h.at("height_above_ground", 0.2, -3.2), 0.0, 1e-4);
  EXPECT_NEAR(h.at("ground_z", 0.2, 3.2), -1.7, 1e-4);
}

TEST(HeightAboveGround, SlopeWithinToleranceStaysGround) {
  test::StageHarness h;
  // 4 % ramp (under the 5 % default): every cell is ground; a cell's top is at most one cell's
  // rise (0.02 m) above the mean of its neighbours' lowest points.
  scene(h, 0.04, 0.0, 0, 0, 0, 0);
  auto stage = h.make("height_above_ground", "{}");
  stage->process(h.ctx);
  for (double x : {-8.2, -3.3, 0.2, 4.7, 8.8})
    for (double y : {-7.1, 0.3, 6.6}) {
      const float v = h.at("height_above_ground", x, y);
      EXPECT_GE(v, -1e-4) << x << "," << y;
      EXPECT_LE(v, 0.05) << x << "," << y;
    }
  // The same ramp with a tolerance of 0 reads the slope as obstacles on the uphill side.
  auto strict = h.make("height_above_ground", "{slope: 0.0, initial_threshold_m: 0.0}");
  strict->process(h.ctx);
  EXPECT_GT(h.at("height_above_ground", 8.8, 0.3), 0.1);
}

TEST(HeightAboveGround, ObjectWiderThanTheLargestWindowIsGround) {
  test::StageHarness h;
  // A 0.6 m plateau 10 m wide: wider than a 4 m window, so it is terrain to the filter. (At
  // 0.5 m it would be terrain under a 16 m window too: the last window grows by 16 cells, 8 m,
  // and the 5 % slope tolerance then allows 0.1 + 0.05 · 8 = 0.5 m.)
  scene(h, 0.0, 0.6, -5, 5, -10, 10);
  h.make("height_above_ground", "{max_window_m: 4}")->process(h.ctx);
  EXPECT_NEAR(h.at("height_above_ground", 0.2, 0.2), 0.0, 1e-4);
  h.make("height_above_ground", "{max_window_m: 16}")->process(h.ctx);
  EXPECT_NEAR(h.at("height_above_ground", 0.2, 0.2), 0.6, 1e-4);
}

// The largest window spans at least max_window_m: a 7.5 m plateau (15 cells) is an object under
// an 8 m window (17 cells; rounded down it was 15 cells, and the plateau stayed ground).
TEST(HeightAboveGround, TheLargestWindowSpansAtLeastMaxWindow) {
  test::StageHarness h;
  scene(h, 0.0, 0.5, -4.0, 3.5, -10, 10);
  h.make("height_above_ground", "{max_window_m: 8}")->process(h.ctx);
  EXPECT_NEAR(h.at("height_above_ground", 0.2, 0.2), 0.5, 1e-4);
  h.make("height_above_ground", "{max_window_m: 7}")->process(h.ctx);  // 15 cells: terrain
  EXPECT_NEAR(h.at("height_above_ground", 0.2, 0.2), 0.0, 1e-4);
}

// The first, 3-cell window takes the initial threshold itself (Zhang et al. 2003): a kerb-like
// object 0.12 m high and 1 m wide stands out against 0.10 m. (The slope term was added to it,
// 0.15 m, and the object read 0.04 m, its road neighbours −0.04 m.)
TEST(HeightAboveGround, TheFirstWindowUsesTheInitialThreshold) {
  test::StageHarness h;
  scene(h, 0.0, 0.12, 0.0, 1.0, -10, 10);
  h.make("height_above_ground", "{}")->process(h.ctx);
  EXPECT_NEAR(h.at("height_above_ground", 0.2, 0.2), 0.12, 1e-4);
  EXPECT_NEAR(h.at("height_above_ground", -0.8, 0.2), 0.0, 1e-4);
  EXPECT_NEAR(h.at("height_above_ground", 1.2, 0.2), 0.0, 1e-4);
}

TEST(HeightAboveGround, EmptyCellsNaNAndBadThresholdsRejected) {
  test::StageHarness h;
  h.frame.points.push_back(1.2f, 1.2f, -1.7f, 0);
  h.bin();
  h.make("height_above_ground", "{}")->process(h.ctx);
  EXPECT_NEAR(h.at("height_above_ground", 1.2, 1.2), 0.0, 1e-6);
  EXPECT_TRUE(std::isnan(h.at("height_above_ground", -3.0, 4.0)));
  try {
    h.make("height_above_ground", "{initial_threshold_m: 0.5, max_threshold_m: 0.2}");
    FAIL() << "expected an error naming the parameter";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("max_threshold_m"), std::string::npos) << e.what();
  }
}

}  // namespace terramrf

namespace terramrf {

namespace {
// The filter as the plugin's doc states it, by brute force: openings with (2w+1)² windows
// (w = 1, 2, 4, … up to w_max; +inf / −inf for cells without data), a cell is non-ground once
// its lowest point rises more than the window's threshold above an opening, and the ground under
// a cell is the mean lowest point of the ground cells within `radius` (grown ×2 until some are
// found).
std::vector<float> referenceHag(const TerrainGrid& g, const std::vector<float>& zmin,
                                const std::vector<float>& zmax, int w_max, double cell, double dh0,
                                double slope, double dh_max, int radius) {
  const int R = g.rows(), C = g.cols(), N = R * C;
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<float> surface(N), eroded(N), opened(N);
  std::vector<char> nonground(N, 0);
  for (int i = 0; i < N; ++i) surface[i] = std::isnan(zmin[i]) ? inf : zmin[i];
  auto window = [&](const std::vector<float>& in, std::vector<float>& out, int w, bool lo) {
    for (int r = 0; r < R; ++r)
      for (int c = 0; c < C; ++c) {
        float v = lo ? inf : -inf;
        for (int rr = std::max(0, r - w); rr <= std::min(R - 1, r + w); ++rr)
          for (int cc = std::max(0, c - w); cc <= std::min(C - 1, c + w); ++cc)
            v = lo ? std::min(v, in[rr * C + cc]) : std::max(v, in[rr * C + cc]);
        out[r * C + c] = v;
      }
  };
  int prev_full = 3;  // Zhang et al.: the 3-cell window's threshold is dh0
  for (int w = 1;; w = std::min(2 * w, w_max)) {
    window(surface, eroded, w, true);
    for (float& v : eroded) v = v == inf ? -inf : v;
    window(eroded, opened, w, false);
    const float dh = static_cast<float>(
        std::min(dh_max, dh0 + slope * (2 * w + 1 - prev_full) * static_cast<float>(cell)));
    for (int i = 0; i < N; ++i) {
      if (opened[i] != -inf && zmin[i] - opened[i] > dh) nonground[i] = 1;
      surface[i] = opened[i] == -inf ? inf : opened[i];
    }
    prev_full = 2 * w + 1;
    if (w == w_max) break;
  }
  std::vector<float> out(N, NAN);
  for (int r = 0; r < R; ++r)
    for (int c = 0; c < C; ++c) {
      if (std::isnan(zmin[r * C + c])) continue;
      for (int rad = radius; rad <= std::max(R, C); rad = std::max(1, 2 * rad)) {
        double s = 0;
        int n = 0;
        for (int rr = std::max(0, r - rad); rr <= std::min(R - 1, r + rad); ++rr)
          for (int cc = std::max(0, c - rad); cc <= std::min(C - 1, c + rad); ++cc) {
            const int i = rr * C + cc;
            if (!std::isnan(zmin[i]) && !nonground[i]) {
              s += zmin[i];
              ++n;
            }
          }
        if (n > 0) {
          out[r * C + c] = zmax[r * C + c] - static_cast<float>(s / n);
          break;
        }
      }
    }
  return out;
}
}  // namespace

// Rough ground with random boxes (cars, hedges, walls; buildings `big_m` wide and deep when set)
// and a hole without returns, over a 40 m grid of 0.5 m cells.
void boxesScene(test::StageHarness& h, float big_m) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  struct Box {
    float x0, y0, w, d, h;
  };
  std::vector<Box> boxes;
  for (int b = 0; b < 25; ++b)
    boxes.push_back({-20 + 38 * u(rng), -20 + 38 * u(rng), 0.5f + 6 * u(rng), 0.5f + 3 * u(rng),
                     0.1f + 2 * u(rng)});
  if (big_m > 0)
    for (int b = 0; b < 4; ++b)
      boxes.push_back({-20 + 30 * u(rng), -20 + 30 * u(rng), big_m * (0.5f + u(rng)),
                       big_m * (0.5f + u(rng)), 3 + 2 * u(rng)});
  for (int i = 0; i < 60000; ++i) {
    const float x = -20 + 40 * u(rng), y = -20 + 40 * u(rng);
    if (std::hypot(x - 5.f, y + 5.f) < 3.f) continue;  // a hole without returns
    float z = -1.7f + 0.02f * x + 0.05f * u(rng);
    if (big_m > 0) z += 0.8f * u(rng) * u(rng);  // rougher: each window's opening differs
    for (const Box& b : boxes)
      if (x >= b.x0 && x < b.x0 + b.w && y >= b.y0 && y < b.y0 + b.d)
        z = -1.7f + b.h * u(rng) + b.h;
    h.frame.points.push_back(x, y, z, 0);
  }
  h.bin();
}

// The stage with `params` against the brute-force filter with windows up to `w_max` cells (half
// width), on the widest vectors of this CPU and on SSE2 (the same bits).
void expectBruteForce(const char* params, int w_max, float big_m) {
  test::StageHarness h(40, 0.5);
  boxesScene(h, big_m);
  const auto& zr = h.grid.zRange(h.frame.points);
  const std::vector<float> ref =
      referenceHag(h.grid, zr.min, zr.max, w_max, 0.5, 0.1, 0.05, 2.5, 1);
  std::vector<float> got[2];
  for (const bool sse2 : {false, true}) {
    SCOPED_TRACE(sse2 ? "SSE2" : "widest vectors of this CPU");
    std::optional<test::ScopedEnv> env;
    if (sse2) env.emplace("TERRAMRF_SIMD", "sse2");
    h.make("height_above_ground", params)->process(h.ctx);
    got[sse2] = h.grid.layer("height_above_ground");
    int valid = 0, raised = 0;
    for (std::size_t i = 0; i < ref.size(); ++i) {
      ASSERT_EQ(std::isnan(got[sse2][i]), std::isnan(ref[i])) << "cell " << i;
      if (std::isnan(ref[i])) continue;
      ++valid;
      raised += ref[i] > 0.3f;
      EXPECT_NEAR(got[sse2][i], ref[i], 1e-5) << "cell " << i;
    }
    EXPECT_GT(valid, 5500);
    EXPECT_GT(raised, 200);  // the boxes stand out
  }
  EXPECT_EQ(0, std::memcmp(got[0].data(), got[1].data(), got[0].size() * sizeof(float)));
}

// The plugin's defaults: windows up to 8 m = 17 cells, each cell's window scanned in full.
TEST(HeightAboveGround, EqualsBruteForceFilterOnBothVectorPaths) { expectBruteForce("{}", 8, 0); }

// Van Herk's block algorithm against scanning every window, bit for bit: grids wider and taller
// than the window and narrower, sizes that are and are not multiples of the block, cells without
// data (the neutral element), erosion and dilation.
TEST(HeightAboveGround, BlockWindowPicksEqualScanningEachWindow) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-3.f, 3.f);
  const float inf = std::numeric_limits<float>::infinity();
  int cases = 0;
  for (const auto& [R, C] : {std::pair{1, 1}, {7, 40}, {40, 7}, {33, 33}, {66, 65}, {100, 90}})
    for (const int w : {1, 2, 3, 16, 17, 32, 50, 120}) {
      std::vector<float> in(std::size_t(R) * C);
      for (float& v : in) v = u(rng) < -2.f ? inf : u(rng);
      std::vector<float> tmp, want, got, g, h, line;
      std::vector<float> neg = in;
      for (float& v : neg) v = v == inf ? -inf : v;
      hag::morph<true>(in, tmp, want, R, C, w);
      hag::morphBlocks<true>(in, tmp, got, R, C, w, g, h, line);
      ASSERT_EQ(want, got) << "min, " << R << " x " << C << ", w " << w;
      hag::morph<false>(neg, tmp, want, R, C, w);
      hag::morphBlocks<false>(neg, tmp, got, R, C, w, g, h, line);
      ASSERT_EQ(want, got) << "max, " << R << " x " << C << ", w " << w;
      ++cases;
    }
  EXPECT_EQ(cases, 48);
}

// Windows of 33, 65 and 81 cells (40 m over the whole grid and beyond its edges) take van Herk's
// block algorithm, which must give what scanning each window does; buildings 6–18 m wide are
// what only those windows remove.
TEST(HeightAboveGround, LargeWindowsEqualBruteForceFilter) {
  expectBruteForce("{max_window_m: 40}", 40, 12);
}

}  // namespace terramrf
