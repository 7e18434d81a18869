// Haralick texture features of each cell's pixels (paper 000 §4.3: f_sam, f_v, f_idm): angular
// second moment, variance and inverse difference moment of the grey-level co-occurrence matrix
// (formulas in glcm_features.hpp).
//
// Grey: OpenCV luma of the RGB image, quantised uniformly to `levels` (level = ⌊grey·L/256⌋).
// Pairs: for each offset (du, dv) every pixel x of the cell with x + (du, dv) also in the cell —
// only pairs inside the cell's pixel set, so neighbouring cells and the background do not leak in.
// Directions: as Haralick et al. do, the features are computed per offset and averaged over the
// offsets that have at least one pair (default: 0°, 45°, 90°, 135° at distance 1).
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "glcm_features.hpp"
#include "terramrf/camera_fusion/fused_cameras.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {

class Haralick final : public Stage {
 public:
  void declare(ParamDecl& d) override {
    d.add("levels", levels_, "grey levels after quantisation (co-occurrence matrix is L × L)")
        .unit("1")
        .range(2, 256);
    d.add("offsets", offsets_,
          "pixel offsets as a flat list du0, dv0, du1, dv1, … (v points down); the matrix is "
          "symmetric, so (du, dv) and (−du, −dv) are the same")
        .unit("px")
        .range(-64, 64);
    fusion::declareCameraChoice(d, camera_, min_pixels_, 2);
    d.add("prefix", prefix_, "layer names: <prefix>_asm, <prefix>_variance, <prefix>_idm");
  }

  void configure(const PluginContext&) override {
    if (offsets_.empty() || offsets_.size() % 2 != 0)
      throw ParamError("offsets", "has " + std::to_string(offsets_.size()) +
                                      " numbers; expected pairs du, dv (e.g. [1, 0, 0, 1])");
    offs_.clear();
    for (std::size_t i = 0; i < offsets_.size(); i += 2) {
      const double du = offsets_[i], dv = offsets_[i + 1];
      if (du != std::round(du) || dv != std::round(dv))
        throw ParamError("offsets", "pair " + std::to_string(i / 2) + " is not whole pixels");
      if (du == 0 && dv == 0)
        throw ParamError("offsets", "pair " + std::to_string(i / 2) +
                                        " is (0, 0); expected a "
                                        "non-zero displacement");
      offs_.push_back({int(du), int(dv)});
    }
    if (prefix_.empty()) throw ParamError("prefix", "is empty; expected e.g. 'haralick'");
    glcm_.setLevels(levels_);
    for (int gv = 0; gv < 256; ++gv) lut_[gv] = uint16_t(gv * levels_ / 256);
  }

  std::vector<std::string> reads() const override { return {artefacts::kCellPixels}; }
  std::vector<std::string> writes() const override {
    return {prefix_ + "_asm", prefix_ + "_variance", prefix_ + "_idm"};
  }

  void process(FrameContext& ctx) override {
    TerrainGrid& g = *ctx.grid;
    const auto cams = fusion::fusedCameras(ctx, camera_, "haralick");
    grey_.resize(cams.size());
    for (std::size_t k = 0; k < cams.size(); ++k) fusion::toGrey(*cams[k].image, grey_[k]);
    Layer& f_asm = g.add(prefix_ + "_asm");
    Layer& f_var = g.add(prefix_ + "_variance");
    Layer& f_idm = g.add(prefix_ + "_idm");
    for (int c = 0, n = int(g.cells()); c < n; ++c) {
      const int k = fusion::bestCamera(cams, c);
      if (k < 0 || cams[k].pixels->count(c) < uint32_t(min_pixels_)) continue;
      GlcmFeatures mean;
      if (!cellFeatures(*cams[k].pixels, c, grey_[k], &mean)) continue;
      f_asm[c] = float(mean.asm_);
      f_var[c] = float(mean.variance);
      f_idm[c] = float(mean.idm);
    }
  }

 private:
  /// Mean over offsets of the cell's f1, f4, f5; false if no offset has a pair.
  bool cellFeatures(const CellPixels& cp, int cell, const cv::Mat& grey, GlcmFeatures* mean) {
    const uint32_t* b = cp.begin(cell);
    const uint32_t* e = cp.end(cell);
    const int w = cp.width;
    // Bounding box by scanning: CellPixels only groups pixels by cell, it does not order them
    // (camera_fusion happens to sort them; taking the first and last pixel's rows would write
    // past the box for any other order). Costs nothing measurable next to the pair counting.
    int u0 = w, u1 = -1, v0 = std::numeric_limits<int>::max(), v1 = -1;
    for (const uint32_t* it = b; it != e; ++it) {
      const int v = int(*it / w), u = int(*it) - v * w;
      u0 = std::min(u0, u), u1 = std::max(u1, u);
      v0 = std::min(v0, v), v1 = std::max(v1, v);
    }
    // Level of every cell pixel in a box around the cell; pixels not in the cell get the
    // accumulator's "outside" level, whose counts are ignored (branch-free counting).
    const int bw = u1 - u0 + 1, bh = v1 - v0 + 1;
    box_.assign(std::size_t(bw) * bh, uint16_t(glcm_.outside()));
    // First and one-past-last member column of each box row (min/max, so in any pixel order),
    // so the pair loops skip the box's empty corners.
    row_lo_.assign(bh, bw);
    row_hi_.assign(bh, 0);
    const uint8_t* gp = grey.ptr<uint8_t>(0);
    for (const uint32_t* it = b; it != e; ++it) {
      const int x = int(*it % w) - u0, y = int(*it / w) - v0;
      box_[std::size_t(y) * bw + x] = lut_[gp[*it]];
      row_lo_[y] = std::min(row_lo_[y], x);
      row_hi_[y] = std::max(row_hi_[y], x + 1);
    }
    double s_asm = 0, s_var = 0, s_idm = 0;
    int used = 0;
    for (const auto& [du, dv] : offs_) {
      // Rows/columns of the box whose partner stays inside the box.
      const int ya = std::max(0, -dv), yb = std::min(bh, bh - dv);
      const int xa = std::max(0, -du), xb = std::min(bw, bw - du);
      for (int y = ya; y < yb; ++y) {
        const uint16_t* row = &box_[std::size_t(y) * bw];
        const uint16_t* prow = &box_[std::size_t(y + dv) * bw];
        const int x0 = std::max(xa, row_lo_[y]), x1 = std::min(xb, row_hi_[y]);
        if (x1 > x0) glcm_.addRow(row + x0, prow + x0 + du, x1 - x0);
      }
      const GlcmFeatures f = glcm_.finish();
      if (f.pairs == 0) continue;
      s_asm += f.asm_, s_var += f.variance, s_idm += f.idm;
      ++used;
    }
    if (used == 0) return false;
    mean->asm_ = s_asm / used;
    mean->variance = s_var / used;
    mean->idm = s_idm / used;
    return true;
  }

  int levels_ = 16;
  std::vector<double> offsets_{1, 0, 1, -1, 0, -1, -1, -1};  // 0°, 45°, 90°, 135° at distance 1
  int camera_ = -1;
  int min_pixels_ = 2;
  std::string prefix_ = "haralick";

  std::vector<std::pair<int, int>> offs_;
  uint16_t lut_[256] = {};
  GlcmAccumulator glcm_;
  std::vector<cv::Mat> grey_;
  std::vector<uint16_t> box_;
  std::vector<int> row_lo_, row_hi_;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::Haralick, terramrf::PluginKind::kFeature, "haralick",
                "Haralick texture: second angular moment, variance, inverse difference moment "
                "of the cell's pixels (paper 000 §4.3)")
