#include "grid_csv_format.hpp"

#include "terramrf/evaluation.hpp"
#include "terramrf/text_format.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <stdexcept>
#include <type_traits>

namespace terramrf {
namespace {

template <class T>
void appendNumber(std::string& out, T v) {
  if constexpr (std::is_floating_point_v<T>) {
    if (std::isnan(v)) return;  // no data: empty field
  }
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v);
  out.append(buf, res.ptr);
}

}  // namespace

std::string gridToCsv(const TerrainGrid& grid, const LabelSet& labels,
                      const std::vector<std::string>& layer_names, const PointLabels* truth) {
  const std::vector<std::string> names = layer_names.empty() ? grid.layerNames() : layer_names;
  std::vector<const Layer*> layers;
  for (const auto& n : names) {
    if (!grid.has(n)) {
      std::string have;
      for (const auto& h : grid.layerNames()) have += (have.empty() ? "" : ", ") + h;
      throw std::invalid_argument("grid_csv: layer '" + n + "' is not in the grid (it has: " +
                                  (have.empty() ? "none" : have) + ")");
    }
    layers.push_back(&grid.layer(n));
  }
  const std::size_t cells = grid.cells();
  const auto& lab = grid.labels();
  const bool has_labels = lab.size() == cells;
  // binPoints() fills cellOfPoint(); before it the point lists must not be read (count = 0).
  const bool binned = !grid.cellOfPoint().empty();

  const bool truth_cols = truth != nullptr;
  const bool has_truth = truth_cols && !truth->empty() && binned;
  if (has_truth && truth->label.size() != grid.cellOfPoint().size()) {
    throw std::invalid_argument("grid_csv: the frame's ground truth has " +
                                std::to_string(truth->label.size()) + " labels for " +
                                std::to_string(grid.cellOfPoint().size()) +
                                " binned points; expected one label per point");
  }
  const int obstacle_id = labels.obstacle();
  std::vector<uint64_t> per_class(labels.size());

  std::string out = "row,col,x_m,y_m,label,label_name,points";
  if (truth_cols) out += ",truth,truth_name,truth_points";
  for (const auto& n : names) out += "," + csvField(n);
  out += '\n';
  out.reserve(out.size() + cells * (32 + 10 * names.size()));
  for (int r = 0; r < grid.rows(); ++r) {
    for (int c = 0; c < grid.cols(); ++c) {
      const int cell = grid.index(r, c);
      // To the nanometre: origin + (i + ½)·cell carries float noise with cells such as 0.3 m
      // (−0.15000000000000036), which a table read by eye or joined on coordinates should not.
      const Eigen::Vector2d centre =
          (grid.geometry().cellCentre(r, c) * 1e9).array().round().matrix() / 1e9;
      appendNumber(out, r);
      out += ',';
      appendNumber(out, c);
      out += ',';
      appendNumber(out, centre.x());
      out += ',';
      appendNumber(out, centre.y());
      out += ',';
      if (has_labels) {
        const LabelId id = lab[cell];
        appendNumber(out, static_cast<int>(id));
        out += ',';
        if (id < labels.size()) out += csvField(labels.name(id));
      } else {
        out += ',';
      }
      out += ',';
      appendNumber(out, binned ? grid.count(cell) : 0u);
      if (truth_cols) {
        CellTruth t;
        if (has_truth && grid.count(cell) > 0) {
          std::fill(per_class.begin(), per_class.end(), 0);
          for (const uint32_t* p = grid.pointsBegin(cell); p != grid.pointsEnd(cell); ++p) {
            const LabelId l = truth->label[*p];
            if (l >= per_class.size()) {
              throw std::invalid_argument("grid_csv: ground-truth label " + std::to_string(l) +
                                          " at point " + std::to_string(*p) +
                                          " is not a class id (" +
                                          std::to_string(per_class.size()) + " classes)");
            }
            ++per_class[l];
          }
          t = cellTruth(per_class, obstacle_id, has_labels ? lab[cell] : labels::kUnknown);
        }
        out += ',';
        if (t.label != labels::kUnknown) {
          appendNumber(out, static_cast<int>(t.label));
          out += ',';
          out += csvField(labels.name(t.label));
          out += ',';
          appendNumber(out, t.labelled);
        } else {
          out += ",,";
        }
      }
      for (const Layer* l : layers) {
        out += ',';
        appendNumber(out, (*l)[cell]);
      }
      out += '\n';
    }
  }
  return out;
}

}  // namespace terramrf
