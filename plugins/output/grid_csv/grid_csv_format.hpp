#pragma once
// The per-cell CSV table of output "grid_csv" (format in docs/plugins/outputs.md).
#include <string>
#include <vector>

#include "terramrf/frame.hpp"
#include "terramrf/label_set.hpp"
#include "terramrf/text_format.hpp"
#include "terramrf/terrain_grid.hpp"

namespace terramrf {

/// One line per cell, row-major (row grows with x, column with y), after the header
/// `row,col,x_m,y_m,label,label_name,points,<layers...>`. x_m/y_m are the cell centre [m]; layer
/// values in the shortest form that reads back to the same float; NaN (no data) is an empty field.
/// `layers` empty = all layers in name order. Throws std::invalid_argument naming a missing layer.
/// With `truth` (the frame's per-point ground truth, binned into `grid`) the columns
/// `truth,truth_name,truth_points` follow `points`: the cell's true class by the evaluation's rule
/// (cellTruth, paper 001 §VI-B) and its labelled points; empty for a cell without a labelled point
/// or a frame without truth. Throws std::invalid_argument on a truth id that is not a class.
std::string gridToCsv(const TerrainGrid& grid, const LabelSet& labels,
                      const std::vector<std::string>& layers,
                      const PointLabels* truth = nullptr);


}  // namespace terramrf
