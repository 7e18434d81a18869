#pragma once
// Carrying grid contents from one placement of a grid to another: the previous frame's layers
// into this frame's grid (temporal fusion, an HMM's label beliefs), and a map window fixed in the
// world moved along with the vehicle (grid_map's GridMap::move). Every temporal stage needs the
// same cell correspondence; written once here, it is tested once.
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "terramrf/terrain_grid.hpp"

namespace terramrf {

/// For each cell of `dst` (row-major), the index of the `src` cell under its centre, or -1 where
/// that centre falls outside `src`. `T_src_dst` maps points of dst's grid frame into src's (for
/// two frames' grids: previous_pose⁻¹ · pose). Cell centres are taken on the z = 0 plane of dst
/// and read on src's x/y after the transform (a roll or pitch projects them onto it).
std::vector<int32_t> cellsUnder(const GridGeometry& dst, const GridGeometry& src,
                                const Eigen::Isometry3d& T_src_dst);

/// `src` (a layer of the grid `cells_under` points into) resampled by nearest cell onto the grid
/// `cells_under` was made for: NaN where the cell maps outside src. For labels and other values
/// that must not be blended.
Layer resampleNearest(const Layer& src, const std::vector<int32_t>& cells_under);
/// As resampleNearest for a label layer: labels::kUnknown outside src.
std::vector<LabelId> resampleLabels(const std::vector<LabelId>& src,
                                    const std::vector<int32_t>& cells_under);

/// `src` (a layer over `src_geom`) resampled bilinearly between the four src cell centres around
/// each dst cell centre (T_src_dst as in cellsUnder). Neighbours outside src or without data
/// (NaN) are left out and the others' weights renormalised, so a hole or the border does not
/// pull values to 0; NaN where none of the four has data. Exact for a layer linear in x and y
/// wherever all four neighbours have data. For continuous values such as heights or per-class
/// probabilities (renormalise the classes after resampling each).
Layer resampleBilinear(const Layer& src, const GridGeometry& src_geom, const GridGeometry& dst,
                       const Eigen::Isometry3d& T_src_dst);

/// Moves `grid` (a map kept in a fixed frame) so that its centre is the point nearest `centre_m`
/// [m] that keeps the cell lattice where it was: whole cells move, so values are never blended
/// however often the map moves. Layers and labels keep their values where the old and new windows
/// overlap; cells that enter the window get NaN / labels::kUnknown. The grid's point lists and
/// pixel lists are dropped (they index one frame's cloud). Returns the shift in cells: x (rows),
/// y (columns).
Eigen::Vector2i moveGrid(TerrainGrid& grid, const Eigen::Vector2d& centre_m);

}  // namespace terramrf
