#pragma once
// Decimation of flat regions of an exported tile (CGAL Surface_mesh_simplification, edge
// collapse). The texture is a top-down projection and a vertex's texture coordinate is a function
// of its (x, y), so a collapse that keeps one endpoint where it is keeps every texture coordinate
// exact. A collapse is taken only while every original vertex and original triangle centroid
// inside the changed triangles stays within `flat_tolerance_m` (vertically) of the new surface;
// the flattest collapses go first. (Samples between those can deviate slightly more on curved
// ground; on planar pieces the result is exact.)
// Vertices on the tile's edge (shared with the neighbouring tiles) and on class boundaries are
// kept, so a building's foot or a ditch's edge stays where it was; the outline of holes stays
// exactly (a vertex there only goes where the outline runs straight through it).
#include <cstddef>

#include "terramrf/meshing/mesh_export.hpp"

namespace terramrf::meshing {

struct DecimationStats {
  std::size_t triangles_before = 0, triangles_after = 0;
  std::size_t vertices_before = 0, vertices_after = 0;
  /// Largest vertical distance of a checked sample (original vertex or triangle centroid) from
  /// the decimated surface [m]
  double max_deviation_m = 0;
};

/// Decimates one tile mesh in place (positions, uvs, colours, classes of the kept vertices are
/// the originals). Throws std::invalid_argument for a negative tolerance.
DecimationStats decimateTileMesh(TileMesh& mesh, double flat_tolerance_m);

}  // namespace terramrf::meshing
