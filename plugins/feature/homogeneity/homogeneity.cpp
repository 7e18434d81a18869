// Texture homogeneity f_th of each cell's pixels (paper 000 §4.3, "after Knauer et al."): rough
// terrain looks inhomogeneous, even terrain homogeneous.
//
// Knauer et al.'s own text was not available to us beyond its abstract, which says it computes "an
// existing homogeneity feature" fast over regions. Two per-pixel definitions are offered, each
// stated exactly, and the cell's value is the mean over its pixels:
//
// `cheng_sun` (Cheng & Sun, IEEE TIP 9(12), 2000; a widely used per-pixel homogeneity of that
// time; whether it is the one Knauer et al. start from could not be checked):
//   v(p) = standard deviation of I over the d × d window centred at p   (d = `window`)
//   e(p) = |∇I(p)|, 3 × 3 Sobel
//   H(p) = 1 − (e(p) / e_max) · (v(p) / v_max)
// e_max, v_max: fixed bounds 8-bit grey cannot exceed (`normalise: fixed`, the default: 1020·√2,
// from |Gx|, |Gy| ≤ 4·255, although e itself reaches at most 1140; and 127.5, which v reaches),
// or the image's maxima (`normalise: image`, as published), with which one strong
// edge anywhere in the image rescales every cell of it. Range [0, 1]; 1 where either factor is
// zero. The default was chosen on the simulator's validation world
// (docs/plugins/camera_features.md).
//
// `local_std` (the spread term alone, as the only public implementation of a terrain-classification
// "homogeneity" we found computes it: cogsys-tuebingen/cslibs_vision,
// docs/plugins/camera_features.md):
//   H(p) = 1 − v(p) / v_max,  v and v_max as above. Range [0, 1]; 1 on a flat patch.
//
// `local_mean` (this project's earlier stand-in):
//   h(p) = 1 / (1 + |I(p) − Ī(p)| / s),  Ī = mean of I over the 3 × 3 neighbourhood, s =
//   `contrast_scale` [grey levels]. Range (0, 1]; exactly 1 on a flat patch and on linear shading.
//
// I = 8-bit grey (OpenCV luma 0.299 R + 0.587 G + 0.114 B); at the image border OpenCV's
// BORDER_REFLECT_101. All three are "fast to compute", as the paper describes the feature: one
// read per cell pixel of a per-pixel map, made by cheng_sun and local_std in one row-by-row
// ChengSunMap pass over the rows the cells use (window sums and Sobel carried from row to row, no
// intermediate image; with normalise: image all rows, and a first pass for the maxima), by
// local_mean with one 3 × 3 box filter of the image.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "cheng_sun_map.hpp"
#include "terramrf/camera_fusion/fused_cameras.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {

class Homogeneity final : public Stage {
 public:
  void declare(ParamDecl& d) override {
    d.add("layer", layer_,
          "name of the output layer: mean pixel homogeneity over the cell, [0, 1]");
    d.add("definition", definition_,
          "per-pixel homogeneity: cheng_sun (1 − normalised Sobel magnitude × normalised local "
          "standard deviation, Cheng & Sun 2000), local_std (1 − normalised local standard "
          "deviation) or local_mean (1/(1+|I − 3×3 mean|/s))")
        .choices({"cheng_sun", "local_std", "local_mean"});
    d.add("window", window_,
          "cheng_sun, local_std: side of the square window of the local standard deviation (odd)")
        .unit("px")
        .range(3, 15);
    d.add("normalise", normalise_,
          "cheng_sun, local_std: divide the gradient (cheng_sun) and the standard deviation by "
          "fixed bounds 8-bit grey cannot exceed (fixed: a cell's value does not depend on the "
          "rest of the image) or by the image's maxima (image, as published)")
        .choices({"image", "fixed"});
    d.add("contrast_scale", scale_,
          "local_mean: grey-level difference to the 3×3 mean at which a pixel's homogeneity is 1/2")
        .unit("grey levels")
        .range(0.01, 255);
    fusion::declareCameraChoice(d, camera_, min_pixels_, 1);
  }

  void configure(const PluginContext&) override {
    if (layer_.empty()) throw ParamError("layer", "is empty; expected e.g. 'homogeneity'");
    if (window_ % 2 == 0)
      throw ParamError("window", "is " + std::to_string(window_) +
                                     "; expected an odd number of pixels (the window is centred)");
    // d = |9·I − ΣI| ∈ [0, 9·255] in integer units of 1/9 grey level.
    for (int d = 0; d < kTable; ++d) weight_[d] = float(1.0 / (1.0 + d / (9.0 * scale_)));
  }

  std::vector<std::string> reads() const override { return {artefacts::kCellPixels}; }
  std::vector<std::string> writes() const override { return {layer_}; }

  void process(FrameContext& ctx) override {
    TerrainGrid& g = *ctx.grid;
    const auto cams = fusion::fusedCameras(ctx, camera_, "homogeneity");
    // cheng_sun and local_std write a float map of H; local_mean the 3 × 3 sums.
    const bool float_map = definition_ != "local_mean";
    grey_.resize(cams.size());
    maps_.resize(cams.size());
    for (std::size_t k = 0; k < cams.size(); ++k) {
      if (float_map) {
        windowed(*cams[k].image, *cams[k].pixels, maps_[k]);
        continue;
      }
      fusion::toGrey(*cams[k].image, grey_[k]);
      cv::boxFilter(grey_[k], maps_[k].h, CV_16U, cv::Size(3, 3), cv::Point(-1, -1), false,
                    cv::BORDER_REFLECT_101);
    }
    Layer& out = g.add(layer_);
    for (int c = 0, n = int(g.cells()); c < n; ++c) {
      const int k = fusion::bestCamera(cams, c);
      if (k < 0) continue;
      const CellPixels& cp = *cams[k].pixels;
      if (cp.count(c) < uint32_t(min_pixels_)) continue;
      double s = 0;
      if (float_map) {
        const float* h = maps_[k].h.ptr<float>(0) - maps_[k].first_pixel;
        for (const uint32_t* it = cp.begin(c); it != cp.end(c); ++it) s += h[*it];
      } else {
        const uint8_t* gi = grey_[k].ptr<uint8_t>(0);
        const uint16_t* si = maps_[k].h.ptr<uint16_t>(0);
        for (const uint32_t* it = cp.begin(c); it != cp.end(c); ++it)
          s += weight_[std::abs(9 * int(gi[*it]) - int(si[*it]))];
      }
      out[c] = float(s / cp.count(c));
    }
  }

 private:
  static constexpr int kTable = 9 * 255 + 1;

  /// Per image. cheng_sun, local_std: H over the rows that hold cell pixels (or the whole image
  /// when its maxima normalise), from `first_pixel` (v·width) on; local_mean: the 3 × 3 sums
  /// (CV_16U).
  struct Maps {
    cv::Mat h, band;
    std::size_t first_pixel = 0;
  };

  /// H of cheng_sun or local_std.
  void windowed(const Image& img, const CellPixels& cp, Maps& m) {
    // Only the rows the cells use need H, unless the image's maxima normalise it. The grey
    // conversion and the filters run on those rows plus the window's reach above and below
    // (clipped to the image, where the border rule applies as on the whole image), and H is kept
    // for the rows inside.
    const int rows = img.height, cols = img.width;
    int v0 = 0, v1 = rows;
    if (normalise_ == "fixed") {
      if (cp.pixels.empty()) {
        m.h.release();
        return;
      }
      // A plain signed min/max loop vectorises, even with SSE2 (pixel indices are below 2^31);
      // std::minmax_element's pairwise scan does not.
      int32_t lo = int32_t(cp.pixels[0]), hi = lo;
      for (const uint32_t p : cp.pixels)
        lo = std::min(lo, int32_t(p)), hi = std::max(hi, int32_t(p));
      v0 = lo / cols;
      v1 = hi / cols + 1;
    }
    const int reach = std::max(window_ / 2, 1);
    const int p0 = std::max(0, v0 - reach), p1 = std::min(rows, v1 + reach);
    fusion::toGrey(img, m.band, p0, p1);  // an image of its own: its border rows reflect
    const cv::Mat& band = m.band;
    m.first_pixel = std::size_t(v0) * cols;
    m.h.create(v1 - v0, cols, CV_32F);
    const uint8_t* grey = band.ptr<uint8_t>(0);
    const int band_rows = p1 - p0, r0 = v0 - p0, r1 = v1 - p0;
    float* h = m.h.ptr<float>(0);
    if (definition_ == "local_std") return localStd(band, r0, r1, h);
    // E·V = √(e²·N²v²) / (e_max·N·v_max), with bounds 8-bit grey cannot exceed (|Gx|, |Gy| ≤
    // 4·255, so e ≤ 1020·√2, though no 3 × 3 patch gets above 1140; v ≤ 127.5, half black, half
    // white) or the image's maxima.
    if (normalise_ == "fixed") {
      const uint32_t area = uint32_t(window_) * uint32_t(window_);
      const float k = float(1.0 / (1020 * M_SQRT2 * area * 127.5));
      return map_.fixed(grey, band_rows, cols, window_, r0, r1, k, h);
    }
    // The image's maxima first, then H: two passes of the kernel (cheaper than keeping e² and
    // N²v² for the whole image between them).
    uint32_t v2_max = 0, e2_max = 0;
    map_.maxima(grey, band_rows, cols, window_, r0, r1, &e2_max, &v2_max);
    // A flat image has no pixel with both spread and gradient: H = 1 everywhere.
    if (v2_max == 0 || e2_max == 0) {
      m.h.setTo(1.0f);
      return;
    }
    // Formed as each pixel's product is, and divided by: the pixel holding both maxima reads 0.
    map_.image(grey, band_rows, cols, window_, r0, r1, std::sqrt(float(e2_max) * float(v2_max)), h);
  }

  /// local_std's H = 1 − v / v_max over band rows [r0, r1) into h, from the same window sums as
  /// Cheng & Sun's v.
  void localStd(const cv::Mat& band, int r0, int r1, float* h) {
    const uint8_t* grey = band.ptr<uint8_t>(0);
    const double n = double(window_) * window_;
    double nv_max = n * 127.5;  // fixed: half the window black, half white
    if (normalise_ == "image") {
      uint32_t e2_max = 0, v2_max = 0;
      map_.maxima(grey, band.rows, band.cols, window_, r0, r1, &e2_max, &v2_max);
      if (v2_max == 0) {  // a flat image: H = 1 everywhere
        std::fill(h, h + std::size_t(r1 - r0) * band.cols, 1.0f);
        return;
      }
      nv_max = std::sqrt(double(v2_max));
    }
    map_.spread(grey, band.rows, band.cols, window_, r0, r1, nv_max, h);
  }

  std::string layer_ = "homogeneity";
  std::string definition_ = "cheng_sun";
  int window_ = 5;
  std::string normalise_ = "fixed";
  double scale_ = 1.0;
  int camera_ = -1;
  int min_pixels_ = 1;

  float weight_[kTable] = {};
  std::vector<cv::Mat> grey_;
  std::vector<Maps> maps_;
  ChengSunMap map_;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::Homogeneity, terramrf::PluginKind::kFeature, "homogeneity",
                "texture homogeneity f_th: mean over the cell's pixels of Cheng & Sun's "
                "1 − E·V (or 1 − V, or 1/(1+|I−mean3x3(I)|/s)) (paper 000 §4.3)")
