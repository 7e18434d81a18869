// The reports of a sweep: summary.md and its tables, CSV and JSON files, ROC plots.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <map>
#include <sstream>
#include <stdexcept>

#include "sweep_internal.hpp"
#include "terramrf/atomic_file.hpp"
#include "terramrf/stop_request.hpp"
#include "terramrf/sweep.hpp"
#include "terramrf/text_format.hpp"
#include "terramrf/version.hpp"

namespace terramrf {
namespace fs = std::filesystem;

namespace sweep_detail {

std::string sanitize(const std::string& s) {
  std::string o;
  for (char ch : s)
    o += (std::isalnum(static_cast<unsigned char>(ch)) || ch == '+' || ch == '-' || ch == '.' ||
          ch == '_')
             ? ch
             : '_';
  return o.empty() ? "_" : o;
}

std::string creationTime() {
  // reproducible-builds.org's SOURCE_DATE_EPOCH: with it, files written twice from the same
  // data are the same bytes (the models' trained_from.date, results.json's and summary.md's
  // "created"); without it, the current time.
  std::time_t t = std::time(nullptr);
  if (const char* env = std::getenv("SOURCE_DATE_EPOCH"); env && *env) {
    const std::string v = env;
    const bool digits = v.size() <= 12 && std::all_of(v.begin(), v.end(), [](unsigned char c) {
                          return std::isdigit(c) != 0;
                        });
    if (!digits)
      throw std::runtime_error(
          "environment variable SOURCE_DATE_EPOCH: '" + v +
          "' is not a time; expected whole seconds since 1970-01-01 00:00:00 UTC (as "
          "'date +%s' prints them, at most 12 digits), or the variable unset for the current "
          "time");
    t = static_cast<std::time_t>(std::stoll(v));
  }
  std::tm tm{};
  gmtime_r(&t, &tm);
  char b[32];
  std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return b;
}

}  // namespace sweep_detail

namespace sweep_detail {
namespace {

std::string fmt(const char* f, double v) {
  if (std::isnan(v)) return "–";
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

std::string csvNum(double v) {
  if (!std::isfinite(v)) return "";
  char b[48];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

std::string jsonNum(double v) {
  if (!std::isfinite(v)) return "null";
  char b[48];
  std::snprintf(b, sizeof b, "%.9g", v);
  return b;
}



std::string capitalise(std::string s) {
  if (!s.empty()) s[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(s[0])));
  return s;
}

struct Stats {
  double mean = kNaN, stddev = kNaN, min = kNaN, max = kNaN, median = kNaN;
  std::size_t n = 0;
};

Stats stats(const std::vector<double>& v) {
  StageTiming t;
  t.ms = v;
  Stats s;
  s.n = v.size();
  if (v.empty()) return s;
  s.mean = t.mean();
  s.stddev = t.stddev();
  s.min = t.min();
  s.max = t.max();
  s.median = t.median();
  return s;
}

std::vector<LabelId> scoredClasses(const LabelSet& l) {
  std::vector<LabelId> v;
  for (std::size_t c = 1; c < l.size(); ++c) v.push_back(static_cast<LabelId>(c));
  return v;
}

std::string pct(double v) { return fmt("%.1f %%", 100.0 * v); }

std::string statusCell(const RunRecord* r) {
  if (!r) return "–";
  if (r->status == RunRecord::Status::kSkipped) return "skipped";
  if (r->status == RunRecord::Status::kFailed) return "failed";
  return "";
}

const char* statusName(RunRecord::Status s) {
  switch (s) {
    case RunRecord::Status::kOk:
      return "ok";
    case RunRecord::Status::kSkipped:
      return "skipped";
    case RunRecord::Status::kFailed:
      return "failed";
  }
  return "?";
}

/// Relative tolerance when comparing energies of different optimisers (float unaries summed in
/// double: differences below this are rounding, not a better labelling).
bool energyLeq(double a, double b) {
  return a <= b + 1e-6 * std::max({1.0, std::fabs(a), std::fabs(b)});
}

std::string energiesSection(const SweepResult& r) {
  std::ostringstream o;
  o << "## Final energies\n\n"
       "Energy of the labelling each optimiser returned, recomputed from the energy model "
       "(`reported` is what the optimiser put in its report). Lower is better; all optimisers "
       "of a row minimise the same energy.\n\n";
  bool any = false;
  for (const auto& ds : r.datasets)
    for (const auto& fset : r.feature_sets) {
      std::vector<const RunRecord*> runs;
      for (const auto& op : r.optimisers) {
        const RunRecord* x = r.find(ds, fset, op);
        if (x && x->status == RunRecord::Status::kOk && !x->energies.empty()) runs.push_back(x);
      }
      if (runs.empty()) continue;
      any = true;
      o << "### " << ds << " × " << fset << "\n\n| scan |";
      for (const auto* x : runs) o << " " << x->optimiser << " |";
      o << " lowest |\n|---|";
      for (std::size_t i = 0; i < runs.size(); ++i) o << "---:|";
      o << "---|\n";
      std::map<std::string, std::map<std::string, double>> by_frame;  // frame → optimiser → E
      std::vector<std::string> frames;
      for (const auto* x : runs)
        for (const auto& e : x->energies) {
          if (!by_frame.count(e.frame)) frames.push_back(e.frame);
          by_frame[e.frame][x->optimiser] = e.recomputed;
        }
      std::map<std::string, std::size_t> lowest_count;
      std::size_t complete = 0;
      for (const auto& fr : frames) {
        o << "| " << fr << " |";
        const auto& m = by_frame[fr];
        for (const auto* x : runs) {
          auto it = m.find(x->optimiser);
          o << " " << (it == m.end() ? std::string("–") : fmt("%.3f", it->second)) << " |";
        }
        std::string lowest;
        if (m.size() == runs.size()) {
          ++complete;
          for (const auto* x : runs) {
            bool leq = true;
            for (const auto* y : runs)
              if (!energyLeq(m.at(x->optimiser), m.at(y->optimiser))) leq = false;
            if (leq) {
              ++lowest_count[x->optimiser];
              lowest += (lowest.empty() ? "" : ", ") + x->optimiser;
            }
          }
        }
        o << " " << (lowest.empty() ? "–" : lowest) << " |\n";
      }
      o << "\n";
      if (runs.size() > 1)
        for (const auto* x : runs)
          o << "- " << x->optimiser << " ≤ every other optimiser on " << lowest_count[x->optimiser]
            << " of " << complete << " scan(s)\n";
      o << "\n";
    }
  if (!any) o << "No run produced energies.\n\n";
  return o.str();
}

std::string evaluationSection(const SweepResult& r) {
  std::ostringstream o;
  o << "## Point-wise and cell-wise evaluation (paper 001 §VI-B)\n\n";
  for (const auto& x : r.runs) {
    o << "### " << x.dataset << " × " << x.feature_set << " × " << x.optimiser << "\n\n";
    if (x.status != RunRecord::Status::kOk) {
      o << "**" << statusName(x.status) << "**: " << x.reason << "\n\n";
      continue;
    }
    if (x.counts.scans == 0) {
      o << "Not scored: " << x.counts.frames_without_truth
        << " frame(s) without per-point ground truth.\n\n";
      continue;
    }
    o << toTable(x.counts, r.labels) << "\n";
  }
  return o.str();
}

std::string rocSection(const SweepResult& r) {
  std::ostringstream o;
  o << "## ROC curves (cell-wise, paper 000 Figure 6)\n\n"
       "| dataset | feature set | optimiser | scores | ";
  const auto classes = scoredClasses(r.labels);
  for (LabelId c : classes) o << capitalise(r.labels.name(c)) << " AUC | ";
  o << "plot |\n|---|---|---|---|";
  for (std::size_t i = 0; i < classes.size(); ++i) o << "---:|";
  o << "---|\n";
  for (const auto& x : r.runs) {
    if (x.status != RunRecord::Status::kOk) continue;
    o << "| " << x.dataset << " | " << x.feature_set << " | " << x.optimiser << " | "
      << (x.roc.empty() ? "none" : toString(x.score_source)) << " | ";
    for (LabelId c : classes) {
      double auc = kNaN;
      for (const auto& cv : x.roc)
        if (cv.class_id == c) auc = cv.auc;
      o << fmt("%.3f", auc) << " | ";
    }
    o << (x.roc.empty() ? std::string("–") : "[svg](roc/" + sanitize(x.key()) + ".svg)") << " |\n";
  }
  o << "\n";
  for (const auto& x : r.runs)
    if (x.status == RunRecord::Status::kOk && !x.roc_note.empty())
      o << "- " << x.dataset << " × " << x.feature_set << " × " << x.optimiser << ": " << x.roc_note
        << "\n";
  o << "\n";
  return o.str();
}

std::string runsSection(const SweepResult& r) {
  std::ostringstream o;
  o << "## Runs\n\n| dataset | feature set | optimiser | status | scans ok | note |\n"
       "|---|---|---|---|---:|---|\n";
  for (const auto& x : r.runs) {
    std::string note = x.reason;
    for (auto& ch : note)
      if (ch == '\n' || ch == '|') ch = ' ';
    o << "| " << x.dataset << " | " << x.feature_set << " | " << x.optimiser << " | "
      << statusName(x.status) << " | " << x.frames_ok << "/" << x.frames << " | " << note << " |\n";
  }
  o << "\n## Models\n\n| feature set | model | trained on |\n|---|---|---|\n";
  for (const auto& m : r.models) {
    o << "| " << m.feature_set << " | " << (m.path.empty() ? "–" : m.path) << " | ";
    for (const auto& t : m.train_items) o << t << "; ";
    if (m.trained)
      o << m.labelled_frames << " labelled of " << m.frames << " frame(s)";
    else
      o << m.reason;
    if (!m.selected.empty()) o << "; selected on validation: " << m.selected;
    if (!m.missing.empty()) {
      o << "; not learnt:";
      for (const auto& x : m.missing) o << " " << x;
    }
    if (!m.failed.empty()) {
      o << "; **" << m.failed.size() << " training frame(s) failed and were skipped:**";
      for (const auto& x : m.failed) {
        std::string why = x.second;
        for (auto& ch : why)
          if (ch == '\n' || ch == '|') ch = ' ';
        o << " " << x.first << " (" << why << ")";
      }
    }
    o << " |\n";
  }
  o << "\n";
  return o.str();
}

/// F1 of class c from cell-wise counts; NaN if undefined.
double cellF1(const EvalCounts& e, LabelId c) { return e.cell_wise.scores(c).f1(); }

std::string selectionSection(const SweepResult& r) {
  if (r.selections.empty()) return "";
  std::ostringstream o;
  o << "## Parameters selected on validation\n\n";
  if (r.folds > 0)
    o << r.folds << "-fold cross-validation inside the train split: for each fold, every "
      << "candidate was trained on the other folds and scored on that fold (";
  else
    o << "Every candidate was trained on the train split and scored on the validation split (";
  for (std::size_t i = 0; i < r.validation_items.size(); ++i)
    o << (i ? "; " : "") << r.validation_items[i];
  o << (r.folds > 0 ? "), the counts of all folds summed; the chosen candidate was then learnt "
                      "on the whole train split"
                    : ")")
    << ", never on the test split. The first candidate listed whose score is within the tie "
       "margin of the best wins (a few cells are noise, not a reason for a larger model). "
       "Cell-wise F1 (paper 001 §VI-B rules).\n\n";
  const std::vector<LabelId> classes = scoredClasses(r.labels);
  for (const auto& s : r.selections) {
    o << "### " << s.feature_set << " (optimiser " << s.optimiser << ", score " << s.score
      << ", tie " << fmt("%g", s.tie) << (s.refit ? ", refit on train + validation" : "")
      << ")\n\n| candidate |";
    for (LabelId c : classes) o << " " << r.labels.name(c) << " F1 |";
    o << " score | |\n|---|";
    for (std::size_t k = 0; k < classes.size(); ++k) o << "---:|";
    o << "---:|---|\n";
    for (std::size_t i = 0; i < s.candidates.size(); ++i) {
      o << "| " << s.candidates[i] << " |";
      for (LabelId c : classes) o << " " << fmt("%.3f", cellF1(s.counts[i], c)) << " |";
      o << " " << fmt("%.4f", s.scores[i]) << " | "
        << (static_cast<int>(i) == s.chosen ? "**chosen**" : s.notes[i]) << " |\n";
    }
    o << "\n";
  }
  return o.str();
}

std::string selectionCsv(const SweepResult& r) {
  std::ostringstream o;
  const std::vector<LabelId> classes = scoredClasses(r.labels);
  o << "feature_set,optimiser,score_name,candidate,chosen,score";
  for (LabelId c : classes) o << ",f1_" << r.labels.name(c);
  o << ",model,note\n";
  for (const auto& s : r.selections)
    for (std::size_t i = 0; i < s.candidates.size(); ++i) {
      o << csvField(s.feature_set) << "," << csvField(s.optimiser) << "," << s.score << ","
        << csvField(s.candidates[i]) << "," << (static_cast<int>(i) == s.chosen ? 1 : 0) << ","
        << csvNum(s.scores[i]);
      for (LabelId c : classes) o << "," << csvNum(cellF1(s.counts[i], c));
      o << "," << csvField(s.models[i]) << "," << csvField(s.notes[i]) << "\n";
    }
  return o.str();
}

std::string accuracyCsv(const SweepResult& r) {
  std::ostringstream o;
  o << "dataset,optimiser,feature_set,status,class,cell_tpr,cell_fpr,point_tpr,point_fpr\n";
  for (const auto& x : r.runs)
    for (LabelId c : scoredClasses(r.labels)) {
      const bool ok = x.status == RunRecord::Status::kOk;
      const ClassScores cs = x.counts.cell_wise.scores(c), ps = x.counts.point_wise.scores(c);
      o << csvField(x.dataset) << "," << csvField(x.optimiser) << "," << csvField(x.feature_set) << ","
        << statusName(x.status) << "," << r.labels.name(c) << "," << (ok ? csvNum(cs.tpr()) : "")
        << "," << (ok ? csvNum(cs.fpr()) : "") << "," << (ok ? csvNum(ps.tpr()) : "") << ","
        << (ok ? csvNum(ps.fpr()) : "") << "\n";
    }
  return o.str();
}

/// "p_lo,p_hi,r_lo,r_hi": 95 % intervals of precision and recall (EvalCounts::ci95).
std::string ci95Csv(const EvalCounts& counts, bool point_wise_level, LabelId c) {
  const auto [p, r] = counts.ci95(point_wise_level, c);
  return csvNum(p.lo) + "," + csvNum(p.hi) + "," + csvNum(r.lo) + "," + csvNum(r.hi);
}

std::string evaluationCsv(const SweepResult& r) {
  std::ostringstream o;
  o << "dataset,optimiser,feature_set,status,level,class,tp,fp,fn,tn,precision,recall,tpr,fpr,"
       "scans,points,labelled_points,classified_points,cells_scored,precision_ci95_lo,"
       "precision_ci95_hi,recall_ci95_lo,recall_ci95_hi\n";
  for (const auto& x : r.runs) {
    if (x.status != RunRecord::Status::kOk) continue;
    for (const char* level : {"point", "cell"})
      for (LabelId c : scoredClasses(r.labels)) {
        const ConfusionMatrix& m = level[0] == 'p' ? x.counts.point_wise : x.counts.cell_wise;
        const ClassScores s = m.scores(c);
        o << csvField(x.dataset) << "," << csvField(x.optimiser) << "," << csvField(x.feature_set)
          << ",ok," << level << "," << r.labels.name(c) << "," << s.tp << "," << s.fp << "," << s.fn
          << "," << s.tn << "," << csvNum(s.precision()) << "," << csvNum(s.recall()) << ","
          << csvNum(s.tpr()) << "," << csvNum(s.fpr()) << "," << x.counts.scans << ","
          << x.counts.points << "," << x.counts.labelled_points << "," << x.counts.classified_points
          << "," << x.counts.cells_scored << "," << ci95Csv(x.counts, level[0] == 'p', c) << "\n";
      }
  }
  return o.str();
}

/// Cell-wise precision/recall of every class, one row per scan (paper 001's rules).
std::string perScanCsv(const SweepResult& r) {
  std::ostringstream o;
  o << "dataset,feature_set,optimiser,frame,level,class,tp,fp,fn,precision,recall,"
       "precision_ci95_lo,precision_ci95_hi,recall_ci95_lo,recall_ci95_hi\n";
  for (const auto& x : r.runs)
    for (const auto& [frame, counts] : x.per_scan)
      for (const char* level : {"point", "cell"})
        for (LabelId c : scoredClasses(r.labels)) {
          const ClassScores s = (level[0] == 'p' ? counts.point_wise : counts.cell_wise).scores(c);
          o << csvField(x.dataset) << "," << csvField(x.feature_set) << "," << csvField(x.optimiser)
            << "," << csvField(frame) << "," << level << "," << r.labels.name(c) << "," << s.tp
            << "," << s.fp << "," << s.fn << "," << csvNum(s.precision()) << ","
            << csvNum(s.recall()) << "," << ci95Csv(counts, level[0] == 'p', c) << "\n";
        }
  return o.str();
}

/// Markdown: one row per run and scan, cell-wise P/R per class.
std::string perScanSection(const SweepResult& r) {
  std::ostringstream o;
  o << "## Cell-wise precision / recall per scan (paper 001 §VI-B)\n\n| dataset | feature set | "
       "optimiser | scan |";
  const std::vector<LabelId> classes = scoredClasses(r.labels);
  for (LabelId c : classes) o << " " << r.labels.name(c) << " P / R |";
  o << "\n|---|---|---|---|";
  for (std::size_t i = 0; i < classes.size(); ++i) o << "---:|";
  o << "\n";
  for (const auto& x : r.runs)
    for (const auto& [frame, counts] : x.per_scan) {
      o << "| " << x.dataset << " | " << x.feature_set << " | " << x.optimiser << " | " << frame
        << " |";
      for (LabelId c : classes) {
        const ClassScores s = counts.cell_wise.scores(c);
        o << " " << fmt("%.3f", s.precision()) << " / " << fmt("%.3f", s.recall()) << " |";
      }
      o << "\n";
    }
  return o.str() + "\n";
}

std::string runtimeCsv(const SweepResult& r) {
  std::ostringstream o;
  o << "dataset,feature_set,optimiser,status,scans,processing_mean_ms,processing_std_ms,"
       "processing_max_ms,processing_min_ms,processing_median_ms,features_mean_ms,mrf_mean_ms,"
       "total_mean_ms\n";
  for (const auto& x : r.runs) {
    const Stats p = stats(x.times.processing);
    o << csvField(x.dataset) << "," << csvField(x.feature_set) << "," << csvField(x.optimiser) << ","
      << statusName(x.status) << "," << p.n << "," << csvNum(p.mean) << "," << csvNum(p.stddev)
      << "," << csvNum(p.max) << "," << csvNum(p.min) << "," << csvNum(p.median) << ","
      << csvNum(stats(x.times.features).mean) << "," << csvNum(stats(x.times.mrf).mean) << ","
      << csvNum(stats(x.times.total).mean) << "\n";
  }
  return o.str();
}

std::string energiesCsv(const SweepResult& r) {
  std::ostringstream o;
  o << "dataset,feature_set,optimiser,frame,initial_energy,reported_final_energy,energy,"
       "iterations,converged\n";
  for (const auto& x : r.runs)
    for (const auto& e : x.energies)
      o << csvField(x.dataset) << "," << csvField(x.feature_set) << "," << csvField(x.optimiser) << ","
        << csvField(e.frame) << "," << csvNum(e.initial) << "," << csvNum(e.reported) << ","
        << csvNum(e.recomputed) << "," << e.iterations << "," << (e.converged ? 1 : 0) << "\n";
  return o.str();
}

std::string rocAucCsv(const SweepResult& r) {
  std::ostringstream o;
  o << "dataset,feature_set,optimiser,class,score_source,positives,negatives,auc,operating_fpr,"
       "operating_tpr\n";
  for (const auto& x : r.runs)
    for (const auto& c : x.roc)
      o << csvField(x.dataset) << "," << csvField(x.feature_set) << "," << csvField(x.optimiser) << ","
        << c.class_name << "," << toString(x.score_source) << "," << c.positives << ","
        << c.negatives << "," << csvNum(c.auc) << "," << csvNum(c.operating_fpr) << ","
        << csvNum(c.operating_tpr) << "\n";
  return o.str();
}

std::string timesJson(const std::vector<double>& v) {
  const Stats s = stats(v);
  std::ostringstream o;
  o << "{\"scans\": " << s.n << ", \"mean\": " << jsonNum(s.mean)
    << ", \"std\": " << jsonNum(s.stddev) << ", \"max\": " << jsonNum(s.max)
    << ", \"min\": " << jsonNum(s.min) << ", \"median\": " << jsonNum(s.median)
    << ", \"per_scan\": [";
  for (std::size_t i = 0; i < v.size(); ++i) o << (i ? ", " : "") << jsonNum(v[i]);
  o << "]}";
  return o.str();
}

/// [{"frame": …, "reason": …}, …]
std::string failedJson(const std::vector<std::pair<std::string, std::string>>& failed) {
  std::string s = "[";
  for (std::size_t k = 0; k < failed.size(); ++k)
    s += (k ? ", " : "") + ("{\"frame\": " + jsonQuote(failed[k].first)) +
         ", \"reason\": " + jsonQuote(failed[k].second) + "}";
  return s + "]";
}

std::string resultsJson(const SweepResult& r) {
  auto list = [](const std::vector<std::string>& v) {
    std::string s = "[";
    for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + jsonQuote(v[i]);
    return s + "]";
  };
  std::ostringstream o;
  o << "{\n  \"schema\": \"terramrf.compare/1\",\n  \"name\": " << jsonQuote(r.name)
    << ",\n  \"sweep\": " << jsonQuote(r.sweep_path)
    << ",\n  \"output_dir\": " << jsonQuote(r.output_dir)
    << ",\n  \"created\": " << jsonQuote(creationTime())
    << ",\n  \"tool\": " << jsonQuote(std::string("terramrf ") + TERRAMRF_VERSION)
    << ",\n  \"limit\": " << r.limit
    << ",\n  \"interrupted\": " << (r.stop_signal ? jsonQuote(signalName(r.stop_signal)) : "null")
    << ",\n  \"labels\": " << list(r.labels.names()) << ",\n  \"datasets\": " << list(r.datasets)
    << ",\n  \"feature_sets\": " << list(r.feature_sets)
    << ",\n  \"optimisers\": " << list(r.optimisers) << ",\n  \"train\": " << list(r.train_items)
    << ",\n  \"models\": [";
  for (std::size_t i = 0; i < r.models.size(); ++i) {
    const auto& m = r.models[i];
    o << (i ? "," : "") << "\n    {\"feature_set\": " << jsonQuote(m.feature_set)
      << ", \"path\": " << (m.path.empty() ? "null" : jsonQuote(m.path))
      << ", \"trained\": " << (m.trained ? "true" : "false")
      << ", \"reason\": " << jsonQuote(m.reason) << ", \"frames\": " << m.frames
      << ", \"labelled_frames\": " << m.labelled_frames << ", \"train\": " << list(m.train_items)
      << ", \"not_learnt\": " << list(m.missing) << ", \"failed\": " << failedJson(m.failed)
      << ", \"selected\": " << (m.selected.empty() ? "null" : jsonQuote(m.selected)) << "}";
  }
  o << "\n  ],\n  \"validation\": " << list(r.validation_items) << ",\n  \"selection\": [";
  for (std::size_t i = 0; i < r.selections.size(); ++i) {
    const auto& s = r.selections[i];
    o << (i ? "," : "") << "\n    {\"feature_set\": " << jsonQuote(s.feature_set)
      << ", \"optimiser\": " << jsonQuote(s.optimiser) << ", \"score\": " << jsonQuote(s.score)
      << ", \"tie\": " << jsonNum(s.tie) << ", \"refit\": " << (s.refit ? "true" : "false")
      << ", \"folds\": " << s.folds << ", \"chosen\": "
      << (s.chosen < 0 ? std::string("null") : jsonQuote(s.candidates[s.chosen]))
      << ", \"candidates\": [";
    for (std::size_t k = 0; k < s.candidates.size(); ++k)
      o << (k ? ", " : "") << "{\"candidate\": " << jsonQuote(s.candidates[k])
        << ", \"score\": " << jsonNum(s.scores[k]) << ", \"model\": " << jsonQuote(s.models[k])
        << ", \"note\": " << jsonQuote(s.notes[k]) << "}";
    o << "]}";
  }
  o << "\n  ],\n  \"runs\": [";
  for (std::size_t i = 0; i < r.runs.size(); ++i) {
    const auto& x = r.runs[i];
    o << (i ? "," : "") << "\n    {\"dataset\": " << jsonQuote(x.dataset)
      << ", \"feature_set\": " << jsonQuote(x.feature_set)
      << ", \"optimiser\": " << jsonQuote(x.optimiser) << ", \"status\": \"" << statusName(x.status)
      << "\", \"reason\": " << jsonQuote(x.reason)
      << ", \"output_dir\": " << jsonQuote(x.output_dir) << ", \"frames\": " << x.frames
      << ", \"frames_ok\": " << x.frames_ok << ", \"failed\": " << failedJson(x.failed)
      << ",\n     \"times_ms\": {\"processing\": " << timesJson(x.times.processing)
      << ",\n                  \"features\": " << timesJson(x.times.features)
      << ",\n                  \"mrf\": " << timesJson(x.times.mrf)
      << ",\n                  \"total\": " << timesJson(x.times.total)
      << "},\n     \"energies\": [";
    for (std::size_t k = 0; k < x.energies.size(); ++k) {
      const auto& e = x.energies[k];
      o << (k ? ", " : "") << "{\"frame\": " << jsonQuote(e.frame)
        << ", \"initial\": " << jsonNum(e.initial) << ", \"reported\": " << jsonNum(e.reported)
        << ", \"energy\": " << jsonNum(e.recomputed) << ", \"iterations\": " << e.iterations
        << ", \"converged\": " << (e.converged ? "true" : "false") << "}";
    }
    o << "],\n     \"roc\": {\"scores\": \"" << (x.roc.empty() ? "none" : toString(x.score_source))
      << "\", \"note\": " << jsonQuote(x.roc_note) << ", \"curves\": " << rocSummaryJson(x.roc)
      << "}";
    if (x.status == RunRecord::Status::kOk)
      o << ",\n     \"evaluation\": " << toJson(x.counts, r.labels);
    o << "}";
  }
  o << "\n  ]\n}\n";
  return o.str();
}

}  // namespace
}  // namespace sweep_detail

using sweep_detail::accuracyCsv;
using sweep_detail::capitalise;
using sweep_detail::creationTime;
using sweep_detail::energiesCsv;
using sweep_detail::energiesSection;
using sweep_detail::evaluationCsv;
using sweep_detail::evaluationSection;
using sweep_detail::fmt;
using sweep_detail::pct;
using sweep_detail::perScanCsv;
using sweep_detail::perScanSection;
using sweep_detail::resultsJson;
using sweep_detail::rocAucCsv;
using sweep_detail::rocSection;
using sweep_detail::runsSection;
using sweep_detail::runtimeCsv;
using sweep_detail::sanitize;
using sweep_detail::scoredClasses;
using sweep_detail::selectionCsv;
using sweep_detail::selectionSection;
using sweep_detail::Stats;
using sweep_detail::stats;
using sweep_detail::statusCell;

std::string accuracyTable(const SweepResult& r, const std::string& dataset,
                          const std::string& optimiser) {
  std::ostringstream o;
  o << "| Class/value |";
  for (const auto& f : r.feature_sets) o << " " << f << " |";
  o << "\n|---|";
  for (std::size_t i = 0; i < r.feature_sets.size(); ++i) o << "---:|";
  o << "\n";
  bool partial = false;
  for (LabelId c : scoredClasses(r.labels)) {
    for (const char* what : {"TPR", "FPR"}) {
      o << "| " << capitalise(r.labels.name(c)) << "/" << what << " |";
      for (const auto& f : r.feature_sets) {
        const RunRecord* x = r.find(dataset, f, optimiser);
        std::string cell = statusCell(x);
        if (cell.empty()) {
          const ClassScores s = x->counts.cell_wise.scores(c);
          cell = x->counts.scans == 0 ? "not scored" : pct(what[0] == 'T' ? s.tpr() : s.fpr());
          // Columns side by side must say when one was scored on fewer scans.
          if (!x->failed.empty()) cell += " †", partial = true;
        }
        o << " " << cell << " |";
      }
      o << "\n";
    }
  }
  if (partial)
    o << "\n† scored without the frames that failed in that run (Runs table: frames ok / "
         "frames)\n";
  return o.str();
}

std::string runtimeTable(const SweepResult& r, const std::string& dataset) {
  std::ostringstream o;
  const bool many = r.optimisers.size() > 1;
  o << "| Mode | Mean | Std. dev. | Max | Min | scans | features (mean) | MRF (mean) |\n"
       "|---|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const auto& f : r.feature_sets)
    for (const auto& op : r.optimisers) {
      const RunRecord* x = r.find(dataset, f, op);
      o << "| " << f << (many ? " (" + op + ")" : std::string()) << " |";
      const std::string st = statusCell(x);
      if (!st.empty()) {
        o << " " << st << " | | | | | | |\n";
        continue;
      }
      const Stats p = stats(x->times.processing);
      o << " " << fmt("%.1f ms", p.mean) << " | " << fmt("%.1f ms", p.stddev) << " | "
        << fmt("%.1f ms", p.max) << " | " << fmt("%.1f ms", p.min) << " | " << p.n << " | "
        << fmt("%.1f ms", stats(x->times.features).mean) << " | "
        << fmt("%.1f ms", stats(x->times.mrf).mean) << " |\n";
    }
  return o.str();
}

void writeSweepReport(const SweepResult& r, const std::string& dir) {
  fs::create_directories(dir + "/roc");
  std::ostringstream acc, rt;
  acc << "## Accuracy per feature set (cell-wise TPR/FPR, paper 000 Tables 1–2)\n\n";
  for (const auto& ds : r.datasets)
    for (const auto& op : r.optimisers)
      acc << "### " << ds << ", optimiser " << op << "\n\n" << accuracyTable(r, ds, op) << "\n";
  rt << "## Runtime per scan (paper 000 Table 3)\n\n"
        "Processing = grid + feature + energy + optimiser stages (reading and outputs excluded); "
        "features = grid + egomotion + feature stages; MRF = energy + optimiser.\n\n";
  for (const auto& ds : r.datasets) rt << "### " << ds << "\n\n" << runtimeTable(r, ds) << "\n";
  const std::string energies = energiesSection(r), evaluation = evaluationSection(r),
                    roc = rocSection(r), runs = runsSection(r);
  std::ostringstream head;
  head << "# Sweep '" << r.name << "'\n\n- sweep file: " << r.sweep_path
       << "\n- created: " << creationTime() << " (terramrf " << TERRAMRF_VERSION
       << ")\n- train split:";
  for (const auto& t : r.train_items) head << " " << t << ";";
  if (r.train_items.empty()) head << " none (every feature set brings its model or train list)";
  if (!r.validation_items.empty()) {
    head << (r.folds > 0 ? "\n- validation folds of the train split (select:):"
                         : "\n- validation split (select:):");
    for (const auto& t : r.validation_items) head << " " << t << ";";
  }
  head << "\n- test datasets:";
  for (const auto& t : r.datasets) head << " " << t << ";";
  if (r.limit) head << "\n- at most " << r.limit << " frame(s) per split item (--limit)";
  std::size_t skipped = 0, failed = 0;
  for (const auto& x : r.runs) {
    skipped += x.status == RunRecord::Status::kSkipped;
    failed += x.status == RunRecord::Status::kFailed;
  }
  head << "\n- runs: " << r.runs.size() << " (" << skipped << " skipped, " << failed
       << " failed; reasons under Runs)";
  if (r.stop_signal != 0)
    head << "\n- **interrupted** (" << signalName(r.stop_signal)
         << "): the run or training in hand stopped after its frame in hand and is reported "
            "failed; those after it were not run";
  if (r.cached_frames)
    head << "\n- frame cache: " << r.cached_frames << " frame(s) kept after their first read ("
         << fmt("%.0f", r.cached_mb) << " MB), " << r.cache_hits
         << " read(s) served from memory (their `read` time in timing.md is the copy)";
  head << "\n\n";
  writeFileAtomic(dir + "/accuracy.md", acc.str());
  writeFileAtomic(dir + "/runtime.md", rt.str());
  writeFileAtomic(dir + "/energies.md", energies);
  const std::string per_scan = perScanSection(r);
  writeFileAtomic(dir + "/evaluation.md", evaluation);
  writeFileAtomic(dir + "/per_scan.md", per_scan);
  const std::string selection = selectionSection(r);
  writeFileAtomic(dir + "/summary.md", head.str() + selection + acc.str() + per_scan + rt.str() +
                                           roc + energies + runs + evaluation);
  if (!r.selections.empty()) {
    writeFileAtomic(dir + "/selection.md", selection);
    writeFileAtomic(dir + "/selection.csv", selectionCsv(r));
  }
  writeFileAtomic(dir + "/accuracy.csv", accuracyCsv(r));
  writeFileAtomic(dir + "/evaluation.csv", evaluationCsv(r));
  writeFileAtomic(dir + "/per_scan.csv", perScanCsv(r));
  writeFileAtomic(dir + "/runtime.csv", runtimeCsv(r));
  writeFileAtomic(dir + "/energies.csv", energiesCsv(r));
  writeFileAtomic(dir + "/roc_auc.csv", rocAucCsv(r));
  writeFileAtomic(dir + "/results.json", resultsJson(r));
  for (const auto& x : r.runs) {
    if (x.roc.empty()) continue;
    const std::string base = dir + "/roc/" + sanitize(x.key());
    writeFileAtomic(base + ".csv", rocCsv(x.roc));
    writeFileAtomic(base + ".svg", rocSvg(x.roc, r.labels,
                                          x.dataset + " — " + x.feature_set + " — " + x.optimiser +
                                              " (" + toString(x.score_source) + ")"));
  }
}

}  // namespace terramrf
