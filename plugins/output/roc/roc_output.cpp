// Output "roc": per-class ROC curves of the cell-wise labelling (paper 000 §5, Figure 6) from the
// optimiser's score layers (`score.<class>`), accumulated over the run. Without score layers it
// falls back to the local energy margin of the final labelling (or skips, as configured) and says
// which in its summary. Rules and formats: docs/compare.md ("ROC curves").
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>
#include <sstream>

#include "terramrf/atomic_file.hpp"
#include "terramrf/output_folder.hpp"
#include "terramrf/plugin.hpp"
#include "terramrf/roc.hpp"
#include "terramrf/stop_request.hpp"

namespace terramrf {

namespace {
/// Rounded, not cut: 0.9919 is 0.992 as in summary.json and compare's tables.
std::string fixed3(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3f", v);
  return b;
}
}  // namespace
namespace {

class RocOutput final : public Output {
 public:
  void declare(ParamDecl& d) override {
    d.add("subdir", subdir_,
          "folder for roc.csv, roc.svg and summary.json, relative to the run's "
          "output folder");
    d.add("fallback", fallback_,
          "scores when the optimiser writes no score layers: local_energy (margin of the eq. 12 "
          "local energy given the final labelling) or skip (no curve for such frames)")
        .choices({"local_energy", "skip"});
    d.add("max_points", max_points_,
          "at most this many points per curve in the CSV/SVG (the AUC uses every sample)")
        .unit("points")
        .range(2, RocAccumulator::kMaxCurvePoints);
    d.add("title", title_, "plot title; empty = the run's config file");
  }
  void configure(const PluginContext& ctx) override {
    checkOutputSubdir(subdir_, "roc");
    output_dir_ = ctx.output_dir;
    if (ctx.labels) labels_ = *ctx.labels;
  }
  std::vector<std::string> reads() const override {
    // Score layers are optional (not every optimiser writes them), so they are not declared.
    return {artefacts::kPoints, artefacts::kLabels};
  }

  void begin(const RunInfo& info) override {
    if (!info.output_dir.empty()) output_dir_ = info.output_dir;
    if (info.labels) labels_ = *info.labels;
    config_ = info.config_path;
    acc_.emplace(labels_);
  }

  void write(const FrameContext& ctx) override {
    if (!ctx.frame || !ctx.grid)
      throw std::invalid_argument("roc: frame context without a frame or grid");
    if (!acc_) acc_.emplace(ctx.labels ? *ctx.labels : labels_);
    const EnergyModel* em = fallback_ == "local_energy" ? &ctx.energy : nullptr;
    acc_->addFrame(*ctx.grid, *ctx.frame, em);
  }

  void end(const RunSummary& summary) override {
    if (!acc_) acc_.emplace(labels_);
    const auto curves = acc_->curves(static_cast<std::size_t>(max_points_));
    std::ostringstream note;
    // The curves of an interrupted run are those of its first frames only.
    if (const std::string stopped = interruptionText(summary); !stopped.empty())
      note << "run " << stopped << ", curves of those only; ";
    if (acc_->frames_with_layers + acc_->frames_with_energy_fallback == 0) {
      note << "no ROC: no frame had ground truth and scores"
           << (fallback_ == "skip" ? " (the optimiser wrote no score layers; fallback: skip)" : "");
    } else {
      note << acc_->frames_with_layers << " frame(s) scored from score layers, "
           << acc_->frames_with_energy_fallback << " from the local energy margin, "
           << acc_->frames_without_scores << " without scores; " << acc_->cells_without_score
           << " of " << acc_->cells_scored << " scored cells had no score";
    }
    std::ostringstream js;
    js << "{\n  \"schema\": \"terramrf.roc/1\",\n  \"note\": \"" << note.str()
       << "\",\n  \"frames_with_score_layers\": " << acc_->frames_with_layers
       << ",\n  \"frames_with_energy_fallback\": " << acc_->frames_with_energy_fallback
       << ",\n  \"frames_without_scores\": " << acc_->frames_without_scores
       << ",\n  \"cells_scored\": " << acc_->cells_scored
       << ",\n  \"cells_without_score\": " << acc_->cells_without_score
       << ",\n  \"curves\": " << rocSummaryJson(curves) << "\n}\n";
    writeFileAtomic(path("summary.json"), js.str());
    writeFileAtomic(path("roc.csv"), rocCsv(curves));
    writeFileAtomic(path("roc.svg"),
                    rocSvg(curves, labels_, title_.empty() ? "ROC — " + config_ : title_));
    std::cout << (curves.empty() ? "" : "ROC: ") << note.str();
    for (const auto& c : curves)
      std::cout << "; " << c.class_name << " AUC " << (c.defined() ? fixed3(c.auc) : "–");
    std::cout << "\n" << std::flush;
  }

  std::vector<std::string> summaryFiles() const override {
    return {path("summary.json"), path("roc.csv"), path("roc.svg")};
  }

 private:
  std::string path(const std::string& f) const {
    return (std::filesystem::path(output_dir_) / subdir_ / f).string();
  }

  std::string subdir_ = "roc";
  std::string fallback_ = "local_energy";
  int max_points_ = 500;
  std::string title_;
  std::string output_dir_, config_;
  LabelSet labels_ = LabelSet::defaults();
  std::optional<RocAccumulator> acc_;
};

}  // namespace
}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::RocOutput, terramrf::PluginKind::kOutput, "roc",
                "per-class ROC curves (cell-wise, paper 000 Fig. 6) from score layers: CSV, SVG, "
                "AUC summary")
