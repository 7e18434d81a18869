#pragma once
// What lasts for one whole run of a pipeline, beyond one frame: grids a stage builds from frame
// to frame (a global semantic map fusing the frames) that an output exports at the end. The
// runner owns it and hands each stage and output a pointer, so nothing is shared through static
// state: plugins are libraries of their own built with hidden visibility, so a static in one is
// not seen by another, and only core types cross between them (no RTTI, no plugin's own class).
#include <map>
#include <memory>
#include <string>

#include "terramrf/terrain_grid.hpp"

namespace terramrf {

/// One run's persistent state: made empty by runPipeline before any stage's begin(), handed to
/// the stages and outputs (RunInfo::run, FrameContext::run, RunSummary::run) and destroyed when
/// the run returns, after every end(). Each run has its own: the runs of `compare` and `train`,
/// warm-up runs included, never see another run's.
struct RunState {
  /// Grids that persist over the run, by name ("map.semantic"). Each stage keeps its own frame
  /// for them (e.g. a world-fixed map, where FrameContext::grid is centred on the sensor); the
  /// runner neither resets nor bins them. Shared so that an output may keep one past the run.
  std::map<std::string, std::shared_ptr<TerrainGrid>> maps;

  /// The map called `name`, or nullptr if there is none.
  TerrainGrid* findMap(const std::string& name);
  const TerrainGrid* findMap(const std::string& name) const;
  /// The map called `name`, made empty with `geometry` if there is none. Throws
  /// std::invalid_argument naming the map if it exists with another geometry: two stages that
  /// mean different grids by one name would otherwise write past each other's cells.
  TerrainGrid& map(const std::string& name, const GridGeometry& geometry);
};

}  // namespace terramrf
