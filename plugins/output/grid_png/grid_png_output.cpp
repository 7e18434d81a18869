// Output "grid_png": one bird's-eye PNG of the labelled grid per frame (see grid_render.hpp for
// the orientation), optionally with the frame's camera images beside it.
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <stdexcept>
#include <string>

#include "grid_render.hpp"
#include "terramrf/adapters/opencv_image.hpp"
#include "terramrf/atomic_file.hpp"
#include "terramrf/known_cameras.hpp"
#include "terramrf/output_folder.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {
namespace {

class GridPngOutput : public Output {
 public:
  void declare(ParamDecl& d) override {
    d.add("subdir", subdir_, "folder for the PNGs, relative to the run's output folder");
    d.add("pixels_per_cell", pixels_per_cell_, "side of the square pixel block drawn per cell")
        .unit("px")
        .range(1, 64);  // and at most 16384 px per image side (configure)
    d.add("write_camera_images", write_camera_images_,
          "also write each camera image of the frame as <frame_id>_<camera>.png");
  }

  void configure(const PluginContext& ctx) override {
    checkOutputSubdir(subdir_, "grid");
    // The grid's size is known here: an image too large to draw is a config error, not a
    // std::bad_alloc in every frame.
    const std::string why =
        gridImageSizeProblem(ctx.grid.cols(), ctx.grid.rows(), pixels_per_cell_);
    if (!why.empty()) throw ParamError("pixels_per_cell", why);
    output_dir_ = ctx.output_dir;
    if (ctx.labels) labels_ = *ctx.labels;
  }

  std::vector<std::string> reads() const override { return {artefacts::kLabels}; }

  void begin(const RunInfo& info) override {
    if (!info.output_dir.empty()) output_dir_ = info.output_dir;
    if (info.labels) labels_ = *info.labels;
    seen_cameras_.note(info.cameras);
  }

  void write(const FrameContext& ctx) override {
    if (!ctx.frame || !ctx.grid) {
      throw std::invalid_argument("grid_png: frame context without a frame or a grid");
    }
    const std::string id =
        safeFileName(ctx.frame->id.empty() ? std::to_string(ctx.index) : ctx.frame->id);
    GridRenderStats stats;
    const Image img =
        renderGrid(*ctx.grid, ctx.labels ? *ctx.labels : labels_, pixels_per_cell_, &stats);
    if (stats.unnamed_label_cells > 0 && !warned_unnamed_) {
      std::cerr << "grid_png: frame " << id << ": " << stats.unnamed_label_cells
                << " cells carry label ids the label set does not name (drawn magenta)\n";
      warned_unnamed_ = true;
    }
    writeImageAtomic(path(id + ".png"), img);
    if (!write_camera_images_) return;
    for (std::size_t i = 0; i < ctx.frame->cameras.size(); ++i) {
      const CameraImage& cam = ctx.frame->cameras[i];
      if (!cam.image || cam.image->empty()) continue;  // calibration-only camera: nothing to show
      const std::string name = cameraName(*ctx.frame, i);
      seen_cameras_.note(name);
      writeImageAtomic(path(id + "_" + safeFileName(name) + ".png"), *cam.image);
    }
  }

  std::vector<std::string> frameFiles(const std::string& frame_id,
                                      const Frame* frame) const override {
    return frameFileNames(path(""), safeFileName(frame_id), drawnCameras(seen_cameras_.with(frame)),
                          ".png");
  }

 private:
  std::vector<std::string> drawnCameras(const std::vector<std::string>& cameras) const {
    return write_camera_images_ ? cameras : std::vector<std::string>{};
  }
  std::string path(const std::string& file) const {
    return (std::filesystem::path(output_dir_) / subdir_ / file).string();
  }

  std::string subdir_ = "grid";
  int pixels_per_cell_ = 8;
  bool write_camera_images_ = true;

  std::string output_dir_ = ".";
  LabelSet labels_ = LabelSet::defaults();
  bool warned_unnamed_ = false;
  KnownCameras seen_cameras_;  // name a failed frame's camera images
};

}  // namespace
}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::GridPngOutput, terramrf::PluginKind::kOutput, "grid_png",
                "bird's-eye PNG of the labelled grid per frame (+ camera images)")
