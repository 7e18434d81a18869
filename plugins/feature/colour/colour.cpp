// Colour f_c of a cell (paper 000 §4.3): the mean colour of the cell's pixels in one colour space.
//
//   rgb  colour_r, colour_g, colour_b   [0, 255], arithmetic means of the 8-bit values
//   hsv  colour_h [deg, 0..360), colour_s, colour_v [0, 1]  (OpenCV's RGB2HSV definition for
//        float RGB/255, computed in hsv.hpp in scalar code: the same bits on every CPU)
//   lab  colour_lab_l [0, 100], colour_lab_a, colour_lab_b  (CIE L*a*b*, D65, sRGB input; OpenCV
//        RGB2Lab on float RGB/255, which linearises the sRGB gamma and interpolates in a 3-D
//        table: within ~0.15 of the exact formula)
// Every pixel is converted first and the converted values are averaged (the mean of a non-linear
// space is not the conversion of the mean RGB).
// Hue is an angle: it is averaged as a direction, weighted by each pixel's chroma C = S·V (the
// radius of the hue circle in HSV's cone): h̄ = atan2(Σ C sin h, Σ C cos h). Grey pixels (C = 0),
// whose hue is undefined, thus do not count, and a cell whose weighted resultant is below
// 1e-6 per pixel (grey as a whole) gets NaN hue (no data) rather than an arbitrary 0°.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "hsv.hpp"
#include "terramrf/camera_fusion/fused_cameras.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {

class Colour final : public Stage {
 public:
  void declare(ParamDecl& d) override {
    d.add("space", space_, "colour space of the mean: rgb, hsv or lab")
        .choices({"rgb", "hsv", "lab"});
    d.add("prefix", prefix_,
          "layer names: <prefix>_<channel>, channels r g b | h s v | lab_l lab_a lab_b");
    fusion::declareCameraChoice(d, camera_, min_pixels_, 1);
  }

  void configure(const PluginContext&) override {
    for (int i = 0; i <= kTrig; ++i) {
      const double a = 2.0 * M_PI * i / kTrig;
      cos_[i] = float(std::cos(a)), sin_[i] = float(std::sin(a));
    }
    if (prefix_.empty()) throw ParamError("prefix", "is empty; expected e.g. 'colour'");
    // Lab's "b" would collide with RGB's blue (colour_b) when both run, hence lab_l/lab_a/lab_b.
    static const char *const kRgb[3] = {"r", "g", "b"}, *const kHsv[3] = {"h", "s", "v"},
                             *const kLab[3] = {"lab_l", "lab_a", "lab_b"};
    const char* const* ch = space_ == "rgb" ? kRgb : space_ == "hsv" ? kHsv : kLab;
    names_.clear();
    for (int i = 0; i < 3; ++i) names_.push_back(prefix_ + "_" + ch[i]);
  }

  std::vector<std::string> reads() const override { return {artefacts::kCellPixels}; }
  std::vector<std::string> writes() const override { return names_; }

  void process(FrameContext& ctx) override {
    TerrainGrid& g = *ctx.grid;
    const auto cams = fusion::fusedCameras(ctx, camera_, "colour");
    for (const auto& c : cams)
      if (c.image->channels != 3)
        throw InputError(c.file, "colour needs a 3-channel RGB image; this one has " +
                                     std::to_string(c.image->channels) + " channel(s)");
    Layer* out[3] = {&g.add(names_[0]), &g.add(names_[1]), &g.add(names_[2])};
    const int n = int(g.cells());
    cam_of_cell_.assign(n, -1);
    for (int c = 0; c < n; ++c) {
      const int k = fusion::bestCamera(cams, c);
      if (k >= 0 && cams[k].pixels->count(c) >= uint32_t(min_pixels_)) cam_of_cell_[c] = k;
    }
    for (std::size_t k = 0; k < cams.size(); ++k) {
      const CellPixels& cp = *cams[k].pixels;
      const uint8_t* rgb = cams[k].image->data.data();
      if (space_ == "rgb") {
        for (int c = 0; c < n; ++c) {
          if (cam_of_cell_[c] != int(k)) continue;
          uint64_t s[3] = {0, 0, 0};
          for (const uint32_t* it = cp.begin(c); it != cp.end(c); ++it) {
            const uint8_t* p = rgb + std::size_t(*it) * 3;
            s[0] += p[0], s[1] += p[1], s[2] += p[2];
          }
          for (int i = 0; i < 3; ++i) (*out[i])[c] = float(double(s[i]) / cp.count(c));
        }
        continue;
      }
      // Gather every pixel of this camera's cells, convert once, then average per cell.
      std::size_t total = 0;
      for (int c = 0; c < n; ++c)
        if (cam_of_cell_[c] == int(k)) total += cp.count(c);
      if (total == 0) continue;
      // One row, not one column: cvtColor (Lab) works row by row and vectorises along a row.
      // The buffers keep their capacity between frames: fresh large allocations cost page faults.
      in_.resize(3 * total);
      out_.resize(3 * total);
      cv::Mat buf(1, int(total), CV_32FC3, in_.data()), conv(1, int(total), CV_32FC3, out_.data());
      float* b = in_.data();
      for (int c = 0; c < n; ++c) {
        if (cam_of_cell_[c] != int(k)) continue;
        for (const uint32_t* it = cp.begin(c); it != cp.end(c); ++it) {
          const uint8_t* p = rgb + std::size_t(*it) * 3;
          *b++ = p[0] * (1.f / 255.f), *b++ = p[1] * (1.f / 255.f), *b++ = p[2] * (1.f / 255.f);
        }
      }
      if (space_ == "hsv") {
        // Not cv::cvtColor: its run-time choice of vector kernel changes the hue's last bits
        // from one CPU to another (hsv.hpp).
        for (std::size_t j = 0; j < 3 * total; j += 3)
          colour::rgbToHsv(in_[j], in_[j + 1], in_[j + 2], out_[j], out_[j + 1], out_[j + 2]);
      } else {
        cv::cvtColor(buf, conv, cv::COLOR_RGB2Lab);
        CV_Assert(conv.data == reinterpret_cast<uchar*>(out_.data()));  // converted in place
      }
      const float* q = out_.data();
      for (int c = 0; c < n; ++c) {
        if (cam_of_cell_[c] != int(k)) continue;
        const uint32_t m = cp.count(c);
        if (space_ == "hsv") {
          double sx = 0, sy = 0, ss = 0, sv = 0;
          for (uint32_t j = 0; j < m; ++j, q += 3) {
            const float chroma = q[1] * q[2];
            float c, sn;
            unitVector(q[0], &c, &sn);
            sx += chroma * c, sy += chroma * sn;
            ss += q[1], sv += q[2];
          }
          float hue = kNoData;
          if (std::hypot(sx, sy) > 1e-6 * m) {
            double deg = std::atan2(sy, sx) * (180.0 / M_PI);
            if (deg < 0) deg += 360.0;
            hue = deg >= 360.0 ? 0.f : float(deg);
          }
          (*out[0])[c] = hue;
          (*out[1])[c] = float(ss / m);
          (*out[2])[c] = float(sv / m);
        } else {
          double s[3] = {0, 0, 0};
          for (uint32_t j = 0; j < m; ++j, q += 3) s[0] += q[0], s[1] += q[1], s[2] += q[2];
          for (int i = 0; i < 3; ++i) (*out[i])[c] = float(s[i] / m);
        }
      }
    }
  }

 private:
  // (cos h, sin h) of a hue in degrees by linear interpolation in a table (error < 1e-6): the
  // library trig calls cost more than the whole colour conversion.
  static constexpr int kTrig = 4096;
  void unitVector(float deg, float* c, float* s) const {
    float t = deg * (kTrig / 360.f);
    t = t < 0 ? 0 : (t > kTrig ? kTrig : t);
    const int i = std::min(int(t), kTrig - 1);
    const float f = t - i;
    *c = cos_[i] + f * (cos_[i + 1] - cos_[i]);
    *s = sin_[i] + f * (sin_[i + 1] - sin_[i]);
  }
  float cos_[kTrig + 1] = {}, sin_[kTrig + 1] = {};

  std::string space_ = "rgb";
  std::string prefix_ = "colour";
  int camera_ = -1;
  int min_pixels_ = 1;

  std::vector<std::string> names_{"colour_r", "colour_g", "colour_b"};
  std::vector<int> cam_of_cell_;
  std::vector<float> in_, out_;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::Colour, terramrf::PluginKind::kFeature, "colour",
                "colour f_c: mean colour of the cell's pixels in RGB, HSV or CIE Lab "
                "(paper 000 §4.3)")
