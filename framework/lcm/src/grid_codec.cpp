#include "terramrf/lcm/grid_codec.hpp"

#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>
#include <terramrf_msgs/terrain_grid_t.hpp>

#include "lcm_bytes.hpp"
#include "terramrf/errors.hpp"

namespace terramrf {
namespace {

// binPoints() fills cellOfPoint(); before it, the point lists must not be read.
bool pointsBinned(const TerrainGrid& grid) { return !grid.cellOfPoint().empty(); }

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s.empty() ? "none" : s;
}

}  // namespace

std::vector<uint32_t> pointCounts(const TerrainGrid& grid) {
  std::vector<uint32_t> counts(grid.cells(), 0);
  if (!pointsBinned(grid)) return counts;
  for (std::size_t c = 0; c < counts.size(); ++c) counts[c] = grid.count(static_cast<int>(c));
  return counts;
}

MessageBytes encodeGrid(const TerrainGrid& grid, const LabelSet& labels,
                        const MessageHeader& header, const std::vector<std::string>& layers) {
  const std::size_t cells = grid.cells();
  if (cells > static_cast<std::size_t>(std::numeric_limits<int32_t>::max())) {
    throw std::invalid_argument("encodeGrid: grid of " + std::to_string(cells) +
                                " cells is too large for terrain_grid_t");
  }
  terramrf_msgs::terrain_grid_t m;
  m.utime = toUtime(header.timestamp_s);
  m.frame_id = header.frame_id;
  m.coordinate_frame = header.coordinate_frame;
  const GridGeometry& g = grid.geometry();
  m.rows = grid.rows();
  m.cols = grid.cols();
  m.cell_m = g.cell_m;
  const Eigen::Vector2d origin = g.origin();
  m.origin_x_m = origin.x();
  m.origin_y_m = origin.y();
  m.num_cells = static_cast<int32_t>(cells);

  m.label_names = labels.names();
  m.num_label_names = static_cast<int16_t>(m.label_names.size());

  const auto& lab = grid.labels();
  if (lab.size() == cells) {
    // A receiver (decodeGrid included) refuses an id without a name: say it here, at the sender.
    for (std::size_t c = 0; c < cells; ++c)
      if (lab[c] >= m.label_names.size())
        throw std::invalid_argument("encodeGrid: cell " + std::to_string(c) + " has label id " +
                                    std::to_string(lab[c]) + " but the label set names only " +
                                    std::to_string(m.label_names.size()) + " classes");
    m.labels.assign(lab.begin(), lab.end());
  } else if (!lab.empty()) {
    throw std::invalid_argument("encodeGrid: label layer has " + std::to_string(lab.size()) +
                                " entries for " + std::to_string(cells) + " cells");
  }
  m.num_labels = static_cast<int32_t>(m.labels.size());

  if (pointsBinned(grid)) {
    const std::vector<uint32_t> counts = pointCounts(grid);
    m.point_counts.assign(counts.begin(), counts.end());
  }
  m.num_point_counts = static_cast<int32_t>(m.point_counts.size());

  m.layer_names = layers.empty() ? grid.layerNames() : layers;
  if (m.layer_names.size() > static_cast<std::size_t>(std::numeric_limits<int16_t>::max())) {
    throw std::invalid_argument("encodeGrid: too many layers");
  }
  m.layers.reserve(m.layer_names.size());
  for (const std::string& name : m.layer_names) {
    if (!grid.has(name)) {
      throw std::invalid_argument("encodeGrid: layer '" + name +
                                  "' is not in the grid (it has: " + join(grid.layerNames()) + ")");
    }
    const Layer& layer = grid.layer(name);
    if (layer.size() != cells) {
      throw std::invalid_argument("encodeGrid: layer '" + name + "' has " +
                                  std::to_string(layer.size()) + " values for " +
                                  std::to_string(cells) + " cells");
    }
    m.layers.push_back(layer);
  }
  m.num_layers = static_cast<int16_t>(m.layer_names.size());
  return lcm_detail::encodeMessage(m, "terrain_grid_t");
}

DecodedGrid decodeGrid(const void* data, std::size_t size, const std::string& source) {
  const auto m = lcm_detail::decodeMessage<terramrf_msgs::terrain_grid_t>(data, size, source,
                                                                          "terrain_grid_t");
  auto bad = [&](const std::string& what) { return InputError(source, "terrain_grid_t: " + what); };

  if (m.rows <= 0 || m.cols <= 0) {
    throw bad("rows and cols must be positive (got " + std::to_string(m.rows) + " x " +
              std::to_string(m.cols) + ")");
  }
  if (m.rows != m.cols) {
    throw bad("TerrainGrid is square; got " + std::to_string(m.rows) + " rows and " +
              std::to_string(m.cols) + " cols");
  }
  const std::size_t cells = std::size_t(m.rows) * std::size_t(m.cols);
  if (std::size_t(m.num_cells) != cells) {
    throw bad("num_cells " + std::to_string(m.num_cells) +
              " != rows * cols = " + std::to_string(cells));
  }
  if (!(std::isfinite(m.cell_m) && m.cell_m > 0) || !std::isfinite(m.origin_x_m) ||
      !std::isfinite(m.origin_y_m)) {
    throw bad("cell_m must be finite and > 0 and the origin finite");
  }
  if (m.num_labels != 0 && std::size_t(m.num_labels) != cells) {
    throw bad("num_labels must be 0 or num_cells (" + std::to_string(cells) + "), got " +
              std::to_string(m.num_labels));
  }
  if (m.num_point_counts != 0 && std::size_t(m.num_point_counts) != cells) {
    throw bad("num_point_counts must be 0 or num_cells, got " + std::to_string(m.num_point_counts));
  }

  DecodedGrid out;
  out.header.frame_id = m.frame_id;
  out.header.coordinate_frame = m.coordinate_frame;
  out.header.timestamp_s = fromUtime(m.utime);
  out.label_names = m.label_names;

  GridGeometry geom;
  geom.cell_m = m.cell_m;
  geom.size_m = m.cols * m.cell_m;
  geom.centre_m =
      Eigen::Vector2d(m.origin_x_m, m.origin_y_m) + Eigen::Vector2d::Constant(0.5 * geom.size_m);
  if (geom.cols() != m.cols) throw bad("geometry does not round-trip (cell_m too small?)");
  out.grid.reset(geom);

  if (m.num_labels > 0) {
    if (!m.label_names.empty()) {
      for (std::size_t c = 0; c < cells; ++c) {
        if (m.labels[c] >= m.label_names.size()) {
          throw bad("cell " + std::to_string(c) + " has label id " + std::to_string(m.labels[c]) +
                    " but only " + std::to_string(m.label_names.size()) + " label names");
        }
      }
    }
    out.grid.labels().assign(m.labels.begin(), m.labels.end());
    out.has_labels = true;
  }
  if (m.num_point_counts > 0) {
    out.point_counts.reserve(cells);
    for (int32_t n : m.point_counts) {
      if (n < 0) throw bad("negative point count " + std::to_string(n));
      out.point_counts.push_back(static_cast<uint32_t>(n));
    }
  }
  std::set<std::string> seen;
  for (int i = 0; i < m.num_layers; ++i) {
    const std::string& name = m.layer_names[i];
    if (!seen.insert(name).second) throw bad("layer '" + name + "' appears twice");
    out.grid.add(name) = m.layers[i];
  }
  return out;
}

}  // namespace terramrf
