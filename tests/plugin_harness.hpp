#pragma once
// Drives one plugin stage by hand on a frame: registry → params → grid → process.
#include <map>
#include <memory>
#include <string>

#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"
#include "test_support.hpp"

namespace terramrf::test {

struct StageHarness {
  LabelSet labels = LabelSet::defaults();
  GridGeometry geom;
  Frame frame;
  TerrainGrid grid;
  FrameContext ctx;
  PluginRegistry registry{{pluginDir()}};
  /// What the stages before the one made would have computed (PluginContext::layer_origins).
  const std::map<std::string, std::string>* layer_origins = nullptr;

  explicit StageHarness(double size_m = 20, double cell_m = 0.5) {
    geom.size_m = size_m;
    geom.cell_m = cell_m;
  }
  PluginContext pluginContext() const {
    PluginContext pc;
    pc.config_dir = sourceDir() + "/configs";
    pc.grid = geom;
    pc.labels = &labels;
    pc.layer_origins = layer_origins;
    return pc;
  }
  std::unique_ptr<Stage> make(const std::string& type, const std::string& params = "{}") {
    auto p = registry.create(type);
    setParams(*p, params, pluginContext());
    return std::unique_ptr<Stage>(static_cast<Stage*>(p.release()));
  }
  /// Bins the frame's points and prepares the context.
  void bin() {
    grid.reset(geom);
    grid.binPoints(frame.points);
    ctx = FrameContext{};
    ctx.frame = &frame;
    ctx.grid = &grid;
    ctx.labels = &labels;
  }
  float at(const std::string& layer, double x, double y) const {
    return grid.layer(layer)[geom.cellOf(x, y)];
  }
};

}  // namespace terramrf::test
