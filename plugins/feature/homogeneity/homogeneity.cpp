// Texture homogeneity f_th of each cell's pixels (paper 000 §4.3, "after Knauer et al."): rough
// terrain looks inhomogeneous, even terrain homogeneous.
//
// Definition implemented (Knauer et al.'s own formula was not available to us, so this is the
// standard local-homogeneity measure, stated exactly):
//   h(p)   = 1 / (1 + |I(p) − Ī(p)| / s)
//   f_th   = mean of h(p) over the cell's pixels p
// I = 8-bit grey (OpenCV luma 0.299 R + 0.587 G + 0.114 B), Ī(p) = mean of I over the 3 × 3
// neighbourhood of p in the image (p included; border reflected, OpenCV BORDER_REFLECT_101), s =
// `contrast_scale` [grey levels]. Range (0, 1]; exactly 1 for a flat patch; lower the more each
// pixel stands out from its immediate surroundings.
// Why this one: it is local (texture at the pixel scale, which is what separates gravel and grass
// from asphalt), bounded, independent of the cell's size and overall brightness gradient, and
// costs one box filter per image plus one table look-up per pixel — "fast to compute", as the
// paper describes the feature.
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "terramrf/camera_fusion/fused_cameras.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {

class Homogeneity final : public Stage {
 public:
  void declare(ParamDecl& d) override {
    d.add("layer", layer_, "name of the output layer: mean local homogeneity, (0, 1]");
    d.add("contrast_scale", scale_,
          "grey-level difference to the 3×3 mean at which a pixel's homogeneity is 1/2")
        .unit("grey levels")
        .range(0.01, 255);
    fusion::declareCameraChoice(d, camera_, min_pixels_, 1);
  }

  void configure(const PluginContext&) override {
    if (layer_.empty()) throw ParamError("layer", "is empty; expected e.g. 'homogeneity'");
    // d = |9·I − ΣI| ∈ [0, 9·255] in integer units of 1/9 grey level.
    for (int d = 0; d < kTable; ++d) weight_[d] = float(1.0 / (1.0 + d / (9.0 * scale_)));
  }

  std::vector<std::string> reads() const override { return {artefacts::kCellPixels}; }
  std::vector<std::string> writes() const override { return {layer_}; }

  void process(FrameContext& ctx) override {
    TerrainGrid& g = *ctx.grid;
    const auto cams = fusion::fusedCameras(ctx, camera_, "homogeneity");
    grey_.resize(cams.size());
    sum_.resize(cams.size());
    for (std::size_t k = 0; k < cams.size(); ++k) {
      fusion::toGrey(*cams[k].image, grey_[k]);
      cv::boxFilter(grey_[k], sum_[k], CV_16U, cv::Size(3, 3), cv::Point(-1, -1), false,
                    cv::BORDER_REFLECT_101);
    }
    Layer& out = g.add(layer_);
    for (int c = 0, n = int(g.cells()); c < n; ++c) {
      const int k = fusion::bestCamera(cams, c);
      if (k < 0) continue;
      const CellPixels& cp = *cams[k].pixels;
      if (cp.count(c) < uint32_t(min_pixels_)) continue;
      const uint8_t* gi = grey_[k].ptr<uint8_t>(0);
      const uint16_t* si = sum_[k].ptr<uint16_t>(0);
      double s = 0;
      for (const uint32_t* it = cp.begin(c); it != cp.end(c); ++it)
        s += weight_[std::abs(9 * int(gi[*it]) - int(si[*it]))];
      out[c] = float(s / cp.count(c));
    }
  }

 private:
  static constexpr int kTable = 9 * 255 + 1;

  std::string layer_ = "homogeneity";
  double scale_ = 1.0;
  int camera_ = -1;
  int min_pixels_ = 1;

  float weight_[kTable] = {};
  std::vector<cv::Mat> grey_, sum_;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::Homogeneity, terramrf::PluginKind::kFeature, "homogeneity",
                "texture homogeneity f_th: mean of 1/(1+|I−mean3x3(I)|/s) over the cell's pixels "
                "(paper 000 §4.3)")
