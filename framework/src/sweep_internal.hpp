#pragma once
// Internal to the framework (not installed): what the files implementing sweep.hpp share.
//   sweep_load.cpp      parsing and validating sweep files (and what train configs share with them)
//   sweep_split.cpp     split items: parsing, data identity, the disjointness check, their sources
//   sweep_pipeline.cpp  plugins from YAML entries, pipelines assembled from them
//   sweep_training.cpp  learning a model with feature_stats (`terramrf train`)
//   sweep_run.cpp       running the grid of a sweep (`terramrf compare`)
//   sweep_select.cpp    `select:`: candidates trained, scored on split.validation (or on
//                       split.folds, each learnt on the other folds), one chosen
//   cached_source.hpp   frames kept between the runs of a sweep
//   sweep_report.cpp    Markdown/CSV/JSON/SVG reports
//
// Pipelines are assembled from YAML snippets of the train config / sweep file (so errors point at
// that file) instead of going through loadPipeline: a sweep combines pieces from several places,
// and training must not configure energy/optimiser stages whose model file does not exist yet.
//
// yaml-cpp: assigning one Node variable to another that already refers to a node overwrites the
// shared node (every handle sees it); rebinding a variable is Node::reset.
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <ostream>
#include <set>
#include <string>
#include <vector>

#include "cached_source.hpp"
#include "config_internal.hpp"
#include "terramrf/config.hpp"
#include "terramrf/pipeline.hpp"
#include "terramrf/registry.hpp"
#include "terramrf/sweep.hpp"

namespace terramrf::sweep_detail {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---- diagnostics, paths, names (config.cpp, sweep_load.cpp, sweep_report.cpp) ------------------

using detail::Diags;

/// Sweep and train files list the allowed keys when none is close to an unknown one.
inline constexpr detail::KeyHint kKeyHint = detail::KeyHint::kNearestOrAll;

/// The output plugin that learns feature models.
inline constexpr const char* kStatsPlugin = "feature_stats";

/// `p` relative to `base_dir` unless absolute, lexically normalised.
std::string absPath(const std::string& base_dir, const std::string& p);
/// `s` usable as a file name: anything but letters, digits and + - . _ becomes '_'.
std::string sanitize(const std::string& s);
/// When result files say they were made, UTC, ISO 8601 ("2026-12-07T02:26:50Z"): the current
/// time, or SOURCE_DATE_EPOCH's (seconds since 1970) when that environment variable is set and
/// not empty, so the files of two runs on the same data are the same bytes. Throws
/// std::runtime_error naming the variable for a value that is not a whole number of seconds.
std::string creationTime();

// ---- progress bar -------------------------------------------------------------------------------

class Progress {
 public:
  explicit Progress(bool enabled) : enabled_(enabled), tty_(::isatty(2) != 0) {}
  void setTotal(std::size_t n) { total_ = n; }
  void tick(const std::string& what) { advanceTo(done_ + 1, what); }
  void advanceTo(std::size_t done, const std::string& what) {
    done_ = std::min(std::max(done, done_), std::max(total_, done));
    if (!enabled_ || total_ == 0) return;
    const std::size_t step = std::max<std::size_t>(1, total_ / 20);
    if (!tty_ && (done_ == printed_ || (done_ != total_ && done_ / step == printed_ / step)))
      return;
    printed_ = done_;
    const int width = 30;
    const int filled = static_cast<int>(width * std::min(done_, total_) / total_);
    std::fprintf(stderr, "%s[%s%s] %zu/%zu scans  %s%s", tty_ ? "\r" : "",
                 std::string(filled, '#').c_str(), std::string(width - filled, '.').c_str(), done_,
                 total_, what.c_str(), tty_ ? "\033[K" : "\n");
    std::fflush(stderr);
  }
  /// Ends the bar's line so log messages start on a fresh one.
  void breakLine() {
    if (enabled_ && tty_ && total_ > 0) std::fprintf(stderr, "\n");
  }
  void finish() {
    if (enabled_ && tty_ && total_ > 0) std::fprintf(stderr, "\n");
  }

 private:
  bool enabled_, tty_;
  std::size_t total_ = 0, done_ = 0, printed_ = 0;
};

// ---- plugins from snippets (sweep_pipeline.cpp) -------------------------------------------------

/// Outcome of instantiating one `{name, type, params}` entry.
struct Made {
  std::unique_ptr<Plugin> plugin;
  std::string not_installed;  ///< set when the type is unknown and the caller tolerates that
  PluginKind kind = PluginKind::kFeature;
  bool ok() const { return plugin != nullptr; }
};

/// Creates, parameterises and configures the plugin of entry `e`. Problems become diagnostics at
/// the entry's position in `d.file`; an unknown type only sets `not_installed` when
/// `tolerate_missing`. With `configure` false only the parameter names are checked (the energy
/// entry of a sweep, whose model is trained later). The entry is checked by
/// detail::createEntryPlugin, as in loadPipeline.
Made makePlugin(PluginRegistry& reg, const YAML::Node& e, const std::string& section,
                const std::vector<PluginKind>& kinds, const PluginContext& ctx, Diags& d,
                bool tolerate_missing, bool configure = true);

// ---- the common part of every pipeline (sweep_load.cpp) -----------------------------------------

/// What a train config or sweep file says about every pipeline it makes: grid, labels, plugin
/// folders, where relative paths start.
struct Frame0 {
  std::string file;      ///< the train config / sweep file (diagnostics)
  std::string base_dir;  ///< its folder
  GridGeometry grid;
  std::shared_ptr<LabelSet> labels = std::make_shared<LabelSet>(LabelSet::defaults());
  bool custom_labels = false;
  YAML::Node labels_node;
  std::vector<std::string> plugin_dirs;  ///< absolute, from the file's plugin_path

  PluginContext context(const std::string& output_dir) const {
    PluginContext ctx;
    ctx.config_dir = base_dir;
    ctx.output_dir = output_dir;
    ctx.grid = grid;
    ctx.labels = labels.get();
    return ctx;
  }
};

/// Reads grid, labels and plugin_path as loadPipeline does (detail::readCommonKeys).
void readFrame0(const YAML::Node& root, Frame0& f0, Diags& d, PluginRegistry& reg);
/// A scalar or a list of scalars as strings; empty if `n` is not defined.
std::vector<std::string> stringList(const YAML::Node& n);

// ---- split items (sweep_split.cpp) --------------------------------------------------------------

/// One element of a split: a source entry (with the item's overrides applied) and frames.
struct Item {
  std::string dataset;  ///< sweep dataset name ("" in train configs)
  std::string label;    ///< unique display name
  YAML::Node source;    ///< {name, type, params} after overrides
  std::string type;
  FrameRange frames;
  YAML::Mark mark;
  bool range_given = false;
  std::string path_written;  ///< the item's `path:` as written (labels show it), or ""
  // Identity of the data, for the overlap check.
  std::string path;      ///< canonical data folder, if the source reads one
  std::string identity;  ///< type + distinguishing parameters, when there is no path
  std::string identity_text;
  // Filled when prepared.
  std::unique_ptr<Source> src;
  std::string unavailable;           ///< why the source cannot be made (type not installed)
  std::size_t size = 0;              ///< frames of the source
  std::size_t first = 0, count = 0;  ///< frames to run after range and limit
  /// "sim_train (frames 0-9)": the label and the frames the runs read (after --limit), with
  /// `note` appended inside the brackets.
  std::string described(const std::string& note = "") const;
};

/// Fills the item's data identity: the canonical `path` if the source has one; else the type and
/// its `seed` if it has one; else the type with every parameter except `frames` (a count, not a
/// selection). Defaults are filled in when the plugin is installed, so `seed: 1` and an omitted
/// default seed compare equal.
void identify(Item& it, const std::string& base_dir, PluginRegistry& reg);
/// Parses one split item. `datasets` (sweeps) maps names to source entries; `base_source`
/// (train configs) is the config's source. A scalar is a dataset name (sweep) or a data folder
/// (train config); a map has keys dataset, path, params, frames.
bool parseItem(const YAML::Node& n, const std::map<std::string, YAML::Node>* datasets,
               const YAML::Node& base_source, const std::string& base_dir, Diags& d, Item& it);
/// Train and test items must not share data: same folder (or one inside the other) or same
/// parameters without a path, with intersecting frame ranges. Diagnostics at the test item; the
/// roles name the two sets in them (validation items are checked against both others).
/// With `notes`, pairs that read the same recording or world in other frames are noted there:
/// allowed, but frames of one drive share ground and objects, so such a test is not unseen data.
void checkDisjoint(const std::vector<Item*>& train, const std::vector<Item*>& test, Diags& d,
                   const std::string& test_role = "test", const std::string& train_role = "train",
                   std::vector<std::string>* notes = nullptr);
/// Instantiates and configures the item's source (unless its type is not installed); checks
/// the frame range against the source's size and applies `limit`. With `cache`, the source keeps
/// the frames it reads within that budget (CachedSource), for items read by many runs.
void prepareItem(Item& it, PluginRegistry& reg, const Frame0& f0, const std::string& out_dir,
                 std::size_t limit, Diags& d, bool tolerate_missing,
                 const std::shared_ptr<FrameBudget>& cache = nullptr);
/// Parses split.train / split.test lists, and split.validation and split.folds (both optional)
/// where `validation` and `folds` are given (sweeps; train configs have neither). A fold is a list
/// of items or one item.
void parseSplit(const YAML::Node& split, const std::map<std::string, YAML::Node>* datasets,
                const YAML::Node& base_source, const std::string& base_dir, Diags& d,
                std::vector<std::unique_ptr<Item>>& train, std::vector<std::unique_ptr<Item>>& test,
                bool need_both, std::vector<std::unique_ptr<Item>>* validation = nullptr,
                std::vector<std::vector<std::unique_ptr<Item>>>* folds = nullptr,
                bool train_optional = false);
/// Every fold item must be part of split.train (same data, its frames inside a train item's):
/// folds divide the train split, they never bring data of their own. Folds must not share data
/// with each other. Diagnostics at the fold item.
void checkFolds(const std::vector<Item*>& train,
                const std::vector<std::vector<std::unique_ptr<Item>>>& folds, Diags& d);
/// Unique labels within one list, also once made file names (sanitize): items whose labels
/// collide get their frame range (when given), then the source parameters in which they differ
/// (`name range_noise_m=0.3`, `name path=<as written>`), then their place in the list (`name #2`),
/// each only while they still collide.
void uniqueLabels(std::vector<std::unique_ptr<Item>>& items);
/// A diagnostic at each item whose label, made a file name, is another's of the list (only left
/// when a `#N` added by uniqueLabels meets a label that is written so).
void checkDistinctLabels(const std::vector<std::unique_ptr<Item>>& items,
                         const std::string& list_name, Diags& d);

/// Gives an item's configured source to a pipeline for one run and takes it back afterwards,
/// also when the run throws.
class SourceLoan {
 public:
  SourceLoan(Item& it, Pipeline& p) : it_(it), p_(p) { p_.source = std::move(it_.src); }
  ~SourceLoan() { it_.src = std::move(p_.source); }

 private:
  Item& it_;
  Pipeline& p_;
};

// ---- pipelines (sweep_pipeline.cpp) -------------------------------------------------------------

/// Assembles a Pipeline from entries (already validated against `d.file`); the source is lent by
/// the caller. Re-checks the read/write order like loadPipeline; throws ConfigError.
Pipeline assemble(PluginRegistry& reg, const Frame0& f0, Item& item,
                  const std::vector<YAML::Node>& stage_entries,
                  const std::vector<YAML::Node>& output_entries,
                  std::vector<std::unique_ptr<Output>> extra_outputs, const std::string& run_dir);
/// Runs the item's frames (after range and limit) without a progress bar of the runner's own.
/// A `timed` run (one whose stage times make the runtime tables) reads each frame when it needs
/// it, so no reader thread competes with its stages; others read ahead (RunOptions::read_ahead).
RunOptions runOptions(const Item& it, std::ostream* log, bool timed);
/// `given`, or the registry's default folders when empty.
std::vector<std::string> pluginDirs(const std::vector<std::string>& given);

// ---- training (sweep_training.cpp) --------------------------------------------------------------

struct TrainJob {
  const Frame0* f0 = nullptr;
  std::vector<YAML::Node> stages;  ///< egomotion + feature entries
  std::vector<Item*> items;
  std::vector<std::string> features;
  YAML::Node stats_params;  ///< extra feature_stats params (min_sigma, min_purity, …)
  YAML::Mark features_mark;
  bool features_from_command_line = false;  ///< `train --features`: no place in the file
  std::string model_path;
  std::string run_root;  ///< per-item run folders (resolved_config.yaml) and scratch files
  std::string origin;    ///< "config <path>" / "sweep <path>, feature set L"
  std::vector<std::string> held_out;  ///< test items, for the provenance
  std::string what;                   ///< progress prefix
};

/// Runs the job's stages over its items, learns with feature_stats and writes the model with our
/// provenance. Throws ConfigError for bad training parameters, std::runtime_error otherwise.
TrainResult runTraining(TrainJob& job, PluginRegistry& reg, Progress& progress, std::ostream& log);

// ---- sweep files (sweep_load.cpp) ---------------------------------------------------------------

struct FeatureSet {
  std::string name;
  std::vector<YAML::Node> stages;
  std::vector<std::string> features;
  YAML::Mark features_mark, mark;
  YAML::Node min_sigma;
  std::string model;        ///< given model (absolute), or "" = train
  std::string unavailable;  ///< a stage type is not installed
  int train_group = -1;     ///< index into Sweep::train_groups, -1 = split.train
  /// Energy parameters of this set's runs over the sweep's `energy.params` (`energy:` of the
  /// set, after those of the set it extends); the file's nodes, for positions in messages.
  YAML::Node energy = YAML::Node(YAML::NodeType::Map);
};

/// A YAML value on one line ("[0.02, 0.05]"), as candidates are named.
inline std::string flowText(const YAML::Node& v) {
  if (v.IsScalar()) return v.Scalar();
  YAML::Emitter e;
  e << YAML::Flow << v;
  return e.c_str();
}

/// One candidate of `select:`: parameter values that override the sweep's `training:`
/// (feature_stats) and `energy:` parameters and the parameters of feature-set stages.
struct Candidate {
  YAML::Node training = YAML::Node(YAML::NodeType::Map);
  YAML::Node energy = YAML::Node(YAML::NodeType::Map);
  /// stage name -> {param: value}: applied to the stage of that name in each feature set.
  YAML::Node stages = YAML::Node(YAML::NodeType::Map);
  /// "components=2", "beta=0.8", "rough.residual=vertical"; "" = none
  std::string training_text, energy_text, stages_text;
  /// What a trained model depends on: training and stage parameters, not the energy's
  /// ("components=2, rough.residual=vertical"; stage keys have a dot, training keys none).
  std::string modelText() const { return join(training_text, stages_text); }
  std::string text() const { return join(modelText(), energy_text); }
  Candidate() = default;
  Candidate(const Candidate&) = default;
  /// Rebinds the YAML nodes: a YAML::Node's own '=' writes into the node it shares with another
  /// candidate (copies share nodes), which would change that one too.
  Candidate& operator=(const Candidate& o) {
    training.reset(o.training);
    energy.reset(o.energy);
    stages.reset(o.stages);
    training_text = o.training_text;
    energy_text = o.energy_text;
    stages_text = o.stages_text;
    return *this;
  }

 private:
  static std::string join(const std::string& a, const std::string& b) {
    return a.empty() ? b : b.empty() ? a : a + ", " + b;
  }
};

/// `select:`: the candidates (the product of the listed values, first listed first) and how they
/// are scored on split.validation or split.folds.
struct Selection {
  std::vector<Candidate> candidates;  ///< empty = no selection
  std::string optimiser;              ///< name of one of the sweep's optimisers
  std::string score = "macro_f1";     ///< or "f1_<class>"
  /// Scores closer than this to the best are ties, which the candidate listed first wins: a
  /// difference of a few cells is noise, not a reason for a larger model.
  double tie = 0.001;
  /// Learn the chosen candidate's model again on train + validation for the test runs.
  bool refit = false;
};

struct OptimiserDef {
  std::string name;
  YAML::Node entry;
  YAML::Mark mark;  ///< where the sweep names it
  std::string unavailable;
};

struct Sweep {
  std::string file, name, output_dir;
  Frame0 f0;
  std::map<std::string, YAML::Node> datasets;
  std::vector<std::unique_ptr<Item>> train, test;
  std::vector<std::unique_ptr<Item>> validation;  ///< split.validation (scores `select:`)
  /// split.folds: `select:` by cross-validation inside split.train (instead of split.validation).
  std::vector<std::vector<std::unique_ptr<Item>>> folds;
  Selection select;
  /// Feature-set specific training items (`train:` of a feature set), overriding split.train.
  std::vector<std::vector<std::unique_ptr<Item>>> train_groups;
  std::vector<YAML::Node> common_stages;
  std::string common_unavailable;
  std::vector<FeatureSet> feature_sets;
  std::vector<OptimiserDef> optimisers;
  YAML::Node energy;
  std::string energy_unavailable;
  YAML::Node training;  ///< feature_stats params
  YAML::Mark training_mark;
  std::vector<YAML::Node> outputs;
  std::size_t roc_max_points = 500;
  /// Frames kept in memory for the runs that read them again (`frame_cache_mb`; 0 = none).
  std::shared_ptr<FrameBudget> frame_cache;
  std::string roc_fallback = "local_energy";
  std::vector<std::string> notes;
};

/// Parses and validates everything; sources of split items are configured (kept for the runs).
std::unique_ptr<Sweep> loadSweep(const std::string& path, PluginRegistry& reg,
                                 const std::string& output_dir, std::size_t limit);

// ---- running a sweep (sweep_run.cpp, sweep_select.cpp) ------------------------------------------

/// What the steps of one `terramrf compare` share while it runs.
struct SweepRun {
  Sweep& s;
  PluginRegistry& reg;
  const LabelSet& labels;
  Progress& progress;
  std::ostream& log;
  std::string sweep_path;  ///< absolute (models name it)
  std::size_t done = 0;    ///< frames processed so far (progress bar)
  /// Items whose untimed warm-up run is done (executeRun).
  std::set<const Item*> warmed = {};
  /// The signal that cut a run or training short (SweepResult::stop_signal), 0 if none did.
  int stopped = 0;
};

/// The items a feature set trains on: its own `train:`, else split.train.
const std::vector<std::unique_ptr<Item>>& trainItems(const Sweep& s, const FeatureSet& f);

/// Everything one run needs besides the sweep: which data, features, optimiser, model, energy.
struct RunSpec {
  Item* item = nullptr;
  const FeatureSet* features = nullptr;
  const OptimiserDef* optimiser = nullptr;
  std::string model;
  YAML::Node energy_params;  ///< overrides of the energy's parameters (select:), may be null
  bool with_outputs = true;  ///< the sweep's `outputs:` (test runs only)
  bool timed = true;         ///< its times make the runtime tables: frames read in place
};

/// Runs one item × feature set × optimiser and fills `rec` (status, counts, times, energies);
/// `rec.output_dir` must be set. Failures are recorded in `rec` and logged, not thrown.
void executeRun(SweepRun& run, const RunSpec& spec, RunRecord& rec);

/// Trains feature set `f` on its train items with the sweep's `training:` and `overrides` on top,
/// writes the model to `model_path` and advances the progress bar by the training frames (also
/// when it throws: ConfigError for bad parameters, std::runtime_error otherwise).
/// With `with_validation` the validation items are training data too (select: refit).
/// `fold` >= 0 trains on the other folds of split.folds only, holding that fold out.
TrainResult trainFeatureSet(SweepRun& run, const FeatureSet& f, const YAML::Node& overrides,
                            const std::string& model_path, const std::string& run_root,
                            const std::string& what, bool with_validation = false, int fold = -1);

/// The candidates of `select:` as they apply to feature set `f`: stage values only for the
/// stages `f` has, and candidates that are then alike listed once (first listed first).
std::vector<Candidate> candidatesFor(const Selection& sel, const FeatureSet& f);

/// Whether `select:` has anything to choose for `f` (not only stage values for stages it lacks).
/// Scores one candidate's validation counts by `score` ("f1_<class>", or "macro_f1" over
/// `classes`, the classes of the validation truth: truthClasses).
double selectionScore(const EvalCounts& counts, const LabelSet& labels, const std::string& score,
                      const std::vector<LabelId>& classes);
/// The classes some cell of the validation truth holds, over the candidates without a note.
std::vector<LabelId> truthClasses(const std::vector<EvalCounts>& counts,
                                  const std::vector<std::string>& notes, std::size_t labels);

inline bool selectsFor(const std::vector<Candidate>& cands) {
  return !cands.empty() && !(cands.size() == 1 && cands[0].text().empty());
}

/// `f` with the stage parameters of `stages` ({stage name: {param: value}}) set.
FeatureSet withStageParams(const FeatureSet& f, const YAML::Node& stages);

/// Distinct models among the candidates (training and stage parameters), in first-use order;
/// `of[c]` = index of candidate c's (candidates that differ only in energy parameters share a
/// model).
std::vector<const Candidate*> distinctTraining(const std::vector<Candidate>& cands,
                                               std::vector<std::size_t>& of);

/// Outcome of `select:` for one feature set.
struct Selected {
  SelectionRecord record;  ///< every candidate's validation counts and score, and the choice
  Candidate candidate;     ///< the chosen one, as it applies to the feature set
  TrainResult model;       ///< the chosen candidate's model (not set for a given `model:`)
  YAML::Node energy;       ///< the chosen candidate's energy parameters
  std::string error;       ///< why none could be chosen ("" = record.chosen >= 0)
};

/// Trains every distinct training candidate of `select:` for `f` (unless it has a given model),
/// runs every candidate on every validation item with the selection optimiser and chooses the
/// first candidate within `tie` of the best score. With split.folds, each candidate is trained
/// once per fold on the other folds and scored on that fold, the counts summed over the folds;
/// `model` is then not set (the caller learns the choice on split.train). ConfigError
/// propagates; other failures of a candidate are noted in the record.
Selected selectParameters(SweepRun& run, const FeatureSet& f);

}  // namespace terramrf::sweep_detail
