// Example feature plugin: point density per cell [points/m²]. Build it against an installed
// TerraMRF (see README.md here), add its build folder to `plugin_path:` and list it as a stage.
#include <terramrf/plugin.hpp>

namespace example {

class PointDensity final : public terramrf::Stage {
 public:
  void declare(terramrf::ParamDecl& d) override {
    d.add("layer", layer_, "name of the output layer [points/m²]");
    d.add("min_points", min_points_, "cells with fewer points get NaN (no data)")
        .unit("points").range(1, 10000);
  }
  std::vector<std::string> reads() const override { return {terramrf::artefacts::kPoints}; }
  std::vector<std::string> writes() const override { return {layer_}; }

  void process(terramrf::FrameContext& ctx) override {
    terramrf::TerrainGrid& g = *ctx.grid;
    const double area_m2 = g.geometry().cell_m * g.geometry().cell_m;
    terramrf::Layer& out = g.add(layer_);
    for (int c = 0; c < static_cast<int>(g.cells()); ++c)
      if (g.count(c) >= static_cast<uint32_t>(min_points_))
        out[c] = static_cast<float>(g.count(c) / area_m2);
  }

 private:
  std::string layer_ = "point_density";
  int min_points_ = 1;
};

}  // namespace example

TERRAMRF_PLUGIN(example::PointDensity, terramrf::PluginKind::kFeature, "point_density",
                "example out-of-tree plugin: points per square metre in each cell")
