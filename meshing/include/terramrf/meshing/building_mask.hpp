#pragma once
// Building / tree classification by masking (paper 004 §3.4, eq. 13). A range sensor sees only
// the outer surface of a building, so in the elevation map a building is a set of thin lines
// (its walls), while a porous tree crown is a filled blob or, seen from below at the LiDAR's
// reach, a scatter of isolated returns. Line-detector masks (Fig. 10: a line of cells through
// the centre against the rest of a (2s+1)² window, at several orientations) are convolved over
// the vertices' elevation above the local ground:
//   U(i, j) = Σ_{m,n=−s..s} h(i−m, j−n) f(m, n)                      (eq. 13)
// with f = +1/|line| on the line and −1/|rest| elsewhere (zero sum, so flat ground gives 0). The
// largest response over the orientations is compared with a threshold: above = building, other
// object vertices = tree.
//
// Two changes make the masks work on our elevation maps (docs/meshing.md, Deviations):
// - h is first grey-dilated by a (2t+1)² window (t = `line_tolerance`): a wall is sampled as a
//   thin staircase with gaps, which a straight digital line would leave after a few cells.
// - With `normalise`, U is divided by the height a complete wall along the line would have (the
//   mean of the raised cells on it, at least the vertex's own), so U is a dimensionless "filled
//   straight line" measure: ≈ 1 for a wall, ≈ (2t+1)/(2s+1) for an isolated foliage return
//   (which the paper's unnormalised masks, or a division by the line's mean, score like a wall),
//   ≈ 0 inside a blob; it does not depend on how tall the object is.
#include "terramrf/meshing/terrain_mesh.hpp"

namespace terramrf::meshing {

struct MaskParams {
  int size = 8;                  ///< s: the mask is (2s+1) × (2s+1) vertices [1]
  int orientations = 8;          ///< line directions over 180° (paper's Fig. 10: 4) [1]
  int line_tolerance = 1;        ///< t: h is grey-dilated by (2t+1)² vertices first (0 = off) [1]
  double threshold = 0.45;       ///< on U (normalised: [1]; else [m])
  bool normalise = true;         ///< divide U by the elevation of a complete wall on the line
  double min_height_m = 1.0;     ///< objects lower than this above the ground are never buildings [m]
  double ground_window_m = 4.0;  ///< half width of the window for the local ground height [m]
};

struct MaskStats {
  std::size_t object_vertices = 0, buildings = 0, trees = 0;
};

/// Classifies every vertex from its votes (ground / object) and splits the object vertices into
/// building / tree. Stores U in Tile::mask_response.
MaskStats classifyVertices(TerrainMesh& mesh, const MaskParams& params);

/// Ground or object from the image votes only (no masking); unknown without votes.
void classifyGroundObject(TerrainMesh& mesh);

}  // namespace terramrf::meshing
