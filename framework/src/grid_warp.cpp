#include "terramrf/grid_warp.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace terramrf {
namespace {

// Calls f(k, q) for each cell k of `dst` (row-major) with its centre q in src's frame. The
// centres of a row are equally spaced, so their images are too: one transform per row and a step
// along it instead of a matrix product per cell.
template <class F>
void forEachCentre(const GridGeometry& dst, const Eigen::Isometry3d& T_src_dst, F f) {
  const int rows = dst.rows(), cols = dst.cols();
  const Eigen::Vector3d step = T_src_dst.linear() * Eigen::Vector3d(0, dst.cell_m, 0);
  for (int r = 0; r < rows; ++r) {
    const Eigen::Vector2d m = dst.cellCentre(r, 0);
    const Eigen::Vector3d q0 = T_src_dst * Eigen::Vector3d(m.x(), m.y(), 0);
    for (int c = 0; c < cols; ++c) f(std::size_t(r) * cols + c, q0 + double(c) * step);
  }
}

}  // namespace

std::vector<int32_t> cellsUnder(const GridGeometry& dst, const GridGeometry& src,
                                const Eigen::Isometry3d& T_src_dst) {
  std::vector<int32_t> out(dst.cells(), -1);
  forEachCentre(dst, T_src_dst, [&](std::size_t k, const Eigen::Vector3d& q) {
    out[k] = src.cellOf(q.x(), q.y());
  });
  return out;
}

Layer resampleNearest(const Layer& src, const std::vector<int32_t>& cells_under) {
  Layer out(cells_under.size(), kNoData);
  for (std::size_t k = 0; k < cells_under.size(); ++k)
    if (cells_under[k] >= 0) out[k] = src.at(std::size_t(cells_under[k]));
  return out;
}

std::vector<LabelId> resampleLabels(const std::vector<LabelId>& src,
                                    const std::vector<int32_t>& cells_under) {
  std::vector<LabelId> out(cells_under.size(), labels::kUnknown);
  for (std::size_t k = 0; k < cells_under.size(); ++k)
    if (cells_under[k] >= 0) out[k] = src.at(std::size_t(cells_under[k]));
  return out;
}

Layer resampleBilinear(const Layer& src, const GridGeometry& src_geom, const GridGeometry& dst,
                       const Eigen::Isometry3d& T_src_dst) {
  const int srows = src_geom.rows(), scols = src_geom.cols();
  if (src.size() != std::size_t(srows) * scols)
    throw std::invalid_argument("resampleBilinear: the layer has " + std::to_string(src.size()) +
                                " cells, its geometry " + std::to_string(srows) + " x " +
                                std::to_string(scols));
  Layer out(dst.cells(), kNoData);
  const Eigen::Vector2d o = src_geom.origin();
  const double inv = 1.0 / src_geom.cell_m;
  forEachCentre(dst, T_src_dst, [&](std::size_t k, const Eigen::Vector3d& q) {
    // Continuous cell coordinates with integers at the cell centres.
    const double fr = (q.x() - o.x()) * inv - 0.5, fc = (q.y() - o.y()) * inv - 0.5;
    if (!(fr > -1.0 && fc > -1.0 && fr < srows && fc < scols)) return;  // NaN too
    const int r0 = int(std::floor(fr)), c0 = int(std::floor(fc));
    const double tr = fr - r0, tc = fc - c0;
    double sum = 0, wsum = 0;
    for (int dr = 0; dr < 2; ++dr)
      for (int dc = 0; dc < 2; ++dc) {
        const int sr = r0 + dr, sc = c0 + dc;
        if (sr < 0 || sc < 0 || sr >= srows || sc >= scols) continue;
        const float v = src[std::size_t(sr) * scols + sc];
        if (std::isnan(v)) continue;
        const double w = (dr ? tr : 1 - tr) * (dc ? tc : 1 - tc);
        sum += w * v;
        wsum += w;
      }
    // wsum == 0 also when the point sits exactly on a cell centre whose value is missing.
    if (wsum > 0) out[k] = float(sum / wsum);
  });
  return out;
}

Eigen::Vector2i moveGrid(TerrainGrid& grid, const Eigen::Vector2d& centre_m) {
  const GridGeometry old = grid.geometry();
  const Eigen::Vector2d d = (centre_m - old.centre_m) / old.cell_m;
  constexpr double kMax = double(std::numeric_limits<int>::max() / 2);
  if (!d.allFinite() || std::abs(d.x()) > kMax || std::abs(d.y()) > kMax)
    throw std::invalid_argument(
        "moveGrid: centre (" + std::to_string(centre_m.x()) + ", " + std::to_string(centre_m.y()) +
        ") m is not a finite point within 2^30 cells of the map's centre (" +
        std::to_string(old.centre_m.x()) + ", " + std::to_string(old.centre_m.y()) + ") m");
  const Eigen::Vector2i shift(int(std::lround(d.x())), int(std::lround(d.y())));
  if (shift.isZero()) return shift;

  std::vector<std::pair<std::string, Layer>> layers;
  for (const auto& name : grid.layerNames()) layers.emplace_back(name, std::move(grid.layer(name)));
  std::vector<LabelId> labels = std::move(grid.labels());
  GridGeometry moved = old;
  moved.centre_m = old.centre_m + shift.cast<double>() * old.cell_m;
  grid.reset(moved);  // labels unknown, no layers, no points

  // New cell (r, c) is old cell (r + shift.x, c + shift.y): the overlap, row by row.
  const int rows = grid.rows(), cols = grid.cols();
  const int r_begin = std::max(0, -shift.x()), r_end = std::min(rows, rows - shift.x());
  const int c_begin = std::max(0, -shift.y()), c_end = std::min(cols, cols - shift.y());
  auto copyOverlap = [&](auto& to, const auto& from) {
    for (int r = r_begin; r < r_end; ++r)
      for (int c = c_begin; c < c_end; ++c)
        to[std::size_t(r) * cols + c] = from[std::size_t(r + shift.x()) * cols + (c + shift.y())];
  };
  for (auto& [name, values] : layers) copyOverlap(grid.add(name), values);
  if (labels.size() == grid.cells()) copyOverlap(grid.labels(), labels);
  return shift;
}

}  // namespace terramrf
