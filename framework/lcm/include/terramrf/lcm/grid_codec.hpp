#pragma once
// TerrainGrid + labels ⇄ terramrf_msgs::terrain_grid_t, as encoded bytes. The header is LCM-free
// on purpose: LCM's C++ header cannot share a translation unit with CGAL.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "terramrf/label_set.hpp"
#include "terramrf/lcm/message_header.hpp"
#include "terramrf/terrain_grid.hpp"

namespace terramrf {

/// Encodes geometry, the label layer (if the grid has one), the label names of `labels`, the
/// number of points per cell (if points were binned) and the float layers named in `layers`
/// (empty = all, in name order). Throws std::invalid_argument naming a requested layer that the
/// grid does not have, or a label layer whose size does not match the grid.
MessageBytes encodeGrid(const TerrainGrid& grid, const LabelSet& labels,
                        const MessageHeader& header, const std::vector<std::string>& layers = {});

struct DecodedGrid {
  MessageHeader header;
  /// Geometry, layers and labels as sent; no point lists (points are a separate message). The
  /// label layer is left as TerrainGrid::reset() makes it when the message carried none.
  TerrainGrid grid;
  bool has_labels = false;
  std::vector<std::string> label_names;  ///< index = LabelId
  std::vector<uint32_t> point_counts;    ///< points per cell; empty if the sender had none
};

/// Decodes a terrain_grid_t. Throws InputError (file = `source`, e.g. the channel) if the bytes
/// are not a terrain_grid_t, are truncated, or describe an inconsistent grid (non-square,
/// cell count mismatch, label id without a name, non-finite geometry).
DecodedGrid decodeGrid(const void* data, std::size_t size,
                       const std::string& source = "terrain_grid_t");
inline DecodedGrid decodeGrid(const MessageBytes& bytes,
                              const std::string& source = "terrain_grid_t") {
  return decodeGrid(bytes.data(), bytes.size(), source);
}

/// Points per cell of a grid whose points were binned, zeros otherwise (never reads unbinned
/// point lists).
std::vector<uint32_t> pointCounts(const TerrainGrid& grid);

}  // namespace terramrf
