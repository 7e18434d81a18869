// Output "grid_csv": the labelled grid as a per-cell CSV table per frame, for scripts and
// spreadsheets (format in grid_csv_format.hpp and docs/plugins/outputs.md).
#include <filesystem>
#include <stdexcept>
#include <string>

#include "grid_csv_format.hpp"
#include "terramrf/atomic_file.hpp"
#include "terramrf/output_folder.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {
namespace {

class GridCsvOutput : public Output {
 public:
  void declare(ParamDecl& d) override {
    d.add("subdir", subdir_, "folder for the CSV files, relative to the run's output folder");
    d.add("layers", layers_, "float layers to write as columns; empty = every layer of the grid")
        .unique();
    d.add("truth", truth_,
          "add columns truth, truth_name, truth_points: each cell's true class by the evaluation's "
          "rule (paper 001 §VI-B) and its labelled points; empty where the frame has no truth");
  }

  void configure(const PluginContext& ctx) override {
    checkOutputSubdir(subdir_, "grid_csv");
    output_dir_ = ctx.output_dir;
    if (ctx.labels) labels_ = *ctx.labels;
  }

  std::vector<std::string> reads() const override {
    std::vector<std::string> r{artefacts::kLabels};
    r.insert(r.end(), layers_.begin(), layers_.end());
    return r;
  }

  void begin(const RunInfo& info) override {
    if (!info.output_dir.empty()) output_dir_ = info.output_dir;
    if (info.labels) labels_ = *info.labels;
  }

  void write(const FrameContext& ctx) override {
    if (!ctx.frame || !ctx.grid) {
      throw std::invalid_argument("grid_csv: frame context without a frame or a grid");
    }
    const std::string id =
        safeFileName(ctx.frame->id.empty() ? std::to_string(ctx.index) : ctx.frame->id);
    const std::string csv = gridToCsv(*ctx.grid, ctx.labels ? *ctx.labels : labels_, layers_,
                                      truth_ ? &ctx.frame->truth : nullptr);
    writeFileAtomic((std::filesystem::path(output_dir_) / subdir_ / (id + ".csv")).string(), csv);
  }

  std::vector<std::string> frameFiles(const std::string& frame_id,
                                      const Frame* /*frame*/) const override {
    return {(std::filesystem::path(output_dir_) / subdir_ / (safeFileName(frame_id) + ".csv"))
                .string()};
  }

 private:
  std::string subdir_ = "grid_csv";
  std::vector<std::string> layers_;
  bool truth_ = false;

  std::string output_dir_ = ".";
  LabelSet labels_ = LabelSet::defaults();
};

}  // namespace
}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::GridCsvOutput, terramrf::PluginKind::kOutput, "grid_csv",
                "per-cell CSV table of the labelled grid per frame")
