#pragma once
// Complete scene recovery (paper 004 §3.3): the tops of objects beyond the LiDAR's reach are
// recovered from the image. Non-ground mesh vertices are projected into the image; a pixel MRF
// (pixel_mrf.hpp) separates object pixels (seeded by those vertices and by the frame's non-ground
// LiDAR points) from background (sky, never sensed); from each vertex the image of the vertical
// line above it is followed up to the object's top boundary, and the ray from the camera centre
// through that boundary pixel, intersected with the vertex's fixed horizontal position, gives the
// object's height there.
//
// The background colours are sampled far from every LiDAR return, so they mix the sky with the
// object parts above the LiDAR's reach (crowns, upper walls); `background_odds` keeps those colours
// object (otherwise crowns become background and walks through them end early). A walk that
// passes under a clearly nearer LiDAR surface (an occluder) gives only a lower bound.
#include <cstdint>
#include <vector>

#include "terramrf/meshing/camera_view.hpp"
#include "terramrf/meshing/ground_segmentation.hpp"
#include "terramrf/meshing/terrain_mesh.hpp"

namespace terramrf::meshing {

struct SceneRecoveryParams {
  PixelMrfParams mrf;             ///< object (1) / background (0) MRF
  int max_gap_px = 2;             ///< background pixels tolerated inside an object column [px]
  double depth_jump_m = 1.5;      ///< the walk stops where LiDAR sees a surface this much farther [m]
  double max_range_m = 60.0;      ///< vertices farther from the camera are not recovered [m]
  int background_clearance_px = 8;  ///< background colour samples keep this far from LiDAR pixels
  /// End the walk with a lower bound where a clearly nearer LiDAR surface covers the column (the
  /// boundary above would belong to the occluder, e.g. a crown in front of a wall).
  bool stop_at_occluders = true;
  /// A colour is background only where it is this many times more frequent among the background
  /// samples than among the object seeds (the samples include object parts above the LiDAR) [1]
  double background_odds = 16.0;
};

struct SceneRecoveryStats {
  std::size_t vertices_tried = 0;
  std::size_t estimates = 0;      ///< boundary found below the image top
  std::size_t lower_bounds = 0;   ///< object continued past the image top, or occluded
  std::size_t occluded = 0;       ///< walks ended under a nearer surface (lower bounds)
  std::size_t raised = 0;         ///< estimates above the measured top
  std::vector<uint8_t> object_mask;  ///< per pixel, 1 = object (for overlays)
};

/// Adds height estimates for the object vertices of `mesh` seen in `view`. `ground` is the frame's
/// ground segmentation of the same image.
SceneRecoveryStats recoverHeights(TerrainMesh& mesh, const CameraView& view, const Image& image,
                                  const GroundSegmentation& ground, const PointCloud& points,
                                  const SceneRecoveryParams& params);

}  // namespace terramrf::meshing
