// Return intensity (reflectance) per cell: the mean of the cell's points' intensities, and
// optionally their standard deviation. Asphalt, paint, grass and foliage reflect a laser
// differently, so where a sensor records intensity it is a cue the geometry lacks. Values stay in
// the sensor's own units (KITTI's HDL-64E ~0..1, RELLIS-3D's Ouster ~0..0.012): a model learnt on
// one sensor does not carry over to another.
#include <algorithm>
#include <cmath>

#include "terramrf/plugin.hpp"

namespace terramrf {

class Intensity final : public Stage {
 public:
  void declare(ParamDecl& d) override {
    d.add("layer", layer_,
          "name of the output layer: mean intensity of the cell's points [sensor units]");
    d.add("std_layer", std_layer_,
          "if set, also write the population standard deviation of the cell's intensities "
          "[sensor units] to this layer");
    d.add("min_points", min_points_, "cells with fewer points get NaN (no data)")
        .unit("points")
        .range(1, 1000);
  }
  void configure(const PluginContext&) override {
    if (layer_.empty()) throw ParamError("layer", "is empty; expected e.g. 'intensity'");
    if (std_layer_ == layer_)
      throw ParamError("std_layer", "must differ from 'layer' ('" + layer_ +
                                        "'); both are written by this stage");
  }
  std::vector<std::string> reads() const override { return {artefacts::kPoints}; }
  std::vector<std::string> writes() const override {
    if (std_layer_.empty()) return {layer_};
    return {layer_, std_layer_};
  }

  void process(FrameContext& ctx) override {
    TerrainGrid& g = *ctx.grid;
    const PointCloud& pc = ctx.frame->points;
    Layer& mean = g.add(layer_);
    Layer* sd = std_layer_.empty() ? nullptr : &g.add(std_layer_);
    // A file format without intensity is read as zeros (the Open3D-ML SemanticKITTI scans, a PCD
    // without the field). Zero everywhere is then "not recorded", not a reflectance: the layers
    // stay NaN, so the energy's term is silent rather than learnt from, or voting for, zeros.
    bool recorded = pc.intensity.size() == pc.size();
    if (recorded) {
      recorded = false;
      for (float v : pc.intensity)
        if (v != 0.f) {
          recorded = true;
          break;
        }
    }
    ctx.metrics[name() + ".recorded"] = recorded ? 1.0 : 0.0;
    if (!recorded) return;
    // One pass in point order: the intensities are read once, in sequence, and only the cells'
    // sums are touched at random (cheaper than walking each cell's point list). Double sums: a
    // cell near the sensor holds thousands of points.
    const std::size_t cells = g.cells();
    sum_.assign(cells, 0.0);
    sum2_.assign(cells, 0.0);
    const std::vector<int32_t>& cell_of = g.cellOfPoint();
    for (std::size_t i = 0, n = pc.size(); i < n; ++i) {
      const int32_t c = cell_of[i];
      if (c < 0) continue;
      const double v = pc.intensity[i];
      sum_[c] += v;
      sum2_[c] += v * v;
    }
    for (std::size_t c = 0; c < cells; ++c) {
      const uint32_t k = g.count(static_cast<int>(c));
      if (k == 0 || k < static_cast<uint32_t>(min_points_)) continue;
      const double m = sum_[c] / k;
      mean[c] = static_cast<float>(m);
      if (sd) (*sd)[c] = static_cast<float>(std::sqrt(std::max(0.0, sum2_[c] / k - m * m)));
    }
  }

 private:
  std::string layer_ = "intensity";
  std::string std_layer_;
  int min_points_ = 1;
  std::vector<double> sum_, sum2_;  ///< per cell; kept between frames to avoid reallocation
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::Intensity, terramrf::PluginKind::kFeature, "intensity",
                "return intensity per cell: mean (and optionally standard deviation) of its points")
