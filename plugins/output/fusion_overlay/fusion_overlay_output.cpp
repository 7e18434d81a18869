// Output "fusion_overlay": a debug image per frame and fused camera — the camera image with each
// cell's pixels tinted and each projected LiDAR point drawn in the colour of its cell's class.
// Shows at a glance whether the calibration fits (points on the objects they hit) and what the
// image features of a cell actually read. Written as <output_dir>/<subdir>/<frame_id>_<camera>.png.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

#include "terramrf/adapters/opencv_image.hpp"
#include "terramrf/atomic_file.hpp"
#include "terramrf/known_cameras.hpp"
#include "terramrf/output_folder.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {
namespace {

class FusionOverlayOutput final : public Output {
 public:
  void declare(ParamDecl& d) override {
    d.add("subdir", subdir_, "folder for the PNGs, relative to the run's output folder");
    d.add("cameras", cameras_, "names of the fused cameras to draw; empty = every fused camera")
        .unique();
    d.add("point_radius_px", point_radius_px_, "radius of a drawn point (0 = one pixel)")
        .unit("px")
        .range(0, 20);
    d.add("cell_alpha", cell_alpha_,
          "opacity of the class colour over each cell's pixels (0 = points only)")
        .unit("1")
        .range(0, 1);
    d.add("draw_unknown", draw_unknown_,
          "also draw points of cells labelled unknown and of points outside the grid (in the "
          "label set's unknown colour)");
  }

  void configure(const PluginContext& ctx) override {
    checkOutputSubdir(subdir_, "fusion");
    output_dir_ = ctx.output_dir;
    if (ctx.labels) labels_ = *ctx.labels;
  }

  std::vector<std::string> reads() const override {
    return {artefacts::kCellPixels, artefacts::kLabels};
  }

  void begin(const RunInfo& info) override {
    if (!info.output_dir.empty()) output_dir_ = info.output_dir;
    if (info.labels) labels_ = *info.labels;
    seen_cameras_.note(info.cameras);
  }

  std::vector<std::string> frameFiles(const std::string& frame_id,
                                      const Frame* frame) const override {
    return frameFileNames(path(""), safeFileName(frame_id), drawnCameras(seen_cameras_.with(frame)),
                          ".png");
  }

  void write(const FrameContext& ctx) override {
    if (!ctx.frame || !ctx.grid)
      throw std::invalid_argument("fusion_overlay: frame context without a frame or a grid");
    const Frame& f = *ctx.frame;
    const TerrainGrid& g = *ctx.grid;
    const LabelSet& labels = ctx.labels ? *ctx.labels : labels_;
    const std::string id = safeFileName(f.id.empty() ? std::to_string(ctx.index) : f.id);
    if (g.cellPixels().empty())
      throw std::runtime_error("fusion_overlay: frame " + id +
                               " has no fused camera pixels; put a camera_fusion stage in the "
                               "pipeline");
    std::size_t drawn = 0;
    for (const CellPixels& cp : g.cellPixels()) {
      if (cp.camera < 0 || std::size_t(cp.camera) >= f.cameras.size()) continue;
      const CameraImage& cam = f.cameras[cp.camera];
      const std::string name = cameraName(f, std::size_t(cp.camera));
      if (!cameras_.empty() && std::find(cameras_.begin(), cameras_.end(), name) == cameras_.end())
        continue;
      seen_cameras_.note(name);
      if (!cam.image || cam.image->empty() || cam.image->width != cp.width ||
          cam.image->height != cp.height)
        throw std::runtime_error("fusion_overlay: frame " + id + ", camera " + name +
                                 ": image missing or not the fused size");
      writeImageAtomic(path(id + "_" + safeFileName(name) + ".png"), render(f, g, labels, cp));
      ++drawn;
    }
    if (drawn == 0 && !cameras_.empty())
      throw std::runtime_error("fusion_overlay: frame " + id +
                               " has none of the configured "
                               "cameras fused");
  }

 private:
  // Only the configured cameras are drawn, when there are any.
  std::vector<std::string> drawnCameras(const std::vector<std::string>& cameras) const {
    return cameras_.empty() ? cameras : cameras_;
  }

  Image render(const Frame& f, const TerrainGrid& g, const LabelSet& labels,
               const CellPixels& cp) const {
    const Image& src = *f.cameras[cp.camera].image;
    Image out(src.width, src.height, 3);
    for (std::size_t i = 0, n = std::size_t(src.width) * src.height; i < n; ++i)
      for (int k = 0; k < 3; ++k)
        out.data[3 * i + k] = src.data[i * src.channels + (src.channels == 3 ? k : 0)];
    auto colour = [&](int cell, bool* ok) {
      // Unknown (and points off the grid) in the label set's unknown colour: grey was road's.
      std::array<uint8_t, 3> rgb = labels[labels::kUnknown].rgb;
      *ok = draw_unknown_;
      if (cell < 0) return rgb;
      const LabelId l = g.labels()[cell];
      if (l == labels::kUnknown) return rgb;
      *ok = true;
      return l < labels.size() ? labels[l].rgb : std::array<uint8_t, 3>{255, 0, 255};
    };
    // Cells: tint their pixels.
    const float a = float(cell_alpha_);
    if (a > 0 && cp.offsets.size() == g.cells() + 1) {
      for (int c = 0, n = int(g.cells()); c < n; ++c) {
        bool ok = false;
        const auto rgb = colour(c, &ok);
        if (!ok) continue;
        for (const uint32_t* it = cp.begin(c); it != cp.end(c); ++it) {
          uint8_t* p = &out.data[std::size_t(*it) * 3];
          for (int k = 0; k < 3; ++k) p[k] = uint8_t(std::lround((1 - a) * p[k] + a * rgb[k]));
        }
      }
    }
    // Points on top.
    cv::Mat view(out.height, out.width, CV_8UC3, out.data.data());
    const auto& cell_of = g.cellOfPoint();
    for (std::size_t i = 0; i < cp.pixel_of_point.size(); ++i) {
      const int32_t px = cp.pixel_of_point[i];
      if (px < 0) continue;
      bool ok = false;
      const auto rgb = colour(i < cell_of.size() ? cell_of[i] : -1, &ok);
      if (!ok) continue;
      const int u = px % cp.width, v = px / cp.width;
      if (point_radius_px_ == 0) {
        std::copy(rgb.begin(), rgb.end(), out.at(u, v));
      } else {
        cv::circle(view, cv::Point(u, v), point_radius_px_, cv::Scalar(rgb[0], rgb[1], rgb[2]),
                   cv::FILLED, cv::LINE_8);
      }
    }
    return out;
  }

  std::string path(const std::string& file) const {
    return (std::filesystem::path(output_dir_) / subdir_ / file).string();
  }

  std::string subdir_ = "fusion";
  std::vector<std::string> cameras_;
  int point_radius_px_ = 1;
  double cell_alpha_ = 0.3;
  bool draw_unknown_ = false;

  std::string output_dir_ = ".";
  LabelSet labels_ = LabelSet::defaults();
  KnownCameras seen_cameras_;  // name a failed frame's camera images
};

}  // namespace
}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::FusionOverlayOutput, terramrf::PluginKind::kOutput, "fusion_overlay",
                "debug PNG per camera: projected points and cell pixels coloured by class over the "
                "camera image")
