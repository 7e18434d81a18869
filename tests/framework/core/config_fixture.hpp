#pragma once
#include <fstream>
#include <string>

#include "terramrf/config.hpp"
#include "terramrf/plugin.hpp"
#include "test_support.hpp"

namespace terramrf::test {

/// A temp folder with a model file, and a registry that sees the real and the test plugins.
struct ConfigFixture {
  TempDir dir;
  PluginRegistry registry{{pluginDir(), std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_source",
                           std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_stream"}};

  ConfigFixture() {
    std::ofstream(dir.str() + "/model.yaml") << R"(provenance: hand-written for tests
classes:
  road:     {height_diff: {mean: 0.02, sigma: 0.02}}
  rough:    {height_diff: {mean: 0.08, sigma: 0.05}}
  obstacle: {height_diff: {mean: 1.0, sigma: 0.8}}
)";
  }
  /// The synthetic test pipeline (validPipeline) with `source_params`, outputs in `<dir>/out`.
  Pipeline loadSynthetic(const std::string& source_params) {
    LoadOptions lo;
    lo.output_dir = dir.str() + "/out";
    return loadPipeline(write("c.yaml", validPipeline(source_params)), lo, registry);
  }
  std::string write(const std::string& name, const std::string& text) {
    const std::string p = dir.str() + "/" + name;
    std::ofstream(p) << text;
    return p;
  }
  static std::string validPipeline(const std::string& source_params = "{frames: 3}") {
    return "version: 1\n"
           "grid: {size_m: 40, cell_m: 0.5}\n"
           "source: {type: test_synthetic, params: " + source_params + "}\n"
           "stages:\n"
           "  - {name: pre, type: eigen_preclass}\n"
           "  - {name: hdiff, type: height_difference}\n"
           "  - {name: mrf, type: potts_gaussian, params: {model: model.yaml, features: [height_diff], preclass_layer: preclass}}\n"
           "  - {name: solve, type: icm}\n"
           "outputs: []\n";
  }
};

/// One frame of a loaded pipeline through its stages, driven by hand (no outputs): the frame,
/// its grid and the context the stages filled.
struct StagesByHand {
  Frame frame;
  TerrainGrid grid;
  FrameContext ctx;
  StagesByHand(Pipeline& p, std::size_t index) : frame(p.source->read(index)), grid(p.grid) {
    grid.binPoints(frame.points);
    ctx.frame = &frame;
    ctx.grid = &grid;
    ctx.labels = p.labels.get();
    for (auto& s : p.stages) s->process(ctx);
  }
  StagesByHand(const StagesByHand&) = delete;
  StagesByHand& operator=(const StagesByHand&) = delete;
};

}  // namespace terramrf::test
