#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "terramrf/terrain_grid.hpp"
#include "test_support.hpp"

namespace terramrf {

TEST(GridGeometry, DefaultIsPaperGrid) {
  GridGeometry g;  // paper 000 §4.1: 40 × 40 m, 0.5 m cells → 80 × 80
  EXPECT_EQ(g.rows(), 80);
  EXPECT_EQ(g.cols(), 80);
  EXPECT_EQ(g.cells(), 6400u);
  EXPECT_DOUBLE_EQ(g.origin().x(), -20.0);
}

TEST(GridGeometry, CellOfCornersAndOutside) {
  GridGeometry g;
  g.size_m = 20;
  g.cell_m = 0.5;
  EXPECT_EQ(g.cellOf(-10.0, -10.0), 0);
  EXPECT_EQ(g.cellOf(-9.76, -9.26), 0 * 40 + 1);
  EXPECT_EQ(g.cellOf(0.1, 0.1), 20 * 40 + 20);
  EXPECT_EQ(g.cellOf(9.99, 9.99), 39 * 40 + 39);
  EXPECT_EQ(g.cellOf(10.0, 0.0), -1);
  EXPECT_EQ(g.cellOf(0.0, -10.01), -1);
  EXPECT_EQ(g.cellOf(std::nan(""), 0.0), -1);
}

TEST(TerrainGrid, BinPointsBuildsCsr) {
  GridGeometry g;
  g.size_m = 20;
  TerrainGrid grid(g);
  PointCloud pc;
  pc.push_back(0.1f, 0.1f, 0, 0);    // cell 820
  pc.push_back(50.f, 0.f, 0, 0);     // outside
  pc.push_back(0.2f, 0.3f, 1, 0);    // cell 820
  pc.push_back(-9.9f, -9.9f, 0, 0);  // cell 0
  pc.push_back(NAN, 0.f, 0, 0);      // outside (NaN)
  grid.binPoints(pc);
  EXPECT_EQ(grid.pointsInside(), 3u);
  EXPECT_EQ(grid.count(820), 2u);
  EXPECT_EQ(grid.count(0), 1u);
  EXPECT_EQ(grid.count(1), 0u);
  EXPECT_EQ(grid.pointsBegin(820)[0], 0u);
  EXPECT_EQ(grid.pointsBegin(820)[1], 2u);
  EXPECT_EQ(grid.pointsBegin(0)[0], 3u);
  EXPECT_EQ(grid.cellOfPoint()[1], -1);
  EXPECT_EQ(grid.cellOfPoint()[4], -1);
  EXPECT_EQ(grid.cellOfPoint()[2], 820);
}

// The z ranges shared by the height features and camera fusion: each cell's lowest, highest and
// mean point as a walk over its points finds them (the mean to the bit, summed in the same order),
// NaN for empty cells, recomputed after every binPoints.
TEST(TerrainGrid, ZRangeIsEachCellsLowestHighestAndMeanPoint) {
  GridGeometry g;
  g.size_m = 10;
  g.cell_m = 1;
  TerrainGrid grid(g);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> xy(-6.f, 6.f), z(-2.f, 3.f);
  for (int round = 0; round < 2; ++round) {
    PointCloud pc;
    for (int i = 0; i < 300 + 50 * round; ++i) pc.push_back(xy(rng), xy(rng), z(rng), 0);
    grid.binPoints(pc);
    const TerrainGrid::ZRange& r = grid.zRange(pc);
    ASSERT_EQ(r.min.size(), grid.cells());
    int empty = 0;
    for (int c = 0; c < static_cast<int>(grid.cells()); ++c) {
      float lo = std::numeric_limits<float>::infinity(), hi = -lo;
      double sum = 0;
      for (const uint32_t* it = grid.pointsBegin(c); it != grid.pointsEnd(c); ++it) {
        lo = std::min(lo, pc.z[*it]);
        hi = std::max(hi, pc.z[*it]);
        sum += pc.z[*it];
      }
      if (grid.count(c) == 0) {
        ++empty;
        EXPECT_TRUE(std::isnan(r.min[c]) && std::isnan(r.max[c]) && std::isnan(r.mean[c]))
            << "cell " << c;
      } else {
        EXPECT_EQ(r.min[c], lo) << "round " << round << " cell " << c;
        EXPECT_EQ(r.max[c], hi) << "round " << round << " cell " << c;
        EXPECT_EQ(r.mean[c], sum / grid.count(c)) << "round " << round << " cell " << c;
      }
    }
    EXPECT_GT(empty, 0) << "round " << round << ": some cells should be empty";
    EXPECT_LT(empty, 50) << "round " << round << ": most cells should hold points";
  }
  // A grid reset (no points binned) has no cells with points.
  grid.reset(g);
  PointCloud none;
  grid.binPoints(none);
  const auto& r = grid.zRange(none);
  for (float v : r.min) EXPECT_TRUE(std::isnan(v));
  for (double v : r.mean) EXPECT_TRUE(std::isnan(v));
}

// A grid received from elsewhere (Frame::grid): the named layers and, on request, the labels;
// nothing else, and only for the run's geometry and sizes.
TEST(TerrainGrid, AdoptLayersTakesTheNamedLayersOfTheRunsGeometryOnly) {
  GridGeometry g;
  g.size_m = 4;
  g.cell_m = 1;
  TerrainGrid from(g);
  from.add("a", 1.5f);
  from.add("b", 2.5f);
  from.labels().assign(from.cells(), labels::kRoad);
  TerrainGrid mine(g);
  mine.add("b", 9.f);
  mine.adoptLayers(from, {"a"}, false);
  EXPECT_EQ(mine.layer("a"), std::vector<float>(16, 1.5f));
  EXPECT_EQ(mine.layer("b"), std::vector<float>(16, 9.f));  // not named: its own
  EXPECT_EQ(mine.labels(), std::vector<LabelId>(16, labels::kUnknown));
  mine.adoptLayers(from, {"a", "b"}, true);
  EXPECT_EQ(mine.layer("b"), std::vector<float>(16, 2.5f));
  EXPECT_EQ(mine.labels(), std::vector<LabelId>(16, labels::kRoad));

  auto refused = [&](const TerrainGrid& other, const std::vector<std::string>& names,
                     const std::string& why) {
    TerrainGrid t(g);
    try {
      t.adoptLayers(other, names, false);
      ADD_FAILURE() << "adopted: " << why;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
    EXPECT_TRUE(t.layerNames().empty());  // nothing taken
  };
  GridGeometry moved = g;
  moved.centre_m = {0.5, 0};
  TerrainGrid elsewhere(moved);
  elsewhere.add("a", 1.f);
  refused(elsewhere, {"a"}, "centred at (0.500000, 0.000000) m; the run's is 4 x 4 cells");
  refused(from, {"a", "c"}, "has no layer 'c'");
  TerrainGrid short_layer(g);
  short_layer.add("a", 1.f).resize(5);
  refused(short_layer, {"a"}, "layer 'a' of the grid received has 5 values for 16 cells");
}

TEST(TerrainGrid, ZRangeRejectsAnotherCloud) {
  TerrainGrid grid{GridGeometry{}};
  PointCloud pc, other;
  pc.push_back(0.1f, 0.1f, 1.f, 0);
  other = pc;
  other.push_back(0.2f, 0.2f, 2.f, 0);
  grid.binPoints(pc);
  try {
    grid.zRange(other);
    FAIL() << "expected std::logic_error";
  } catch (const std::logic_error& e) {
    EXPECT_NE(std::string(e.what()).find("binPoints"), std::string::npos) << e.what();
  }
}

// binPoints walks dense clouds (8+ points per cell: here from 800 points) in four blocks side
// by side, sparse ones in one; whatever the cloud's size (not a multiple of four, fewer than four
// points) every cell must list its points in increasing index order, as one pass in index order
// would. Clustered points make long runs in one cell, as a LiDAR scan does.
TEST(TerrainGrid, EveryCellListsItsPointsInIndexOrder) {
  GridGeometry g;
  g.size_m = 10;
  g.cell_m = 1;
  std::mt19937 rng(7);
  std::normal_distribution<float> near(0.f, 2.f), far(0.f, 9.f);
  for (const std::size_t n : {0u, 1u, 3u, 4u, 5u, 1001u, 40003u}) {
    PointCloud pc;
    for (std::size_t i = 0; i < n; ++i) {
      const bool wide = (i / 50) % 3 == 0;
      pc.push_back(wide ? far(rng) : near(rng), wide ? far(rng) : near(rng), 0, 0);
    }
    TerrainGrid grid(g);
    grid.binPoints(pc);
    std::vector<std::vector<uint32_t>> expected(g.cells());
    std::size_t inside = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const int c = g.cellOf(pc.x[i], pc.y[i]);
      ASSERT_EQ(grid.cellOfPoint()[i], c) << "n " << n << " point " << i;
      if (c >= 0) expected[c].push_back(static_cast<uint32_t>(i)), ++inside;
    }
    EXPECT_EQ(grid.pointsInside(), inside);
    for (int c = 0; c < static_cast<int>(g.cells()); ++c)
      ASSERT_EQ(std::vector<uint32_t>(grid.pointsBegin(c), grid.pointsEnd(c)), expected[c])
          << "n " << n << " cell " << c;
  }
}

// Where the CPU has AVX2 the cells are computed eight points at a time; the scalar path must
// give the same cells for points on the borders, beyond them, far away and not finite.
TEST(TerrainGrid, VectorAndScalarBinningAgree) {
  GridGeometry g;
  g.size_m = 10;
  g.cell_m = 0.5;
  const float lo = static_cast<float>(g.origin().x()), hi = lo + 10.f;
  const float edge[] = {lo,
                        std::nextafter(lo, -1e9f),
                        std::nextafter(lo, 1e9f),
                        hi,
                        std::nextafter(hi, -1e9f),
                        0.f,
                        -0.f,
                        0.25f,
                        1e30f,
                        -1e30f,
                        3e9f,
                        std::numeric_limits<float>::quiet_NaN(),
                        std::numeric_limits<float>::infinity()};
  PointCloud pc;
  for (float x : edge)
    for (float y : edge) pc.push_back(x, y, 0, 0);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-7.f, 7.f);
  for (int i = 0; i < 1000; ++i) pc.push_back(u(rng), u(rng), 0, 0);
  TerrainGrid wide(g), narrow(g);
  wide.binPoints(pc);
  {
    test::ScopedEnv sse2("TERRAMRF_SIMD", "sse2");
    narrow.binPoints(pc);
  }
  EXPECT_EQ(wide.cellOfPoint(), narrow.cellOfPoint());
  for (int c = 0; c < static_cast<int>(g.cells()); ++c)
    ASSERT_EQ(std::vector<uint32_t>(wide.pointsBegin(c), wide.pointsEnd(c)),
              std::vector<uint32_t>(narrow.pointsBegin(c), narrow.pointsEnd(c)));
  // Far and non-finite points are outside, on both paths.
  for (std::size_t i = 0; i < pc.size(); ++i)
    if (!(std::fabs(pc.x[i]) < 1e9f && std::fabs(pc.y[i]) < 1e9f))
      EXPECT_EQ(narrow.cellOfPoint()[i], -1) << pc.x[i] << ", " << pc.y[i];
}

TEST(TerrainGrid, LayersAreNaNByDefaultAndNamed) {
  TerrainGrid grid{GridGeometry{}};
  Layer& l = grid.add("height_diff");
  EXPECT_EQ(l.size(), 6400u);
  EXPECT_TRUE(std::isnan(l[17]));
  EXPECT_TRUE(grid.has("height_diff"));
  EXPECT_THROW(grid.layer("nope"), std::out_of_range);
  EXPECT_EQ(grid.labels().size(), 6400u);
  EXPECT_EQ(grid.labels()[5], labels::kUnknown);
}

TEST(TerrainGrid, EmptyCloudGivesEmptyCells) {
  TerrainGrid grid{GridGeometry{}};
  grid.binPoints(PointCloud{});
  EXPECT_EQ(grid.pointsInside(), 0u);
  for (int c = 0; c < 6400; ++c) ASSERT_EQ(grid.count(c), 0u);
}

}  // namespace terramrf
