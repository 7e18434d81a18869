// Height difference f_h (paper 000 §4.3, after Happold et al.): highest minus lowest point of a
// cell. The main cue for obstacles, whose defining property is their height.
#include "terramrf/plugin.hpp"

namespace terramrf {

class HeightDifference final : public Stage {
 public:
  void declare(ParamDecl& d) override {
    d.add("layer", layer_, "name of the output layer: max z − min z per cell [m]");
    d.add("min_points", min_points_, "cells with fewer points get NaN (no data)")
        .unit("points").range(1, 1000);
  }
  std::vector<std::string> reads() const override { return {artefacts::kPoints}; }
  std::vector<std::string> writes() const override { return {layer_}; }

  void process(FrameContext& ctx) override {
    TerrainGrid& g = *ctx.grid;
    const TerrainGrid::ZRange& z = g.zRange(ctx.frame->points);
    Layer& out = g.add(layer_);
    for (int c = 0, n = static_cast<int>(g.cells()); c < n; ++c)
      if (g.count(c) >= static_cast<uint32_t>(min_points_)) out[c] = z.max[c] - z.min[c];
  }

 private:
  std::string layer_ = "height_diff";
  int min_points_ = 1;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::HeightDifference, terramrf::PluginKind::kFeature, "height_difference",
                "height difference f_h: highest minus lowest point per cell (paper 000 §4.3)")
