#include "terramrf/terrain_grid.hpp"

#include <stdexcept>

namespace terramrf {

void TerrainGrid::reset(const GridGeometry& g) {
  geom_ = g;
  rows_ = g.rows();
  cols_ = g.cols();
  for (auto& kv : layers_) kv.second.clear();
  layers_.clear();
  labels_.assign(cells(), labels::kUnknown);
  offsets_.assign(cells() + 1, 0);
  indices_.clear();
  cell_of_point_.clear();
  cell_pixels_.clear();
}

Layer& TerrainGrid::add(const std::string& name, float fill) {
  Layer& l = layers_[name];
  l.assign(cells(), fill);
  return l;
}

Layer& TerrainGrid::layer(const std::string& name) {
  auto it = layers_.find(name);
  if (it == layers_.end()) throw std::out_of_range("grid has no layer '" + name + "'");
  return it->second;
}

const Layer& TerrainGrid::layer(const std::string& name) const {
  auto it = layers_.find(name);
  if (it == layers_.end()) throw std::out_of_range("grid has no layer '" + name + "'");
  return it->second;
}

std::vector<std::string> TerrainGrid::layerNames() const {
  std::vector<std::string> n;
  for (const auto& kv : layers_) n.push_back(kv.first);
  return n;
}

void TerrainGrid::binPoints(const PointCloud& cloud) {
  // Counting sort into CSR: one pass for cell ids and counts, one prefix sum, one scatter. No
  // per-cell allocations, so the cost is linear in points plus cells.
  const std::size_t n = cloud.size();
  const int cols = cols_, rows = rows_;
  const Eigen::Vector2d o = geom_.origin();
  const float ox = static_cast<float>(o.x()), oy = static_cast<float>(o.y());
  const float inv = static_cast<float>(1.0 / geom_.cell_m);
  cell_of_point_.resize(n);
  offsets_.assign(cells() + 1, 0);
  const float* px = cloud.x.data();
  const float* py = cloud.y.data();
  int32_t* cop = cell_of_point_.data();
  uint32_t* cnt = offsets_.data() + 1;
  for (std::size_t i = 0; i < n; ++i) {
    const float fr = (px[i] - ox) * inv, fc = (py[i] - oy) * inv;
    int32_t cell = -1;
    if (fr >= 0.f && fc >= 0.f) {
      const int r = static_cast<int>(fr), c = static_cast<int>(fc);
      if (r < rows && c < cols) cell = r * cols + c;
    }
    cop[i] = cell;
    if (cell >= 0) ++cnt[cell];
  }
  for (std::size_t c = 1; c <= cells(); ++c) offsets_[c] += offsets_[c - 1];
  indices_.resize(offsets_[cells()]);
  // Scatter with a moving cursor per cell; reuse a scratch copy of the offsets.
  thread_local std::vector<uint32_t> cursor;
  cursor.assign(offsets_.begin(), offsets_.end() - 1);
  for (std::size_t i = 0; i < n; ++i) {
    const int32_t c = cop[i];
    if (c >= 0) indices_[cursor[c]++] = static_cast<uint32_t>(i);
  }
}

}  // namespace terramrf
