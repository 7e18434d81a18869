#include <gtest/gtest.h>

#include <cmath>

#include "terramrf/terrain_grid.hpp"

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
