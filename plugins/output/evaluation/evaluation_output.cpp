// Output "evaluation": scores each labelled frame with the rules of paper 001 §VI-B (see
// docs/evaluation.md), writes per-frame JSON, and at the end the run's totals as JSON and as a
// Markdown table shaped like paper 001 Table I (also printed to stdout).
#include <filesystem>
#include <iostream>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>

#include "terramrf/atomic_file.hpp"
#include "terramrf/evaluation.hpp"
#include "terramrf/output_folder.hpp"
#include "terramrf/plugin.hpp"
#include "terramrf/stop_request.hpp"
#include "terramrf/text_format.hpp"

namespace terramrf {
namespace {

class EvaluationOutput : public Output {
 public:
  void declare(ParamDecl& d) override {
    d.add("subdir", subdir_,
          "folder for the evaluation files, relative to the run's output folder");
    d.add("per_frame", per_frame_, "also write <frame_id>.json with the counts of each frame");
    d.add("rules", rules_, "evaluation rule set (paper001: paper 001 §VI-B with obstacle rules)")
        .choices({"paper001"});
  }

  void configure(const PluginContext& ctx) override {
    checkOutputSubdir(subdir_, "evaluation");
    try {
      rules_id_ = evalRulesFromString(rules_);
    } catch (const std::invalid_argument& e) {
      throw ParamError("rules", e.what());
    }
    output_dir_ = ctx.output_dir;
    if (ctx.labels) labels_ = *ctx.labels;
  }

  std::vector<std::string> reads() const override {
    return {artefacts::kPoints, artefacts::kLabels};
  }

  void begin(const RunInfo& info) override {
    if (!info.output_dir.empty()) output_dir_ = info.output_dir;
    if (info.labels) labels_ = *info.labels;
    evaluator_.emplace(labels_, rules_id_);
  }

  void write(const FrameContext& ctx) override {
    if (!ctx.frame || !ctx.grid) {
      throw std::invalid_argument("evaluation: frame context without a frame or a grid");
    }
    if (!evaluator_) {  // driven without begin() (e.g. programmatic use)
      if (ctx.labels) labels_ = *ctx.labels;
      evaluator_.emplace(labels_, rules_id_);
    }
    const Frame& frame = *ctx.frame;
    const EvalCounts counts = evaluator_->addFrame(*ctx.grid, frame);
    seen_.insert(frame.id);
    if (counts.scans == 0 || !per_frame_) return;  // no ground truth: counted, nothing to write
    const std::string id = frame.id.empty() ? std::to_string(ctx.index) : frame.id;
    writeFileAtomic(path(id + ".json"), toJson(counts, labels_, rules_id_, id));
  }

  void end(const RunSummary& summary) override {
    if (!evaluator_) evaluator_.emplace(labels_, rules_id_);
    EvalCounts total = evaluator_->total();
    // A frame that failed in an output after this one was evaluated all the same: counted, and
    // said so, as the run reports it failed.
    for (const auto& failed : summary.failed) {
      if (seen_.count(failed.first))
        ++total.frames_failed_after_evaluation;
      else
        ++total.frames_failed;
    }
    std::string table = toTable(total, labels_, rules_id_);
    if (total.scans == 0) {
      table += "- no frame with ground truth was evaluated; all ratios are undefined\n";
    }
    std::string json = toJson(total, labels_, rules_id_);
    // An interrupted run's totals are those of its first frames only: said first in the table,
    // and right after the schema in the JSON. A stream planned no number of frames: null.
    if (const std::string stopped = interruptionText(summary); !stopped.empty()) {
      table = "**Run " + stopped + "**: these totals cover those frames only.\n\n" + table;
      json.insert(
          json.find('\n', json.find("\"schema\"")) + 1,
          "  \"interrupted\": " + jsonQuote("run " + stopped) + ",\n  \"frames_planned\": " +
              (summary.frames_total ? std::to_string(summary.frames_total) : "null") + ",\n");
    }
    writeFileAtomic(path("summary.json"), json);
    writeFileAtomic(path("summary.md"), table);
    std::cout << table << std::flush;
  }

  std::vector<std::string> frameFiles(const std::string& frame_id,
                                      const Frame* /*frame*/) const override {
    return {path(frame_id + ".json")};
  }
  std::vector<std::string> summaryFiles() const override {
    return {path("summary.json"), path("summary.md")};
  }

 private:
  std::string path(const std::string& file) const {
    return (std::filesystem::path(output_dir_) / subdir_ / file).string();
  }

  std::string subdir_ = "evaluation";
  bool per_frame_ = true;
  std::string rules_ = "paper001";

  EvalRules rules_id_ = EvalRules::kPaper001;
  std::string output_dir_;
  LabelSet labels_ = LabelSet::defaults();
  std::optional<Evaluator> evaluator_;
  std::set<std::string> seen_;  ///< ids of frames added (with or without truth)
};

}  // namespace
}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::EvaluationOutput, terramrf::PluginKind::kOutput, "evaluation",
                "Point-wise and cell-wise precision/recall, TPR/FPR and confusion matrices "
                "against per-point ground truth (paper 001 §VI-B rules)")
