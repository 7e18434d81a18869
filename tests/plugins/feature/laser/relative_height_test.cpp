#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "plugin_harness.hpp"

namespace terramrf {

TEST(RelativeHeight, DitchFloorIsBelowItsSurroundings) {
  test::StageHarness h;
  // Flat ground at −1.7 m with a 1 m deep, one-cell-wide trench along x at y ∈ [2, 2.5).
  for (double x = -5; x < 5; x += 0.1)
    for (double y = -5; y < 5; y += 0.1) {
      const bool trench = y >= 2.0 && y < 2.5;
      h.frame.points.push_back(float(x + 0.05), float(y + 0.05), trench ? -2.7f : -1.7f, 0);
    }
  h.bin();
  h.make("relative_height", "{radius_cells: 2}")->process(h.ctx);
  EXPECT_NEAR(h.at("relative_height", 0.2, 2.2), -1.0, 1e-5);
  EXPECT_NEAR(h.at("relative_height", 0.2, -2.2), 0.0, 1e-5);
  // Next to the trench most neighbours are ground: the median stays at ground level.
  EXPECT_NEAR(h.at("relative_height", 0.2, 1.7), 0.0, 1e-5);
}

// Against the definition, computed the obvious way (nth_element per cell), on random grids with
// empty cells, ties (heights on a 1 cm lattice) and every radius and quantile the fast selection
// (a walk from the neighbour's reference, rank selection where that does not apply) must handle.
TEST(RelativeHeight, EqualsTheMedianOfItsNeighboursOnRandomGrids) {
  std::mt19937 rng(7);
  for (const auto& [radius, quantile] : std::vector<std::pair<int, double>>{
           {1, 0.5}, {2, 0.5}, {3, 0.5}, {5, 0.5}, {3, 0.2}, {2, 0.9}, {3, 0.0}, {4, 1.0}}) {
    test::StageHarness h(10, 0.5);  // 20 × 20 cells
    std::uniform_real_distribution<float> pos(-5.f, 5.f);
    std::uniform_int_distribution<int> level(-30, 30);
    for (int i = 0; i < 500; ++i)
      h.frame.points.push_back(pos(rng), pos(rng), -1.7f + 0.01f * level(rng), 0);
    h.bin();
    h.make("relative_height", "{radius_cells: " + std::to_string(radius) +
                                  ", min_neighbours: 1, quantile: " + std::to_string(quantile) +
                                  "}")
        ->process(h.ctx);
    const TerrainGrid& g = h.grid;
    std::vector<float> zmin(g.cells(), NAN);
    for (std::size_t i = 0; i < h.frame.points.size(); ++i) {
      const int c = g.cellOfPoint()[i];
      if (c >= 0) zmin[c] = std::isnan(zmin[c]) ? h.frame.points.z[i] : std::min(zmin[c], h.frame.points.z[i]);
    }
    int checked = 0;
    for (int r = 0; r < g.rows(); ++r)
      for (int c = 0; c < g.cols(); ++c) {
        const float out = g.layer("relative_height")[g.index(r, c)];
        const float z = zmin[g.index(r, c)];
        std::vector<float> w;
        for (int rr = std::max(0, r - radius); rr <= std::min(g.rows() - 1, r + radius); ++rr)
          for (int cc = std::max(0, c - radius); cc <= std::min(g.cols() - 1, c + radius); ++cc)
            if ((rr != r || cc != c) && !std::isnan(zmin[g.index(rr, cc)])) w.push_back(zmin[g.index(rr, cc)]);
        if (std::isnan(z) || w.empty()) {
          EXPECT_TRUE(std::isnan(out)) << r << "," << c;
          continue;
        }
        const int n = static_cast<int>(w.size()),
                  k = std::min(n - 1, static_cast<int>(quantile * n));
        std::nth_element(w.begin(), w.begin() + k, w.end());
        ASSERT_EQ(out, z - w[k]) << "radius " << radius << " quantile " << quantile << " cell " << r
                                 << "," << c;
        ++checked;
      }
    EXPECT_GT(checked, 250) << radius;  // ~70 % of 400 cells hold a point
  }
}

}  // namespace terramrf

namespace terramrf {

// The foot of a hedge: a ground cell in the inner corner of an L-shaped hedge, whose lowest
// returns are 0.5 m up (the ground under it is hidden). Of its 24 neighbours (radius 2) 16 are
// hedge: against their median the cell sits 0.5 m "below ground" like a ditch floor; against
// their lower quartile (8 ground values come first) it is ground.
TEST(RelativeHeight, QuantileKeepsTheFootOfAHedgeAtGround) {
  test::StageHarness h;
  for (double x = -5; x < 5; x += 0.1)
    for (double y = -5; y < 5; y += 0.1) {
      const bool hedge = x + 0.05 >= 0.5 || y + 0.05 >= 0.5;
      h.frame.points.push_back(float(x + 0.05), float(y + 0.05), hedge ? -1.2f : -1.7f, 0);
    }
  h.bin();
  h.make("relative_height", "{radius_cells: 2}")->process(h.ctx);
  EXPECT_NEAR(h.at("relative_height", 0.2, 0.2), -0.5, 1e-5);
  EXPECT_NEAR(h.at("relative_height", -2.2, -2.2), 0.0, 1e-5);
  h.make("relative_height", "{radius_cells: 2, quantile: 0.25}")->process(h.ctx);
  EXPECT_NEAR(h.at("relative_height", 0.2, 0.2), 0.0, 1e-5);
  EXPECT_NEAR(h.at("relative_height", -2.2, -2.2), 0.0, 1e-5);
  // A hedge cell is level with the hedge around it, and a trench floor stays below the quartile.
  EXPECT_NEAR(h.at("relative_height", 2.2, 2.2), 0.0, 1e-5);
}

}  // namespace terramrf
