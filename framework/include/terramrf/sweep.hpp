#pragma once
// Training a feature model (`terramrf train`) and comparing feature sets × optimisers × datasets
// (`terramrf compare`), as a library so both commands and their tests share one implementation.
//
// Both read YAML with a `split:` section whose train and test sets must be disjoint; the file
// formats, the overlap rule and every output file are documented in docs/training.md and
// docs/compare.md. Problems in a file are reported like the config validator does
// (ConfigError with `file:line:col: ...` diagnostics, all at once).
#include <cstddef>
#include <iosfwd>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "terramrf/config.hpp"
#include "terramrf/evaluation.hpp"
#include "terramrf/label_set.hpp"
#include "terramrf/roc.hpp"

namespace terramrf {

/// Inclusive range of frame indices of a source; `last` = npos means "to the end".
struct FrameRange {
  static constexpr std::size_t npos = std::numeric_limits<std::size_t>::max();
  std::size_t first = 0;
  std::size_t last = npos;
  bool all() const { return first == 0 && last == npos; }
  bool overlaps(const FrameRange& o) const { return first <= o.last && o.first <= last; }
  /// "all frames", "frames 3-7", "frame 4".
  std::string str() const;
};

// ---- training -----------------------------------------------------------------------------------

struct TrainOptions {
  std::string config_path;               ///< pipeline config (optionally with a `split:` section)
  std::vector<std::string> data;         ///< --data folders: each replaces the source's `path`
  std::string model_out;                 ///< model file to write
  std::vector<std::string> features;     ///< feature layers; empty = from the config (see docs)
  std::size_t limit = 0;                 ///< at most this many frames per data item (0 = all)
  bool progress = true;                  ///< progress bar on stderr
  std::ostream* log = nullptr;           ///< failures and notes (default std::cerr)
  std::vector<std::string> plugin_dirs;  ///< empty = PluginRegistry::defaultSearchDirs()
};

struct TrainedItem {
  std::string label;  ///< what the item is ("…/converted_semantickitti", "seed 7")
  std::string source_type;
  std::string path;       ///< the source's data folder, if it has one
  std::string label_map;  ///< the source's `label_map` parameter, if it has one
  FrameRange frames;
  std::vector<std::string> frame_ids;  ///< frames that were processed
  std::size_t labelled_frames = 0;
  std::size_t failed_frames = 0;
};

struct TrainResult {
  std::string model_path;
  std::vector<std::string> features;
  std::vector<TrainedItem> items;
  std::size_t frames = 0;           ///< processed
  std::size_t labelled_frames = 0;  ///< processed and carrying per-point labels
  std::vector<std::pair<std::string, std::string>> failed;  ///< frame id, reason
  /// Classes and features that got fewer than two training cells (not in the model).
  std::vector<std::string> missing;
  /// How each layer was computed (PluginContext::layer_origins); the model records its features'.
  std::map<std::string, std::string> layer_origins;
};

/// Runs the config's source and its egomotion/feature stages (energy and optimiser stages are not
/// run) over every training item, learns per-class mean/σ per feature with the feature_stats
/// output plugin, and writes the model with its provenance. Throws ConfigError (file positions)
/// for a bad config or an overlapping split, std::runtime_error for anything else (no labelled
/// frame, a feature no stage writes, …).
TrainResult trainModel(const TrainOptions& options);

/// The checks `train` makes of a pipeline config's `split:` section (keys, items, disjoint train
/// and test sets), without training: for `terramrf validate`. Throws ConfigError; a config
/// without `split:` passes. Returns the notes `train` would print (test frames of a recording
/// trained on).
std::vector<std::string> checkTrainSplit(const std::string& config_path,
                                         const std::vector<std::string>& plugin_dirs = {});

// ---- compare ------------------------------------------------------------------------------------

struct CompareOptions {
  std::string sweep_path;
  std::string output_dir;  ///< "" = the sweep's `output_dir` (relative to it) or ./out/<name>
  std::size_t limit = 0;   ///< at most this many frames per split item (0 = as the sweep says)
  bool progress = true;
  std::ostream* log = nullptr;
  std::vector<std::string> plugin_dirs;  ///< empty = PluginRegistry::defaultSearchDirs()
};

struct FrameEnergy {
  std::string frame;
  double initial = 0;     ///< as the optimiser reported it
  double reported = 0;    ///< final energy as the optimiser reported it (ctx.optimiser)
  double recomputed = 0;  ///< energy of the labelling it returned, recomputed from the model
  int iterations = 0;
  bool converged = false;
};

/// Per-scan times [ms] of one run; index = successfully processed frame.
struct RunTimes {
  std::vector<double> processing;  ///< grid + every stage (features, energy, optimiser)
  std::vector<double> features;    ///< grid + egomotion + feature stages
  std::vector<double> mrf;         ///< energy + optimiser stages
  std::vector<double> total;       ///< the runner's total (read + stages + outputs)
};

struct RunRecord {
  enum class Status { kOk, kSkipped, kFailed };
  std::string dataset, feature_set, optimiser;
  Status status = Status::kOk;
  std::string reason;  ///< why skipped/failed; notes for ok runs (e.g. ROC source)
  std::string output_dir;
  std::size_t frames = 0;  ///< frames of the test item
  std::size_t frames_ok = 0;
  std::vector<std::pair<std::string, std::string>> failed;  ///< frame id, reason
  EvalCounts counts;
  /// The same counts per scanned frame (frame id, counts), in reading order: one bad scan or
  /// one easy scan must not hide in the total.
  std::vector<std::pair<std::string, EvalCounts>> per_scan;
  std::vector<RocCurve> roc;
  ScoreSource score_source = ScoreSource::kNone;  ///< of the frames that had scores
  std::string roc_note;  ///< why there is no ROC, or where its scores came from
  RunTimes times;
  std::vector<FrameEnergy> energies;
  std::string key() const { return dataset + "__" + feature_set + "__" + optimiser; }
};

struct ModelRecord {
  std::string feature_set;
  std::string path;      ///< model used by the feature set's runs ("" if none)
  bool trained = false;  ///< false: given in the sweep, or not available (see reason)
  std::string reason;    ///< why no model (its runs are then skipped)
  std::vector<std::string> train_items;  ///< what it was trained on
  std::size_t frames = 0, labelled_frames = 0;
  std::vector<std::string> missing;
  /// Training frames that failed to read or process (frame, reason): skipped, never silently.
  std::vector<std::pair<std::string, std::string>> failed;
  std::string selected;  ///< with `select:`: the candidate chosen on validation ("components=4")
};

/// How `select:` chose one feature set's training and energy parameters: every candidate was
/// trained on the train split and scored on the validation split (never on the test split) with
/// one optimiser — or, with split.folds, trained on all folds but one and scored on that one, for
/// each fold in turn; the first candidate within `tie` of the best score won.
struct SelectionRecord {
  std::string feature_set;
  std::string optimiser;  ///< the optimiser that scored the candidates
  std::string score;      ///< "macro_f1" or "f1_<class>" (cell-wise, paper 001 §VI-B rules)
  double tie = 0;         ///< scores this close to the best count as ties
  bool refit = false;     ///< the test runs used the choice learnt again on train + validation
  std::size_t folds = 0;  ///< split.folds cross-validated (0 = scored on split.validation)
  std::vector<std::string> candidates;  ///< "components=2, beta=0.8", in sweep order
  std::vector<std::string> models;  ///< model file each candidate used (folds: one each, "; ")
  std::vector<EvalCounts> counts;  ///< per candidate, summed over the validation items (or folds)
  std::vector<double> scores;           ///< per candidate; NaN = it failed (see notes)
  std::vector<std::string> notes;       ///< per candidate: why it failed, or ""
  int chosen = -1;                      ///< index into candidates, -1 = none could be scored
};

struct SweepResult {
  std::string name, sweep_path, output_dir;
  LabelSet labels;
  std::vector<std::string> datasets;      ///< test items, in sweep order
  std::vector<std::string> feature_sets;  ///< in sweep order
  std::vector<std::string> optimisers;    ///< in sweep order
  std::vector<std::string> train_items;   ///< descriptions of the train split
  /// Descriptions of the validation split, or of the folds' items ("fold 1: …").
  std::vector<std::string> validation_items;
  /// Number of split.folds: select: cross-validated inside the train split (0 = it used
  /// split.validation, or there is no select:).
  std::size_t folds = 0;
  std::vector<ModelRecord> models;
  std::vector<SelectionRecord> selections;  ///< one per feature set that `select:` tuned
  std::vector<RunRecord> runs;  ///< dataset-major, then feature set, then optimiser
  std::size_t limit = 0;
  /// Frame cache (`frame_cache_mb`): frames kept after their first read, their size, and the
  /// reads served from memory instead of the source.
  std::size_t cached_frames = 0, cache_hits = 0;
  double cached_mb = 0;
  const RunRecord* find(const std::string& dataset, const std::string& feature_set,
                        const std::string& optimiser) const;
  /// Non-zero when a stop was requested (the signal: SIGINT, SIGTERM; stop_request.hpp): the run
  /// or training in hand stopped after its frame in hand (failed, "interrupted …"), the runs and
  /// trainings after it were skipped, and the report was still written.
  int stop_signal = 0;
  /// 0: every run that could run did (skipped runs are reported, not failures); 3: a run failed
  /// or lost frames; 128 + the signal (130, 143) when interrupted.
  int exitCode() const;
};

/// Parses and validates a sweep file (structure, plugin parameters, disjoint split) without
/// running anything; throws ConfigError with every problem. Returns the runs it would do, as
/// "dataset × feature set × optimiser", and the skipped ones with their reason.
struct SweepPlan {
  std::string name;
  std::vector<std::string> runs;
  std::vector<std::pair<std::string, std::string>> skipped;  ///< run, reason
  /// With `select:`: "L: sim_val × icm [components=2]", one per feature set, candidate and
  /// validation item, run before the test runs.
  std::vector<std::string> selection_runs;
  /// What the sweep allows but a reader of its figures should know (e.g. a test item of the
  /// same recording as a train item, other frames), as `compare` logs them.
  std::vector<std::string> notes;
};
SweepPlan planSweep(const std::string& sweep_path,
                    const std::vector<std::string>& plugin_dirs = {});

/// Trains one model per feature set on the train split (unless the sweep gives one), runs every
/// test item × feature set × optimiser, and writes the report (writeSweepReport) to the output
/// folder. With `select:`, each feature set's parameters are first chosen on the validation split
/// (SelectionRecord). Throws ConfigError for a bad sweep file (nothing run).
SweepResult runSweep(const CompareOptions& options);

/// Writes summary.md (all tables), accuracy.{md,csv}, runtime.{md,csv}, evaluation.{md,csv},
/// energies.{md,csv}, roc_auc.csv, roc/<run>.{csv,svg}, roc/<dataset>__<optimiser>.svg,
/// selection.{md,csv} (with `select:`) and results.json into `dir`.
void writeSweepReport(const SweepResult& result, const std::string& dir);

/// Table shaped like paper 000 Tables 1–2: rows "<Class>/TPR", "<Class>/FPR" (cell-wise), one
/// column per feature set; for one dataset and optimiser. Markdown.
std::string accuracyTable(const SweepResult& r, const std::string& dataset,
                          const std::string& optimiser);
/// Table shaped like paper 000 Table 3: per feature set (and optimiser) mean, std, max, min of the
/// per-scan processing time [ms]; for one dataset. Markdown.
std::string runtimeTable(const SweepResult& r, const std::string& dataset);

}  // namespace terramrf
