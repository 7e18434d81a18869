#pragma once
// A small hand-made labelled grid shared by the message tests.
#include <cmath>

#include "terramrf/terrain_grid.hpp"

namespace terramrf::test {

/// 4 × 4 cells of 0.5 m centred at (10, -3) [m], so origin = (9, -4). Labels: cell (3,0)
/// obstacle, (0,3) road, (1,2) rough, rest unknown. Layers "height" (row + col/10, NaN in cell
/// (2,2)) and "rough" (all NaN except cell 5 = 0.125). Points binned: 2 in cell (0,0), 1 in
/// cell (3,3), 1 outside.
inline TerrainGrid smallGrid() {
  GridGeometry g;
  g.size_m = 2.0;
  g.cell_m = 0.5;
  g.centre_m = Eigen::Vector2d(10.0, -3.0);
  TerrainGrid grid(g);
  grid.labels()[grid.index(3, 0)] = labels::kObstacle;
  grid.labels()[grid.index(0, 3)] = labels::kRoad;
  grid.labels()[grid.index(1, 2)] = labels::kRough;
  Layer& h = grid.add("height");
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) h[grid.index(r, c)] = static_cast<float>(r + c / 10.0);
  h[grid.index(2, 2)] = kNoData;
  grid.add("rough")[5] = 0.125f;
  PointCloud cloud;
  cloud.push_back(9.1f, -3.9f, 0.f, 1.f);
  cloud.push_back(9.4f, -3.6f, 0.f, 1.f);
  cloud.push_back(10.9f, -2.1f, 0.f, 1.f);
  cloud.push_back(50.f, 50.f, 0.f, 1.f);
  grid.binPoints(cloud);
  return grid;
}

/// Layer equality where NaN equals NaN.
inline bool sameLayer(const Layer& a, const Layer& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (std::isnan(a[i]) != std::isnan(b[i])) return false;
    if (!std::isnan(a[i]) && a[i] != b[i]) return false;
  }
  return true;
}

}  // namespace terramrf::test
