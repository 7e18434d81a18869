// Carrying layers between grid placements (grid_warp.hpp), checked on cases with an exact answer:
// whole-cell translations, quarter turns, linear ramps, and map windows moved back and forth.
#include "terramrf/grid_warp.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace terramrf {
namespace {

GridGeometry geometry(double size_m, double cell_m, Eigen::Vector2d centre = {0, 0}) {
  GridGeometry g;
  g.size_m = size_m;
  g.cell_m = cell_m;
  g.centre_m = centre;
  return g;
}

Eigen::Isometry3d pose(double x, double y, double yaw_rad) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, y, 0);
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

// A layer with distinct values: row·1000 + column.
Layer indexLayer(const GridGeometry& g) {
  Layer l(g.cells());
  for (int r = 0; r < g.rows(); ++r)
    for (int c = 0; c < g.cols(); ++c) l[std::size_t(r) * g.cols() + c] = float(r * 1000 + c);
  return l;
}

}  // namespace

// The vehicle drove 3 cells forward (x) and 2 left (y): this frame's cell (r, c) is the previous
// frame's (r + 3, c + 2), and the last rows/columns see nothing of it.
TEST(GridWarp, WholeCellTranslationShiftsCells) {
  const GridGeometry g = geometry(10, 0.5);  // 20 × 20
  const Eigen::Isometry3d prev = pose(100, 50, 0), cur = pose(101.5, 51.0, 0);
  const auto under = cellsUnder(g, g, prev.inverse() * cur);
  const Layer moved = resampleNearest(indexLayer(g), under);
  for (int r = 0; r < 20; ++r)
    for (int c = 0; c < 20; ++c) {
      const float v = moved[std::size_t(r) * 20 + c];
      if (r + 3 < 20 && c + 2 < 20)
        EXPECT_EQ(v, float((r + 3) * 1000 + c + 2)) << r << "," << c;
      else
        EXPECT_TRUE(std::isnan(v)) << r << "," << c;
    }
}

// A quarter turn left about the grid centre: this frame's x axis is the previous frame's y axis,
// so cell (r, c) was cell (c, n−1−r). Every cell maps, none twice.
TEST(GridWarp, QuarterTurnPermutesCells) {
  const GridGeometry g = geometry(8, 0.5);  // 16 × 16, centred on the sensor
  const auto under = cellsUnder(g, g, pose(0, 0, M_PI / 2));
  std::vector<int> hits(g.cells(), 0);
  for (int r = 0; r < 16; ++r)
    for (int c = 0; c < 16; ++c) {
      const int32_t k = under[std::size_t(r) * 16 + c];
      ASSERT_GE(k, 0);
      EXPECT_EQ(k, (15 - c) * 16 + r) << r << "," << c;
      ++hits[k];
    }
  for (int h : hits) EXPECT_EQ(h, 1);
  std::vector<LabelId> labels(g.cells(), 1);
  labels[(15 - 0) * 16 + 0] = 2;  // under cell (0, 0)
  const auto carried = resampleLabels(labels, under);
  EXPECT_EQ(carried[0], 2);
  EXPECT_EQ(carried[1], 1);
}

// Labels are never invented outside the previous grid.
TEST(GridWarp, LabelsOutsideThePreviousGridAreUnknown) {
  const GridGeometry g = geometry(10, 0.5);
  const auto under = cellsUnder(g, g, pose(7.0, 0, 0));  // 14 rows beyond the previous grid
  std::vector<LabelId> labels(g.cells(), 3);
  const auto carried = resampleLabels(labels, under);
  for (int r = 0; r < 20; ++r)
    EXPECT_EQ(carried[std::size_t(r) * 20], r < 6 ? LabelId(3) : labels::kUnknown) << r;
}

// Bilinear resampling reproduces a plane at any sub-cell offset and rotation where its four
// neighbours have data, and a hole or the border reweights instead of pulling towards 0.
TEST(GridWarp, BilinearIsExactOnAPlaneAndSkipsHoles) {
  const GridGeometry src = geometry(20, 0.5), dst = geometry(10, 0.25);
  auto plane = [](double x, double y) { return 2.0 + 0.3 * x - 0.7 * y; };
  Layer l(src.cells());
  for (int r = 0; r < src.rows(); ++r)
    for (int c = 0; c < src.cols(); ++c) {
      const Eigen::Vector2d m = src.cellCentre(r, c);
      l[std::size_t(r) * src.cols() + c] = float(plane(m.x(), m.y()));
    }
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> off(-1.3, 1.3), yaw(-M_PI, M_PI);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Isometry3d T = pose(off(rng), off(rng), yaw(rng));
    const Layer out = resampleBilinear(l, src, dst, T);
    for (int r = 0; r < dst.rows(); ++r)
      for (int c = 0; c < dst.cols(); ++c) {
        const Eigen::Vector2d m = dst.cellCentre(r, c);
        const Eigen::Vector3d q = T * Eigen::Vector3d(m.x(), m.y(), 0);
        ASSERT_NEAR(out[std::size_t(r) * dst.cols() + c], plane(q.x(), q.y()), 2e-4)
            << "trial " << trial << " cell " << r << "," << c;
      }
  }
  // A hole: the neighbours with data decide, in proportion to their weights.
  Layer holed(src.cells(), 1.0f);
  const GridGeometry one = geometry(0.5, 0.5);  // one cell, centre (0, 0)
  holed[std::size_t(20) * 40 + 20] = kNoData;   // the src cell centred at (0.25, 0.25)
  holed[std::size_t(19) * 40 + 20] = 5.0f;      // centred at (-0.25, 0.25)
  const float v = resampleBilinear(holed, src, one, pose(0, 0, 0))[0];
  EXPECT_NEAR(v, (5.0 + 1.0 + 1.0) / 3.0, 1e-6);  // four equal weights, one of them a hole
  // All four without data, or outside the source grid: no data.
  Layer empty(src.cells(), kNoData);
  EXPECT_TRUE(std::isnan(resampleBilinear(empty, src, one, pose(0, 0, 0))[0]));
  EXPECT_TRUE(std::isnan(resampleBilinear(l, src, one, pose(30, 0, 0))[0]));
  EXPECT_THROW(resampleBilinear(Layer(3), src, one, pose(0, 0, 0)), std::invalid_argument);
}

// A world-fixed map window follows the vehicle by whole cells: what both windows cover keeps
// its values and labels, what enters is empty, and moving back restores the overlap exactly.
TEST(GridWarp, MoveGridKeepsTheOverlapAndTheLattice) {
  TerrainGrid map(geometry(10, 0.5, {100.0, 200.0}));  // 20 × 20
  Layer& h = map.add("height");
  h = indexLayer(map.geometry());
  for (std::size_t k = 0; k < map.cells(); ++k) map.labels()[k] = LabelId(1 + k % 3);
  const Layer before = h;
  const auto labels_before = map.labels();

  // 1.3 m forward and 0.6 m right: the lattice keeps its place, so 3 rows and -1 column.
  const Eigen::Vector2i s = moveGrid(map, {101.3, 199.4});
  EXPECT_EQ(s, Eigen::Vector2i(3, -1));
  EXPECT_DOUBLE_EQ(map.geometry().centre_m.x(), 101.5);
  EXPECT_DOUBLE_EQ(map.geometry().centre_m.y(), 199.5);
  const Layer& moved = map.layer("height");
  for (int r = 0; r < 20; ++r)
    for (int c = 0; c < 20; ++c) {
      const std::size_t k = std::size_t(r) * 20 + c;
      const int orow = r + 3, ocol = c - 1;
      if (orow < 20 && ocol >= 0) {
        EXPECT_EQ(moved[k], before[std::size_t(orow) * 20 + ocol]) << r << "," << c;
        EXPECT_EQ(map.labels()[k], labels_before[std::size_t(orow) * 20 + ocol]);
        // The same world point lies in both cells.
        EXPECT_EQ(map.geometry().cellCentre(r, c),
                  geometry(10, 0.5, {100.0, 200.0}).cellCentre(orow, ocol));
      } else {
        EXPECT_TRUE(std::isnan(moved[k])) << r << "," << c;
        EXPECT_EQ(map.labels()[k], labels::kUnknown);
      }
    }
  EXPECT_EQ(moveGrid(map, {100.0, 200.0}), Eigen::Vector2i(-3, 1));
  const Layer& back = map.layer("height");
  for (int r = 0; r < 20; ++r)
    for (int c = 0; c < 20; ++c) {
      const std::size_t k = std::size_t(r) * 20 + c;
      if (r >= 3 && c < 19) EXPECT_EQ(back[k], before[k]) << r << "," << c;
    }
  // Less than half a cell: nothing moves. A window moved past its size is empty.
  EXPECT_EQ(moveGrid(map, {100.2, 200.2}), Eigen::Vector2i(0, 0));
  moveGrid(map, {200.0, 200.0});
  for (float v : map.layer("height")) EXPECT_TRUE(std::isnan(v));
  EXPECT_THROW(moveGrid(map, {NAN, 0.0}), std::invalid_argument);
  EXPECT_THROW(moveGrid(map, {1e300, 0.0}), std::invalid_argument);
}

}  // namespace terramrf
