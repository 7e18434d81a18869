#pragma once
// Bird's-eye rendering of a labelled grid: forward (+x, growing row) is up, left (+y, growing
// column) is left, so the picture looks like the scene seen from above with the vehicle facing up.
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "terramrf/image.hpp"
#include "terramrf/label_set.hpp"
#include "terramrf/terrain_grid.hpp"

namespace terramrf {

/// Colour of label ids that the label set does not know (so they stand out).
inline constexpr std::array<uint8_t, 3> kUnnamedLabelRgb{255, 0, 255};
/// Colour of the sensor cross.
inline constexpr std::array<uint8_t, 3> kSensorRgb{255, 255, 255};

struct GridRenderStats {
  std::size_t unnamed_label_cells = 0;  ///< cells whose id has no entry in the label set
  bool sensor_marked = false;           ///< false when the sensor lies outside the grid
};

/// Largest image side renderGrid draws [px]: 16384, i.e. at most 2^28 pixels (768 MiB RGB) per
/// frame for the square grid. Above it a frame failed with a bare std::bad_alloc (a 2000-cell grid
/// at 64 px per cell asked for 128000² px, 45.8 GiB), or the side overflowed int.
inline constexpr int kMaxGridImageSidePx = 16384;

/// Why a grid of `cols` × `rows` cells cannot be drawn at `pixels_per_cell` (the image's side
/// above kMaxGridImageSidePx), naming both and the image size; empty when it can.
std::string gridImageSizeProblem(int cols, int rows, int pixels_per_cell);

/// Renders each cell as a `pixels_per_cell`² block in its label's colour (unknown when the grid
/// has no labels) and marks the grid frame's origin (0, 0), the sensor of a sensor-centred grid,
/// with a cross whose arms are max(2, `pixels_per_cell`) pixels long (visible at 1 px per cell).
/// Throws std::invalid_argument (gridImageSizeProblem) for an image too large to draw.
Image renderGrid(const TerrainGrid& grid, const LabelSet& labels, int pixels_per_cell,
                 GridRenderStats* stats = nullptr);

}  // namespace terramrf
