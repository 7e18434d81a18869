// A layer on a logarithmic scale: ln(max(x, 0) + offset) per cell.
//
// Why: the energy of eq. 11 models each feature of a class as one Gaussian. Scale quantities such
// as roughness are far from that: asphalt sits in a narrow band near the sensor's noise while
// grass and vegetation spread over a decade, so a Gaussian fitted to the linear values is either
// too wide for asphalt or too narrow for grass. On a log scale both are close to Gaussian, and a
// road cell whose roughness is twice the usual no longer costs as much as one ten times rougher
// (measured in docs/benchmarks.md). The offset keeps zero finite and sets the floor below which
// differences stop mattering (about the sensor's noise).
#include <algorithm>
#include <cmath>

#include "terramrf/plugin.hpp"

namespace terramrf {

class LogTransform final : public Stage {
 public:
  void declare(ParamDecl& d) override {
    d.add("input", input_, "layer to transform (written by an earlier stage)").required();
    d.add("layer", layer_, "output layer: ln(max(input, 0) + offset); '' = 'log_' + input");
    d.add("offset", offset_,
          "added before the logarithm, in the input's unit: keeps 0 finite; differences well "
          "below it are flattened (choose about the sensor's noise level)")
        .unit("unit of input")
        .range(1e-9, 1e9);
  }
  void configure(const PluginContext&) override {
    if (input_.empty()) throw ParamError("input", "name the layer to transform");
    if (outName() == input_)
      throw ParamError("layer", "must differ from 'input' ('" + input_ +
                                    "'): a stage never rewrites a layer it reads");
  }
  std::vector<std::string> reads() const override { return {input_}; }
  std::vector<std::string> writes() const override { return {outName()}; }

  void process(FrameContext& ctx) override {
    TerrainGrid& g = *ctx.grid;
    const Layer& in = g.layer(input_);
    Layer& out = g.add(outName());
    const float off = static_cast<float>(offset_);
    for (std::size_t c = 0, n = g.cells(); c < n; ++c) {
      const float v = in[c];
      if (!std::isnan(v)) out[c] = std::log(std::max(v, 0.f) + off);  // NaN stays "no data"
    }
  }

 private:
  std::string outName() const { return layer_.empty() ? "log_" + input_ : layer_; }

  std::string input_;
  std::string layer_;
  double offset_ = 1e-3;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::LogTransform, terramrf::PluginKind::kFeature, "log_transform",
                "a layer on a log scale, ln(max(x, 0) + offset): scale features such as roughness "
                "become close to Gaussian for eq. 11")
