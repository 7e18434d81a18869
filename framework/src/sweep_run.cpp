// `terramrf compare`: one model per feature set, then every test item x feature set x optimiser,
// each run scored by the evaluation and ROC accumulators.
#include <cmath>
#include <filesystem>
#include <iostream>
#include <set>
#include <sstream>

#include "sweep_internal.hpp"
#include "terramrf/atomic_file.hpp"
#include "terramrf/stop_request.hpp"
#include "terramrf/sweep.hpp"

namespace terramrf {
namespace fs = std::filesystem;

namespace sweep_detail {

const std::vector<std::unique_ptr<Item>>& trainItems(const Sweep& s, const FeatureSet& f) {
  return f.train_group >= 0 ? s.train_groups[f.train_group] : s.train;
}

namespace {

/// Frames of a test item the untimed warm-up runs over (runOne).
constexpr std::size_t kWarmUpFrames = 5;

std::string trainUnavailable(const Sweep& s, const FeatureSet& f) {
  if (!f.model.empty()) return "";
  for (const auto& it : trainItems(s, f))
    if (!it->unavailable.empty()) return "train item '" + it->label + "': " + it->unavailable;
  return "";
}

/// Why a run cannot be made ("" = it can).
std::string skipReason(const Sweep& s, const Item& test, const FeatureSet& f,
                       const OptimiserDef& o) {
  if (!test.unavailable.empty()) return "dataset '" + test.label + "': " + test.unavailable;
  if (!s.common_unavailable.empty()) return "common stages: " + s.common_unavailable;
  if (!f.unavailable.empty()) return "feature set '" + f.name + "': " + f.unavailable;
  if (!s.energy_unavailable.empty()) return "energy: " + s.energy_unavailable;
  if (!o.unavailable.empty()) return "optimiser '" + o.name + "': " + o.unavailable;
  const std::string t = trainUnavailable(s, f);
  if (!t.empty()) return "no model for feature set '" + f.name + "': " + t;
  return "";
}

/// Collects evaluation, ROC samples, energies of one run; ticks the progress bar.
class RunCollector final : public Output {
 public:
  RunCollector(const LabelSet& labels, bool energy_fallback, RunRecord& rec, Progress& progress,
               std::string what)
      : evaluator_(labels),
        roc_(labels),
        energy_fallback_(energy_fallback),
        rec_(rec),
        progress_(progress),
        what_(std::move(what)) {
    setIdentity("compare_collector", "compare_collector");
  }
  std::vector<std::string> reads() const override {
    return {artefacts::kPoints, artefacts::kLabels};
  }
  void write(const FrameContext& ctx) override {
    const TerrainGrid& g = *ctx.grid;
    const Frame& fr = *ctx.frame;
    const EvalCounts frame_counts = evaluator_.addFrame(g, fr);
    if (frame_counts.scans) rec_.per_scan.emplace_back(fr.id, frame_counts);
    const RocFrameStats st = roc_.addFrame(
        g, fr, energy_fallback_ ? &ctx.energy : static_cast<const EnergyModel*>(nullptr));
    if (st.source != ScoreSource::kNone) sources_.insert(st.source);
    FrameEnergy e;
    e.frame = fr.id;
    e.initial = ctx.optimiser.initial_energy;
    e.reported = ctx.optimiser.final_energy;
    e.iterations = ctx.optimiser.iterations;
    e.converged = ctx.optimiser.converged;
    e.recomputed = recompute(ctx.energy, g.labels());
    rec_.energies.push_back(e);
    progress_.tick(what_ + " " + fr.id);
  }
  void end(const RunSummary&) override {
    rec_.counts = evaluator_.total();
    rec_.roc = roc_.curves(max_points_);
    if (sources_.count(ScoreSource::kScoreLayers))
      rec_.score_source = ScoreSource::kScoreLayers;
    else if (sources_.count(ScoreSource::kLocalEnergy))
      rec_.score_source = ScoreSource::kLocalEnergy;
    std::ostringstream note;
    if (rec_.counts.scans == 0) {
      note << "no frame with per-point ground truth: nothing to score";
    } else if (sources_.empty()) {
      note << "no ROC: the optimiser wrote no score layers"
           << (energy_fallback_ ? " and there was no energy model" : " (roc.fallback: skip)");
    } else {
      if (roc_.frames_with_layers)
        note << roc_.frames_with_layers << " frame(s) scored from score layers";
      if (roc_.frames_with_energy_fallback)
        note << (roc_.frames_with_layers ? "; " : "") << roc_.frames_with_energy_fallback
             << " frame(s) from the local energy margin (the optimiser wrote no score layers)";
      if (roc_.frames_without_scores)
        note << "; " << roc_.frames_without_scores << " frame(s) without scores";
      if (roc_.cells_without_score)
        note << "; " << roc_.cells_without_score << " of " << roc_.cells_scored
             << " scored cells had no score";
    }
    rec_.roc_note = note.str();
  }
  void setMaxPoints(std::size_t n) { max_points_ = n; }

 private:
  static double recompute(const EnergyModel& em, const std::vector<LabelId>& labels) {
    if (em.empty() || em.cells() != labels.size()) return kNaN;
    std::vector<int> index_of(256, -1);
    for (int k = 0; k < em.numLabels(); ++k) index_of[em.active[k]] = k;
    std::vector<uint8_t> lab(em.cells(), 0);
    for (std::size_t i = 0; i < em.cells(); ++i) {
      if (em.fixed[i]) continue;
      const int k = index_of[labels[i]];
      if (k < 0) return kNaN;  // a label the model cannot express
      lab[i] = static_cast<uint8_t>(k);
    }
    return em.energy(lab);
  }

  Evaluator evaluator_;
  RocAccumulator roc_;
  bool energy_fallback_;
  RunRecord& rec_;
  Progress& progress_;
  std::string what_;
  std::set<ScoreSource> sources_;
  std::size_t max_points_ = 500;
};

RunTimes runTimes(const RunResult& r, const Pipeline& p) {
  std::set<std::string> mrf, feature;
  for (std::size_t i = 0; i < p.stages.size(); ++i) {
    const PluginKind k = p.stage_kinds[i];
    (k == PluginKind::kEnergy || k == PluginKind::kOptimiser ? mrf : feature)
        .insert(p.stages[i]->name());
  }
  RunTimes t;
  std::size_t n = 0;
  for (const auto& s : r.timings) n = std::max(n, s.ms.size());
  t.processing.assign(n, 0);
  t.features.assign(n, 0);
  t.mrf.assign(n, 0);
  t.total.assign(n, 0);
  for (const auto& s : r.timings) {
    if (s.ms.size() != n) continue;
    const bool is_total = s.name == "total";
    const bool is_io = s.name == "read" || s.name == "read wait" || s.name.rfind("output:", 0) == 0;
    for (std::size_t f = 0; f < n; ++f) {
      if (is_total) {
        t.total[f] = s.ms[f];
        continue;
      }
      if (is_io) continue;
      t.processing[f] += s.ms[f];
      if (mrf.count(s.name))
        t.mrf[f] += s.ms[f];
      else
        t.features[f] += s.ms[f];  // grid + egomotion + features
    }
  }
  return t;
}

}  // namespace
}  // namespace sweep_detail

using sweep_detail::assemble;
using sweep_detail::FeatureSet;
using sweep_detail::Item;
using sweep_detail::kNaN;
using sweep_detail::loadSweep;
using sweep_detail::pluginDirs;
using sweep_detail::Progress;
using sweep_detail::RunCollector;
using sweep_detail::runOptions;
using sweep_detail::runTimes;
using sweep_detail::runTraining;
using sweep_detail::sanitize;
using sweep_detail::skipReason;
using sweep_detail::SourceLoan;
using sweep_detail::trainItems;
using sweep_detail::TrainJob;
using sweep_detail::trainUnavailable;

SweepPlan planSweep(const std::string& sweep_path, const std::vector<std::string>& plugin_dirs) {
  PluginRegistry reg(pluginDirs(plugin_dirs));
  auto s = loadSweep(sweep_path, reg, "", 0);
  SweepPlan plan;
  plan.name = s->name;
  plan.notes = s->notes;
  for (const auto& t : s->test)
    for (const auto& f : s->feature_sets)
      for (const auto& o : s->optimisers) {
        const std::string run = t->label + " × " + f.name + " × " + o.name;
        const std::string why = skipReason(*s, *t, f, o);
        if (why.empty())
          plan.runs.push_back(run);
        else
          plan.skipped.push_back({run, why});
      }
  for (const auto& f : s->feature_sets) {
    const std::vector<sweep_detail::Candidate> cands = sweep_detail::candidatesFor(s->select, f);
    if (!sweep_detail::selectsFor(cands)) continue;
    for (const auto& c : cands) {
      for (const auto& v : s->validation)
        plan.selection_runs.push_back(f.name + ": " + v->label + " × " + s->select.optimiser +
                                      " [" + c.text() + "]");
      for (std::size_t k = 0; k < s->folds.size(); ++k)
        for (const auto& v : s->folds[k])
          plan.selection_runs.push_back(f.name + ": fold " + std::to_string(k + 1) + " " +
                                        v->described() + " × " + s->select.optimiser + " [" +
                                        c.text() + "] (trained on the other folds)");
    }
  }
  return plan;
}

const RunRecord* SweepResult::find(const std::string& dataset, const std::string& feature_set,
                                   const std::string& optimiser) const {
  for (const auto& r : runs)
    if (r.dataset == dataset && r.feature_set == feature_set && r.optimiser == optimiser) return &r;
  return nullptr;
}

int SweepResult::exitCode() const {
  if (stop_signal != 0) return 128 + stop_signal;
  for (const auto& r : runs)
    if (r.status == RunRecord::Status::kFailed || !r.failed.empty()) return 3;
  for (const auto& m : models)
    if (!m.failed.empty()) return 3;
  return 0;
}

namespace sweep_detail {

void executeRun(SweepRun& run, const RunSpec& spec, RunRecord& rec) {
  Sweep& s = run.s;
  Item& t = *spec.item;
  const FeatureSet& f = *spec.features;
  const std::string what = rec.dataset + " × " + f.name + " × " + rec.optimiser + ":";
  try {
    std::vector<YAML::Node> stages = s.common_stages;
    stages.insert(stages.end(), f.stages.begin(), f.stages.end());
    // Over the sweep's own nodes, so errors keep their place in the sweep.
    YAML::Node energy = detail::copyEntryKeepingPositions(s.energy);
    YAML::Node params = energy["params"];
    // The set's own energy parameters, then the candidate's of `select:` (never the same key).
    for (const YAML::Node& over : {f.energy, spec.energy_params})
      if (over && over.IsMap())
        for (auto it = over.begin(); it != over.end(); ++it) {
          params.remove(it->first.Scalar());
          params[it->first.Scalar()] = it->second;
        }
    params.remove("model");
    params["model"] = spec.model;
    YAML::Node features(YAML::NodeType::Sequence);
    for (const auto& feat : f.features) features.push_back(feat);
    params.remove("features");
    params["features"] = features;
    stages.push_back(energy);
    stages.push_back(spec.optimiser->entry);
    std::vector<std::unique_ptr<Output>> extra;
    auto collector = std::make_unique<RunCollector>(run.labels, s.roc_fallback == "local_energy",
                                                    rec, run.progress, what);
    collector->setMaxPoints(s.roc_max_points);
    extra.push_back(std::move(collector));
    Pipeline p = assemble(run.reg, s.f0, t, stages,
                          spec.with_outputs ? s.outputs : std::vector<YAML::Node>{},
                          std::move(extra), rec.output_dir);
    // The first run over an item is slower than the ones after it, by 1.5–2× in its feature
    // stages on the simulator (memory the process touches for the first time, frames read from
    // file in place), so the sweep's first optimiser looked slowest. Every timed run should
    // see the same state: an untimed run of the same stages over the item's first frames goes
    // first. A few frames touch what the stages touch; all of them made a long item's sweep run
    // it once more (+100 % with one optimiser).
    if (spec.timed && run.warmed.insert(&t).second) {
      Pipeline warm = assemble(run.reg, s.f0, t, stages, {}, {}, rec.output_dir);
      SourceLoan loan(t, warm);
      RunOptions wo = runOptions(t, nullptr, true);
      wo.limit = wo.limit ? std::min(wo.limit, kWarmUpFrames) : kWarmUpFrames;
      runPipeline(warm, wo);
    }
    RunResult rr;
    {
      SourceLoan loan(t, p);
      rr = runPipeline(p, runOptions(t, &run.log, spec.timed));
    }
    rec.frames_ok = rr.summary.frames_ok;
    rec.failed = rr.summary.failed;
    if (rr.summary.stop_signal != 0) {
      // Scores of part of the item would pass for the whole in the tables: a failed run.
      run.stopped = rr.summary.stop_signal;
      rec.status = RunRecord::Status::kFailed;
      rec.reason = "run " + interruptionText(rr.summary) + "; its files cover those only";
    }
    rec.counts.frames_failed = rec.failed.size();
    rec.times = runTimes(rr, p);
    writeRunReports(rec.output_dir, rr);
    if (rr.frames_total > 0 && rr.summary.frames_ok == 0) {
      rec.status = RunRecord::Status::kFailed;
      rec.reason = "every frame failed";
      if (!rr.summary.failed.empty()) rec.reason += " (first: " + rr.summary.failed[0].second + ")";
    }
    for (const auto& e : rr.output_errors) {
      rec.status = RunRecord::Status::kFailed;
      rec.reason += (rec.reason.empty() ? "" : "; ") + e;
    }
    if (!rec.failed.empty()) {
      run.progress.breakLine();
      run.log << what << " " << rec.failed.size() << " frame(s) failed and were skipped\n";
    }
  } catch (const std::exception& e) {
    rec.status = RunRecord::Status::kFailed;
    rec.reason = e.what();
  }
  if (rec.status == RunRecord::Status::kFailed) {
    run.progress.breakLine();
    run.log << what << " failed: " << rec.reason << "\n";
  }
}

TrainResult trainFeatureSet(SweepRun& run, const FeatureSet& f, const YAML::Node& overrides,
                            const std::string& model_path, const std::string& run_root,
                            const std::string& what, bool with_validation, int fold) {
  const Sweep& s = run.s;
  TrainJob job;
  job.f0 = &s.f0;
  job.stages = s.common_stages;
  job.stages.insert(job.stages.end(), f.stages.begin(), f.stages.end());
  if (fold < 0) {
    for (auto& t : trainItems(s, f)) job.items.push_back(t.get());
  } else {
    for (std::size_t k = 0; k < s.folds.size(); ++k)
      for (auto& t : s.folds[k]) {
        if (static_cast<int>(k) != fold)
          job.items.push_back(t.get());
        else
          job.held_out.push_back(t->described("validation fold " + std::to_string(k + 1)));
      }
  }
  if (with_validation)
    for (auto& t : s.validation) job.items.push_back(t.get());
  job.features = f.features;
  job.features_mark = f.features_mark;
  job.stats_params = s.training ? YAML::Clone(s.training) : YAML::Node(YAML::NodeType::Map);
  if (f.min_sigma) job.stats_params["min_sigma"] = f.min_sigma;
  if (overrides)
    for (auto it = overrides.begin(); it != overrides.end(); ++it)
      job.stats_params[it->first.Scalar()] = YAML::Clone(it->second);
  job.model_path = model_path;
  job.run_root = run_root;
  job.origin = "sweep " + run.sweep_path + ", feature set " + f.name;
  for (const auto& t : s.test) job.held_out.push_back(t->described());
  if (!with_validation)
    for (const auto& t : s.validation) job.held_out.push_back(t->described("validation"));
  job.what = what;
  auto advance = [&] {
    for (const Item* t : job.items) run.done += t->count;
    run.progress.advanceTo(run.done, "trained " + f.name);
  };
  try {
    TrainResult r = runTraining(job, run.reg, run.progress, run.log);
    if (!r.missing.empty()) {
      run.progress.breakLine();
      run.log << "note: feature set " << f.name << ": no statistics for";
      for (const auto& m : r.missing) run.log << " " << m;
      run.log << " (fewer than two training cells)\n";
    }
    advance();
    return r;
  } catch (...) {
    advance();
    throw;
  }
}

}  // namespace sweep_detail

using sweep_detail::Candidate;
using sweep_detail::distinctTraining;
using sweep_detail::executeRun;
using sweep_detail::RunSpec;
using sweep_detail::selectParameters;
using sweep_detail::SweepRun;
using sweep_detail::trainFeatureSet;

SweepResult runSweep(const CompareOptions& o) {
  std::ostream& log = o.log ? *o.log : std::cerr;
  // A bad SOURCE_DATE_EPOCH is refused now, not when the report is written after every run.
  (void)sweep_detail::creationTime();
  PluginRegistry reg(pluginDirs(o.plugin_dirs));
  auto s = loadSweep(o.sweep_path, reg, o.output_dir, o.limit);
  for (const auto& n : s->notes) log << "note: " << n << "\n";
  SweepResult res;
  res.name = s->name;
  res.sweep_path = fs::absolute(o.sweep_path).lexically_normal().string();
  res.output_dir = s->output_dir;
  res.labels = *s->f0.labels;
  res.limit = o.limit;
  for (const auto& t : s->test) res.datasets.push_back(t->label);
  for (const auto& f : s->feature_sets) res.feature_sets.push_back(f.name);
  for (const auto& op : s->optimisers) res.optimisers.push_back(op.name);
  for (const auto& t : s->train) res.train_items.push_back(t->described());
  for (const auto& t : s->validation) res.validation_items.push_back(t->described());
  for (std::size_t k = 0; k < s->folds.size(); ++k)
    for (const auto& t : s->folds[k])
      res.validation_items.push_back("fold " + std::to_string(k + 1) + ": " + t->described());
  res.folds = s->folds.size();
  fs::create_directories(s->output_dir);
  writeFileAtomic(s->output_dir + "/sweep.yaml", readFile(o.sweep_path));

  const sweep_detail::Selection& sel = s->select;
  const bool selecting = !sel.candidates.empty();
  // Frames each candidate is validated on, and (folds) trained on besides split.train: every
  // fold is held out once and trains the others.
  std::size_t validation_frames = 0, fold_training_frames = 0;
  for (const auto& v : s->validation) validation_frames += v->count;
  for (const auto& fold : s->folds)
    for (const auto& v : fold) validation_frames += v->count;
  if (!s->folds.empty()) fold_training_frames = validation_frames * (s->folds.size() - 1);
  const bool folds = !s->folds.empty();

  // Progress total: training frames of every feature set that trains (once per distinct training
  // candidate), validation frames of every candidate, test frames of every run.
  Progress progress(o.progress);
  std::size_t total = 0;
  std::vector<std::string> fs_train_reason(s->feature_sets.size());
  for (std::size_t i = 0; i < s->feature_sets.size(); ++i) {
    const auto& f = s->feature_sets[i];
    std::string why = trainUnavailable(*s, f);
    if (why.empty() && !f.unavailable.empty()) why = f.unavailable;
    if (why.empty() && !s->common_unavailable.empty()) why = s->common_unavailable;
    if (why.empty() && !s->energy_unavailable.empty() && selecting) why = s->energy_unavailable;
    fs_train_reason[i] = why;
    if (!why.empty()) continue;
    std::size_t train_frames = 0;
    for (const auto& t : trainItems(*s, f)) train_frames += t->count;
    // Candidates as they apply to this set (stage values only for its stages), and the models
    // among them.
    const std::vector<sweep_detail::Candidate> cands = sweep_detail::candidatesFor(sel, f);
    const bool selects = sweep_detail::selectsFor(cands);
    std::vector<std::size_t> training_of;
    const std::size_t trainings = distinctTraining(cands, training_of).size();
    if (f.model.empty())
      total += selects && !folds ? train_frames * trainings
                                 : train_frames + (selects ? fold_training_frames * trainings : 0);
    if (selects) total += validation_frames * cands.size();
    if (selects && sel.refit && f.model.empty()) total += train_frames + validation_frames;
  }
  for (const auto& t : s->test)
    for (const auto& f : s->feature_sets)
      for (const auto& op : s->optimisers)
        if (skipReason(*s, *t, f, op).empty()) total += t->count;
  progress.setTotal(total);
  SweepRun run{*s, reg, res.labels, progress, log, res.sweep_path};

  // 1. One model per feature set; with select: the candidate best on validation.
  std::vector<std::string> model_of(s->feature_sets.size());
  std::vector<YAML::Node> energy_of(s->feature_sets.size());
  // The feature sets as the test runs use them: with the chosen stage parameters of select:.
  std::vector<sweep_detail::FeatureSet> used = s->feature_sets;
  std::vector<bool> train_failed(s->feature_sets.size(), false);
  for (std::size_t i = 0; i < s->feature_sets.size(); ++i) {
    const FeatureSet& f = s->feature_sets[i];
    ModelRecord mr;
    mr.feature_set = f.name;
    for (const auto& t : trainItems(*s, f)) mr.train_items.push_back(t->described());
    const std::string model_path = s->output_dir + "/models/" + sanitize(f.name) + ".yaml";
    auto record = [&](const TrainResult& tr) {
      mr.trained = true;
      mr.frames = tr.frames;
      mr.labelled_frames = tr.labelled_frames;
      mr.missing = tr.missing;
      mr.failed = tr.failed;
    };
    auto fail = [&](const std::string& why) {
      if (const int sig = stopRequested()) run.stopped = sig;  // why says "interrupted"
      mr.reason = why;
      mr.path.clear();
      train_failed[i] = true;
      progress.breakLine();
      log << "feature set " << f.name << ": " << why << "\n";
    };
    if (!f.model.empty()) {
      mr.path = f.model;
      mr.reason = "given in the sweep";
      mr.train_items.clear();
    } else if (!fs_train_reason[i].empty()) {
      mr.reason = "not trained: " + fs_train_reason[i];
    }
    if (const int sig = stopRequested(); sig != 0 && mr.path.empty()) {
      run.stopped = sig;
      mr.reason = "not trained: compare interrupted (" + signalName(sig) + ")";
      train_failed[i] = true;
      model_of[i].clear();
      res.models.push_back(mr);
      continue;
    }
    if (selecting && fs_train_reason[i].empty() &&
        sweep_detail::selectsFor(sweep_detail::candidatesFor(sel, f))) {
      sweep_detail::Selected chosen = selectParameters(run, f);
      if (!chosen.error.empty()) {
        fail(chosen.error);
      } else {
        energy_of[i] = chosen.energy;
        // swap, not '=': assigning YAML::Nodes would write into the sweep's own stage nodes.
        FeatureSet chosen_set = sweep_detail::withStageParams(f, chosen.candidate.stages);
        used[i].stages.swap(chosen_set.stages);
        mr.selected = chosen.record.candidates[chosen.record.chosen];
        if (f.model.empty() && (sel.refit || folds)) {
          // The winner's parameters, learnt again with the validation data (refit), or on the
          // whole train split after cross-validation on its folds.
          try {
            const TrainResult tr = trainFeatureSet(
                run, used[i], chosen.candidate.training, model_path,
                s->output_dir + "/models/" + sanitize(f.name) + ".train",
                (folds ? "train " : "refit ") + f.name + " [" + mr.selected + "]: ", sel.refit);
            mr.path = tr.model_path;
            record(tr);
            if (sel.refit) {
              for (const auto& t : s->validation)
                mr.train_items.push_back(t->described("validation"));
              mr.selected += " (refit on train + validation)";
            } else {
              mr.selected += " (" + std::to_string(s->folds.size()) + "-fold cross-validation)";
            }
          } catch (const ConfigError&) {
            throw;
          } catch (const std::exception& e) {
            fail(std::string("refit failed: ") + e.what());
          }
        } else if (f.model.empty()) {
          // The winner's model under the feature set's usual name.
          fs::create_directories(s->output_dir + "/models");
          writeFileAtomic(model_path, readFile(chosen.model.model_path));
          mr.path = model_path;
          record(chosen.model);
        }
      }
      res.selections.push_back(std::move(chosen.record));
    } else if (mr.reason.empty()) {
      try {
        const TrainResult tr = trainFeatureSet(
            run, f, YAML::Node(), model_path,
            s->output_dir + "/models/" + sanitize(f.name) + ".train", "train " + f.name + ": ");
        mr.path = tr.model_path;
        record(tr);
      } catch (const ConfigError&) {
        throw;
      } catch (const std::exception& e) {
        fail(std::string("training failed: ") + e.what());
      }
    }
    model_of[i] = mr.path;
    res.models.push_back(mr);
  }

  // 2. Every test item × feature set × optimiser.
  for (auto& tptr : s->test) {
    Item& t = *tptr;
    for (std::size_t fi = 0; fi < s->feature_sets.size(); ++fi) {
      const FeatureSet& f = s->feature_sets[fi];
      for (const auto& op : s->optimisers) {
        RunRecord rec;
        rec.dataset = t.label;
        rec.feature_set = f.name;
        rec.optimiser = op.name;
        rec.frames = t.count;
        rec.counts = EvalCounts(res.labels.size());
        rec.reason = skipReason(*s, t, f, op);
        if (!rec.reason.empty()) {
          rec.status = RunRecord::Status::kSkipped;
          res.runs.push_back(std::move(rec));
          continue;
        }
        if (model_of[fi].empty()) {
          rec.status = train_failed[fi] ? RunRecord::Status::kFailed : RunRecord::Status::kSkipped;
          rec.reason = "no model for feature set '" + f.name + "': " + res.models[fi].reason;
          res.runs.push_back(std::move(rec));
          continue;
        }
        if (const int sig = stopRequested()) {
          run.stopped = sig;
          rec.status = RunRecord::Status::kSkipped;
          rec.reason = "not run: compare interrupted (" + signalName(sig) + ")";
          res.runs.push_back(std::move(rec));
          continue;
        }
        rec.output_dir = s->output_dir + "/runs/" + sanitize(rec.key());
        RunSpec spec;
        spec.item = &t;
        spec.features = &used[fi];
        spec.optimiser = &op;
        spec.model = model_of[fi];
        spec.energy_params = energy_of[fi];
        executeRun(run, spec, rec);
        run.done += t.count;
        progress.advanceTo(run.done, rec.dataset + " × " + f.name + " × " + op.name + ": done");
        res.runs.push_back(std::move(rec));
      }
    }
  }
  progress.finish();
  std::vector<const std::vector<std::unique_ptr<Item>>*> lists = {&s->train, &s->validation,
                                                                  &s->test};
  for (const auto& g : s->train_groups) lists.push_back(&g);
  for (const auto* l : lists)
    for (const auto& it : *l)
      if (const auto* c = dynamic_cast<const sweep_detail::CachedSource*>(it->src.get())) {
        res.cached_frames += c->kept();
        res.cache_hits += c->hits();
        res.cached_mb += c->keptBytes() / 1048576.0;
      }
  res.stop_signal = run.stopped;
  writeSweepReport(res, s->output_dir);
  return res;
}

}  // namespace terramrf
