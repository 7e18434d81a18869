#include "grid_render.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "terramrf/text_format.hpp"

namespace terramrf {

std::string gridImageSizeProblem(int cols, int rows, int ppc) {
  // In 64 bits: renderGrid takes any pixels_per_cell, and cols · ppc can overflow int.
  const int64_t w = int64_t(cols) * ppc, h = int64_t(rows) * ppc;
  if (w <= kMaxGridImageSidePx && h <= kMaxGridImageSidePx) return "";
  const int largest = kMaxGridImageSidePx / std::max({cols, rows, 1});
  return "pixels_per_cell " + std::to_string(ppc) + " on the grid's " + std::to_string(cols) +
         " x " + std::to_string(rows) + " cells makes a " + std::to_string(w) + " x " +
         std::to_string(h) + " px image (" + byteSize(double(w) * double(h) * 3) +
         " RGB per frame); expected at most " + std::to_string(kMaxGridImageSidePx) +
         " px per side" +
         (largest >= 1 ? ": pixels_per_cell <= " + std::to_string(largest) + " for this grid"
                       : ": this grid has more cells per side than that; write it with grid_csv");
}

Image renderGrid(const TerrainGrid& grid, const LabelSet& labels, int ppc, GridRenderStats* stats) {
  if (ppc < 1) throw std::invalid_argument("renderGrid: pixels_per_cell must be >= 1");
  const int rows = grid.rows(), cols = grid.cols();
  if (const std::string why = gridImageSizeProblem(cols, rows, ppc); !why.empty())
    throw std::invalid_argument("renderGrid: " + why);
  Image img(cols * ppc, rows * ppc, 3);
  GridRenderStats st;
  const auto& lab = grid.labels();
  const bool has_labels = lab.size() == grid.cells();
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const LabelId id = has_labels ? lab[grid.index(r, c)] : labels::kUnknown;
      std::array<uint8_t, 3> rgb = kUnnamedLabelRgb;
      if (id < labels.size()) {
        rgb = labels[id].rgb;
      } else {
        ++st.unnamed_label_cells;
      }
      const int v0 = (rows - 1 - r) * ppc, u0 = (cols - 1 - c) * ppc;
      for (int v = v0; v < v0 + ppc; ++v) {
        for (int u = u0; u < u0 + ppc; ++u) std::copy(rgb.begin(), rgb.end(), img.at(u, v));
      }
    }
  }

  // Sensor at (0, 0) of the grid frame, in fractional cells from the lower-left corner.
  const GridGeometry& g = grid.geometry();
  const Eigen::Vector2d o = g.origin();
  const double fr = -o.x() / g.cell_m, fc = -o.y() / g.cell_m;
  if (fr >= 0 && fr <= rows && fc >= 0 && fc <= cols) {
    // The continuous image position is ((cols - fc) ppc, (rows - fr) ppc); for a centred grid it
    // falls on a pixel corner, and the pixel below-right of it is taken as the centre.
    const int cu = std::min(img.width - 1, static_cast<int>(std::floor((cols - fc) * ppc)));
    const int cv = std::min(img.height - 1, static_cast<int>(std::floor((rows - fr) * ppc)));
    const int arm = std::max(2, ppc);
    for (int d = -arm; d <= arm; ++d) {
      if (cu + d >= 0 && cu + d < img.width)
        std::copy(kSensorRgb.begin(), kSensorRgb.end(), img.at(cu + d, cv));
      if (cv + d >= 0 && cv + d < img.height)
        std::copy(kSensorRgb.begin(), kSensorRgb.end(), img.at(cu, cv + d));
    }
    st.sensor_marked = true;
  }
  if (stats) *stats = st;
  return img;
}

}  // namespace terramrf
