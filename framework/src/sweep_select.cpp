// `select:` of `terramrf compare`: every candidate (training and energy parameters) trained on the
// train split and scored on the validation split — or cross-validated on split.folds: trained on
// all folds but one, scored on that one, for each fold; the test split is not read here.
#include <cmath>

#include "sweep_internal.hpp"

namespace terramrf::sweep_detail {
namespace {

/// The validation counts of one candidate summed over `items` (added to `sum`), or why there
/// are none.
std::string validate(SweepRun& run, const FeatureSet& f, const Candidate& cand,
                     const std::string& model, const std::string& run_dir,
                     const std::vector<std::unique_ptr<Item>>& items, EvalCounts& sum) {
  const Sweep& s = run.s;
  const OptimiserDef* opt = nullptr;
  for (const auto& op : s.optimisers)
    if (op.name == s.select.optimiser) opt = &op;
  std::string note;
  for (const auto& v : items) {
    if (note.empty()) {
      RunRecord rec;
      rec.dataset = v->label;
      rec.feature_set = f.name;
      rec.optimiser = s.select.optimiser + " [" + cand.text() + "]";
      rec.frames = v->count;
      rec.counts = EvalCounts(run.labels.size());
      rec.output_dir = run_dir + "__" + sanitize(v->label);
      if (!v->unavailable.empty()) {
        note = "validation item '" + v->label + "': " + v->unavailable;
      } else {
        RunSpec spec;
        spec.item = v.get();
        spec.features = &f;
        spec.optimiser = opt;
        spec.model = model;
        spec.energy_params = cand.energy;
        spec.with_outputs = false;
        spec.timed = false;
        executeRun(run, spec, rec);
        if (rec.status == RunRecord::Status::kFailed)
          note = "validation run on '" + v->label + "' failed: " + rec.reason;
        else if (!rec.failed.empty())
          note = std::to_string(rec.failed.size()) + " validation frame(s) of '" + v->label +
                 "' failed";
        else
          sum += rec.counts;
      }
    }
    run.done += v->count;
    run.progress.advanceTo(run.done, "validated " + f.name);
  }
  return note;
}

}  // namespace

/// Scores `counts` by `score`: cell-wise F1 of one class ("f1_<class>") or averaged over
/// `classes` ("macro_f1"), the classes of the validation truth, the same for every candidate:
/// averaged over what each candidate happened to predict, one stray cell of a class the data
/// lacks (F1 0) outweighed being better on every class it has.
double selectionScore(const EvalCounts& counts, const LabelSet& labels, const std::string& score,
                      const std::vector<LabelId>& classes) {
  auto f1 = [&](LabelId c) { return counts.cell_wise.scores(c).f1(); };
  if (score.rfind("f1_", 0) == 0) {
    const int c = labels.find(score.substr(3));
    return c > 0 ? f1(static_cast<LabelId>(c)) : kNaN;
  }
  double sum = 0;
  int n = 0;
  for (LabelId c : classes) {
    const double v = f1(c);
    if (std::isnan(v)) continue;  // only if the tie rule gave this candidate no such cell
    sum += v;
    ++n;
  }
  return n ? sum / n : kNaN;
}

/// The classes some cell of the validation truth holds, over every candidate scored (the truth
/// is the candidates' own but for the tie rule, which follows the prediction).
std::vector<LabelId> truthClasses(const std::vector<EvalCounts>& counts,
                                  const std::vector<std::string>& notes, std::size_t labels) {
  std::vector<LabelId> out;
  for (std::size_t c = 1; c < labels; ++c)
    for (std::size_t k = 0; k < counts.size(); ++k) {
      const ClassScores s = counts[k].cell_wise.scores(static_cast<LabelId>(c));
      if (notes[k].empty() && s.tp + s.fn > 0) {
        out.push_back(static_cast<LabelId>(c));
        break;
      }
    }
  return out;
}

std::vector<Candidate> candidatesFor(const Selection& sel, const FeatureSet& f) {
  // A given model was learnt with its stages as they are, and nothing trains it: only its energy
  // is selected (training candidates would be identical runs reported as "trained").
  const bool given = !f.model.empty();
  auto has = [&](const std::string& stage) {
    if (!f.model.empty()) return false;
    for (const YAML::Node& e : f.stages)
      if (e["name"] && e["name"].Scalar() == stage) return true;
    return false;
  };
  std::vector<Candidate> out;
  for (const Candidate& c : sel.candidates) {
    Candidate k = c;
    if (given) {
      k.training.reset(YAML::Node(YAML::NodeType::Map));
      k.training_text.clear();
    }
    // reset(), not '=': assigning a YAML::Node writes into the node it shares with `c`.
    k.stages.reset(YAML::Node(YAML::NodeType::Map));
    k.stages_text.clear();
    for (auto st = c.stages.begin(); st != c.stages.end(); ++st) {
      const std::string stage = st->first.Scalar();
      if (!has(stage)) continue;
      for (auto p = st->second.begin(); p != st->second.end(); ++p) {
        k.stages[stage][p->first.Scalar()] = YAML::Clone(p->second);
        k.stages_text += (k.stages_text.empty() ? "" : ", ") + stage + "." + p->first.Scalar() +
                         "=" + flowText(p->second);
      }
    }
    // A candidate whose stage values all missed this set's stages is another one again; values
    // listed twice by the sweep itself stay (the sweep asked for them).
    bool seen = false;
    if (k.stages_text != c.stages_text || k.training_text != c.training_text)
      for (const Candidate& o : out) seen = seen || o.text() == k.text();
    if (!seen) out.push_back(std::move(k));
  }
  return out;
}

FeatureSet withStageParams(const FeatureSet& f, const YAML::Node& stages) {
  FeatureSet out = f;
  if (!stages || stages.size() == 0) return out;
  for (YAML::Node& e : out.stages) {
    if (!e["name"] || !stages[e["name"].Scalar()]) continue;
    const YAML::Node set = stages[e["name"].Scalar()];
    YAML::Node copy = detail::copyMapKeepingPositions(e);  // f's own node stays as it is
    YAML::Node params(YAML::NodeType::Map);
    if (e["params"] && e["params"].IsMap()) params = detail::copyMapKeepingPositions(e["params"]);
    for (auto p = set.begin(); p != set.end(); ++p)
      params[p->first.Scalar()] = YAML::Clone(p->second);
    copy["params"] = params;
    e.reset(copy);
  }
  return out;
}

std::vector<const Candidate*> distinctTraining(const std::vector<Candidate>& cands,
                                               std::vector<std::size_t>& of) {
  std::vector<const Candidate*> distinct;
  of.assign(cands.size(), 0);
  for (std::size_t c = 0; c < cands.size(); ++c) {
    std::size_t k = 0;
    while (k < distinct.size() && distinct[k]->modelText() != cands[c].modelText()) ++k;
    if (k == distinct.size()) distinct.push_back(&cands[c]);
    of[c] = k;
  }
  return distinct;
}

Selected selectParameters(SweepRun& run, const FeatureSet& f) {
  const Sweep& s = run.s;
  const Selection& sel = s.select;
  Selected out;
  SelectionRecord& sr = out.record;
  sr.feature_set = f.name;
  sr.optimiser = sel.optimiser;
  sr.score = sel.score;
  sr.tie = sel.tie;
  sr.refit = sel.refit;
  sr.folds = s.folds.size();
  const std::string dir = s.output_dir + "/select/" + sanitize(f.name);
  const std::vector<Candidate> cands = candidatesFor(sel, f);
  std::vector<std::size_t> training_of;
  const std::vector<const Candidate*> trainings = distinctTraining(cands, training_of);
  // One validation set (split.validation), or one per fold, each scored with models trained on
  // the other folds.
  const bool folds = !s.folds.empty();
  std::vector<const std::vector<std::unique_ptr<Item>>*> parts;
  if (folds)
    for (const auto& fold : s.folds) parts.push_back(&fold);
  else
    parts.push_back(&s.validation);
  // trained[k][p]: training candidate k for part p.
  std::vector<std::vector<TrainResult>> trained(trainings.size(),
                                                std::vector<TrainResult>(parts.size()));
  std::vector<std::string> train_error(trainings.size());
  if (f.model.empty()) {
    for (std::size_t k = 0; k < trainings.size(); ++k)
      for (std::size_t p = 0; p < parts.size() && train_error[k].empty(); ++p) {
        const std::string tag =
            std::to_string(k + 1) + (folds ? "_fold" + std::to_string(p + 1) : "");
        const std::string what = "train " + f.name + " [" + trainings[k]->modelText() + "]" +
                                 (folds ? " without fold " + std::to_string(p + 1) : "") + ": ";
        try {
          trained[k][p] =
              trainFeatureSet(run, withStageParams(f, trainings[k]->stages), trainings[k]->training,
                              dir + "/model_" + tag + ".yaml", dir + "/model_" + tag + ".train",
                              what, false, folds ? static_cast<int>(p) : -1);
        } catch (const ConfigError&) {
          throw;
        } catch (const std::exception& e) {
          train_error[k] = std::string("training") +
                           (folds ? " without fold " + std::to_string(p + 1) : "") +
                           " failed: " + e.what();
          run.progress.breakLine();
          run.log << "feature set " << f.name << " [" << trainings[k]->modelText()
                  << "]: " << train_error[k] << "\n";
        }
      }
  }
  for (std::size_t c = 0; c < cands.size(); ++c) {
    const Candidate& cand = cands[c];
    const FeatureSet fc = withStageParams(f, cand.stages);
    const std::size_t k = training_of[c];
    sr.candidates.push_back(cand.text());
    std::string models;
    EvalCounts sum(run.labels.size());
    std::string note = f.model.empty() ? train_error[k] : "";
    for (std::size_t p = 0; p < parts.size(); ++p) {
      const std::string model = f.model.empty() ? trained[k][p].model_path : f.model;
      if (p == 0 || f.model.empty()) models += (p ? "; " : "") + model;
      if (note.empty()) {
        note = validate(
            run, fc, cand, model,
            dir + "/runs/" + std::to_string(c + 1) + (folds ? "_fold" + std::to_string(p + 1) : ""),
            *parts[p], sum);
        if (!note.empty() && folds) note = "fold " + std::to_string(p + 1) + ": " + note;
      } else {
        for (const auto& v : *parts[p]) run.done += v->count;  // not run: counted as done
        run.progress.advanceTo(run.done, "validated " + f.name);
      }
    }
    if (note.empty() && sum.scans == 0) note = "no validation frame with ground truth";
    sr.models.push_back(models);
    sr.counts.push_back(sum);
    sr.notes.push_back(note);
  }
  const std::vector<LabelId> classes = truthClasses(sr.counts, sr.notes, run.labels.size());
  for (std::size_t c = 0; c < cands.size(); ++c)
    sr.scores.push_back(
        sr.notes[c].empty() ? selectionScore(sr.counts[c], run.labels, sel.score, classes) : kNaN);
  // The first candidate within `tie` of the best score: a few cells are noise, not a reason for
  // a larger model.
  double best = -INFINITY;
  for (double v : sr.scores)
    if (!std::isnan(v)) best = std::max(best, v);
  for (std::size_t c = 0; c < sr.scores.size() && sr.chosen < 0; ++c)
    if (!std::isnan(sr.scores[c]) && sr.scores[c] >= best - sel.tie)
      sr.chosen = static_cast<int>(c);
  if (sr.chosen < 0) {
    out.error = "select: no candidate could be scored on the validation split";
    for (const auto& n : sr.notes)
      if (!n.empty()) {
        out.error += " (first: " + n + ")";
        break;
      }
    return out;
  }
  out.candidate = cands[sr.chosen];
  out.energy = cands[sr.chosen].energy;
  if (f.model.empty() && !folds) out.model = trained[training_of[sr.chosen]][0];
  return out;
}

}  // namespace terramrf::sweep_detail
