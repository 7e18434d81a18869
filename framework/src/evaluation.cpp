#include "terramrf/evaluation.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "terramrf/errors.hpp"
#include "terramrf/text_format.hpp"

namespace terramrf {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double ratio(uint64_t num, uint64_t den) {
  return den == 0 ? kNaN : static_cast<double>(num) / static_cast<double>(den);
}

/// Geometry of a sum: the common value, the other one if one side has none yet (0), NaN if
/// the two differ.
double mergeGeometry(double a, double b) {
  if (a == 0) return b;
  if (b == 0) return a;
  return a == b ? a : kNaN;
}

}  // namespace

// ---- ClassScores / ConfusionMatrix ----------------------------------------------------------

Interval wilsonInterval(uint64_t successes, uint64_t trials, double z) {
  if (trials == 0) return {kNaN, kNaN};
  return wilsonIntervalOf(double(successes) / double(trials), double(trials), z);
}

Interval wilsonIntervalOf(double p, double n, double z) {
  if (!(n > 0) || std::isnan(p)) return {kNaN, kNaN};
  const double z2 = z * z;
  const double centre = (p + z2 / (2 * n)) / (1 + z2 / n);
  const double half = z * std::sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / (1 + z2 / n);
  return {std::max(0.0, centre - half), std::min(1.0, centre + half)};
}

ClusteredProportion& ClusteredProportion::operator+=(const ClusteredProportion& o) {
  clusters += o.clusters;
  a += o.a, n += o.n, aa += o.aa, nn += o.nn, an += o.an;
  return *this;
}

double ClusteredProportion::effectiveTrials() const {
  if (!(n > 0)) return kNaN;
  const double r = a / n;
  // Σ(a_i − r·n_i)², the residual of the ratio estimator; rounding can leave it a hair below 0.
  const double resid = std::max(0.0, aa - 2 * r * an + r * r * nn);
  if (r <= 0 || r >= 1) return clusters;  // every cluster all or nothing: one trial each
  if (clusters < 2 || resid <= 0) return clusters < 2 ? clusters : n;
  const double var = clusters / (clusters - 1) * resid / (n * n);
  return std::clamp(r * (1 - r) / var, 1.0, n);
}

double ClassScores::precision() const { return ratio(tp, tp + fp); }
double ClassScores::recall() const { return ratio(tp, tp + fn); }
double ClassScores::fpr() const { return ratio(fp, fp + tn); }
double ClassScores::f1() const { return ratio(2 * tp, 2 * tp + fp + fn); }

uint64_t ConfusionMatrix::total() const {
  uint64_t s = 0;
  for (uint64_t v : m_) s += v;
  for (uint64_t v : x_) s += v;
  return s;
}

uint64_t ConfusionMatrix::excusedOf(LabelId truth) const {
  uint64_t s = 0;
  for (std::size_t p = 0; p < k_ && truth < k_; ++p) s += x_[truth * k_ + p];
  return s;
}

ClassScores ConfusionMatrix::scores(LabelId c) const {
  ClassScores s;
  if (c >= k_) return s;
  for (std::size_t t = 0; t < k_; ++t) {
    for (std::size_t p = 0; p < k_; ++p) {
      const uint64_t v = m_[t * k_ + p], x = x_[t * k_ + p];
      if (t == c) {
        (p == c ? s.tp : s.fn) += v;
        s.fn += x;
      } else if (p == c) {
        s.fp += v;  // excused items x: neither a false positive nor a true negative
      } else {
        s.tn += v + x;
      }
    }
  }
  return s;
}

ConfusionMatrix& ConfusionMatrix::operator+=(const ConfusionMatrix& o) {
  if (o.k_ != k_) {
    throw std::invalid_argument("confusion matrices of different label sets (" +
                                std::to_string(k_) + " vs " + std::to_string(o.k_) +
                                " classes) cannot be added");
  }
  for (std::size_t i = 0; i < m_.size(); ++i) m_[i] += o.m_[i];
  for (std::size_t i = 0; i < x_.size(); ++i) x_[i] += o.x_[i];
  return *this;
}

// ---- rules ----------------------------------------------------------------------------------

const char* toString(EvalRules r) {
  switch (r) {
    case EvalRules::kPaper001:
      return "paper001";
  }
  return "?";
}

std::pair<Interval, Interval> EvalCounts::ci95(bool point_wise_level, LabelId c) const {
  if (!point_wise_level) {
    const ClassScores s = cell_wise.scores(c);
    return {s.precisionCi95(), s.recallCi95()};
  }
  const Interval none{kNaN, kNaN};
  return {c < point_precision.size() ? point_precision[c].ci95() : none,
          c < point_recall.size() ? point_recall[c].ci95() : none};
}

EvalRules evalRulesFromString(const std::string& name) {
  if (name == "paper001") return EvalRules::kPaper001;
  throw std::invalid_argument("unknown evaluation rules '" + name + "'; known: paper001");
}

// ---- EvalCounts -----------------------------------------------------------------------------

EvalCounts& EvalCounts::operator+=(const EvalCounts& o) {
  point_wise += o.point_wise;
  cell_wise += o.cell_wise;
  scans += o.scans;
  frames_without_truth += o.frames_without_truth;
  frames_failed += o.frames_failed;
  frames_failed_after_evaluation += o.frames_failed_after_evaluation;
  if (point_precision.size() < o.point_precision.size()) {
    point_precision.resize(o.point_precision.size());
    point_recall.resize(o.point_recall.size());
  }
  for (std::size_t c = 0; c < o.point_precision.size(); ++c) {
    point_precision[c] += o.point_precision[c];
    point_recall[c] += o.point_recall[c];
  }
  points += o.points;
  labelled_points += o.labelled_points;
  classified_points += o.classified_points;
  points_outside_grid += o.points_outside_grid;
  labelled_points_outside_grid += o.labelled_points_outside_grid;
  labelled_points_unclassified += o.labelled_points_unclassified;
  excused_points += o.excused_points;
  cells_scored += o.cells_scored;
  cells_labelled_unclassified += o.cells_labelled_unclassified;
  cells_obstacle_rule += o.cells_obstacle_rule;
  cells_tied += o.cells_tied;
  grid_size_m = mergeGeometry(grid_size_m, o.grid_size_m);
  cell_m = mergeGeometry(cell_m, o.cell_m);
  return *this;
}

// ---- cell truth -----------------------------------------------------------------------------

CellTruth cellTruth(const std::vector<uint64_t>& per_class, int obstacle_id, LabelId predicted) {
  CellTruth t;
  const std::size_t k = per_class.size();
  uint64_t largest = 0;  // from class 1 on: unknown truth is not scored
  for (std::size_t c = 1; c < k; ++c) {
    t.labelled += per_class[c];
    largest = std::max(largest, per_class[c]);
  }
  if (t.labelled == 0) return t;
  // Obstacle-any: the planner must avoid a cell with any obstacle point in it.
  if (obstacle_id > 0 && static_cast<std::size_t>(obstacle_id) < k && per_class[obstacle_id] > 0) {
    t.label = static_cast<LabelId>(obstacle_id);
    t.obstacle_rule = per_class[obstacle_id] < largest;
    return t;
  }
  // Majority; among tied classes the predicted one (kTieRule), else the highest id.
  int n_tied = 0;
  bool pred_tied = false;
  for (std::size_t c = 1; c < k; ++c) {
    if (per_class[c] != largest) continue;
    ++n_tied;
    t.label = static_cast<LabelId>(c);
    if (c == predicted) pred_tied = true;
  }
  if (n_tied > 1) {
    t.tied = true;
    if (pred_tied) t.label = predicted;
  }
  return t;
}

// ---- Evaluator ------------------------------------------------------------------------------

Evaluator::Evaluator(const LabelSet& labels, EvalRules rules)
    : labels_(labels), rules_(rules), total_(labels.size()) {}

EvalCounts Evaluator::addFrame(const TerrainGrid& grid, const Frame& frame) {
  const std::size_t k = labels_.size();
  EvalCounts f(k);
  if (frame.truth.empty()) {
    f.frames_without_truth = 1;
    total_ += f;
    return f;
  }

  // Validate everything before counting so a bad frame leaves the totals untouched.
  const std::string where = frame.source_path.empty() ? frame.id : frame.source_path;
  const std::string name = "frame " + frame.id + ": ";
  const std::size_t n = frame.points.size();
  const auto& truth = frame.truth.label;
  if (truth.size() != n) {
    throw InputError(where, name + "ground truth has " + std::to_string(truth.size()) +
                                " labels for " + std::to_string(n) +
                                " points; expected one label per point");
  }
  const auto& cell_of = grid.cellOfPoint();
  if (cell_of.size() != n) {
    throw InputError(where, name + "grid point lists cover " + std::to_string(cell_of.size()) +
                                " points but the frame has " + std::to_string(n) +
                                "; expected the grid to be binned from this frame's points");
  }
  const auto& predicted = grid.labels();
  if (predicted.size() != grid.cells()) {
    throw InputError(where, name + "grid has " + std::to_string(predicted.size()) + " labels for " +
                                std::to_string(grid.cells()) +
                                " cells; expected one label per cell");
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (truth[i] >= k) {
      throw InputError(where, name + "ground-truth label " + std::to_string(truth[i]) +
                                  " at point " + std::to_string(i) + " is not a class id (" +
                                  std::to_string(k) + " classes)");
    }
  }
  for (std::size_t c = 0; c < predicted.size(); ++c) {
    if (predicted[c] >= k) {
      throw InputError(where, name + "predicted label " + std::to_string(predicted[c]) +
                                  " in cell " + std::to_string(c) + " is not a class id (" +
                                  std::to_string(k) + " classes)");
    }
  }

  const int obstacle_id = labels_.obstacle();  // -1: no obstacle class, majority rule only
  f.scans = 1;
  f.points = n;
  f.grid_size_m = grid.cols() * grid.geometry().cell_m;
  f.cell_m = grid.geometry().cell_m;
  for (std::size_t i = 0; i < n; ++i) {
    const bool labelled = truth[i] != labels::kUnknown;
    f.labelled_points += labelled;
    if (cell_of[i] < 0) {
      ++f.points_outside_grid;
      f.labelled_points_outside_grid += labelled;
    }
  }

  std::vector<uint64_t> per_class(k);
  const int cells = static_cast<int>(grid.cells());
  for (int cell = 0; cell < cells; ++cell) {
    const uint32_t in_cell = grid.count(cell);
    if (in_cell == 0) continue;
    const LabelId pred = predicted[cell];
    if (pred != labels::kUnknown) f.classified_points += in_cell;

    std::fill(per_class.begin(), per_class.end(), 0);
    for (const uint32_t* p = grid.pointsBegin(cell); p != grid.pointsEnd(cell); ++p) {
      ++per_class[truth[*p]];
    }
    const CellTruth cell_truth = cellTruth(per_class, obstacle_id, pred);
    if (cell_truth.label == labels::kUnknown) continue;  // nothing to compare with: not scored
    const uint64_t labelled = cell_truth.labelled;
    const bool holds_obstacle = obstacle_id > 0 && per_class[obstacle_id] > 0;
    f.cells_obstacle_rule += cell_truth.obstacle_rule;
    f.cells_tied += cell_truth.tied;
    ++f.cells_scored;
    f.cell_wise.add(cell_truth.label, pred);
    if (pred == labels::kUnknown) {
      ++f.cells_labelled_unclassified;
      f.labelled_points_unclassified += labelled;
    }

    // Points: scored against the cell's class, except non-obstacle points in a cell that is
    // rightly an obstacle (it holds a GT obstacle point and is predicted obstacle): "not
    // considered a FP", but still missed as their own class, as paper 001's tables count them.
    const bool excuse = holds_obstacle && pred == obstacle_id;
    uint64_t predicted_as_pred = 0;  // points this cell adds to TP + FP of its predicted class
    for (std::size_t c = 1; c < k; ++c) {
      if (per_class[c] == 0) continue;
      if (excuse && static_cast<int>(c) != obstacle_id) {
        f.excused_points += per_class[c];
        f.point_wise.addExcused(static_cast<LabelId>(c), pred, per_class[c]);
      } else {
        f.point_wise.add(static_cast<LabelId>(c), pred, per_class[c]);
        predicted_as_pred += per_class[c];
      }
      // The cell is one cluster of each true class's recall: all its points of class c are
      // found together or missed together.
      f.point_recall[c].add(c == pred ? double(per_class[c]) : 0.0, double(per_class[c]));
    }
    if (pred != labels::kUnknown)
      f.point_precision[pred].add(double(per_class[pred]), double(predicted_as_pred));
  }

  total_ += f;
  return f;
}

// ---- JSON -----------------------------------------------------------------------------------

namespace {

/// Shortest text that reads back to the same double; null for NaN/inf (not JSON numbers).
std::string jsonNumber(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

void jsonScores(std::ostringstream& o, const EvalCounts& counts, bool point_wise_level,
                const LabelSet& labels, const std::string& indent) {
  const ConfusionMatrix& m = point_wise_level ? counts.point_wise : counts.cell_wise;
  o << indent << "\"classes\": [\n";
  for (std::size_t c = 1; c < labels.size(); ++c) {
    const ClassScores s = m.scores(static_cast<LabelId>(c));
    const auto [p_ci, r_ci] = counts.ci95(point_wise_level, static_cast<LabelId>(c));
    o << indent << "  {\"id\": " << c << ", \"name\": " << jsonQuote(labels.name(c))
      << ", \"tp\": " << s.tp << ", \"fp\": " << s.fp << ", \"fn\": " << s.fn
      << ", \"tn\": " << s.tn << ", \"precision\": " << jsonNumber(s.precision())
      << ", \"recall\": " << jsonNumber(s.recall()) << ", \"precision_ci95\": ["
      << jsonNumber(p_ci.lo) << ", " << jsonNumber(p_ci.hi) << "], \"recall_ci95\": ["
      << jsonNumber(r_ci.lo) << ", " << jsonNumber(r_ci.hi) << "], \"tpr\": " << jsonNumber(s.tpr())
      << ", \"fpr\": " << jsonNumber(s.fpr()) << "}" << (c + 1 < labels.size() ? "," : "") << "\n";
  }
  o << indent << "],\n";
  o << indent << "\"confusion\": [\n";
  for (std::size_t t = 0; t < labels.size(); ++t) {
    o << indent << "  [";
    for (std::size_t p = 0; p < labels.size(); ++p) {
      o << (p ? ", " : "") << m.at(static_cast<LabelId>(t), static_cast<LabelId>(p));
    }
    o << "]" << (t + 1 < labels.size() ? "," : "") << "\n";
  }
  o << indent << "],\n";
  // Per true class: its items excused in obstacle cells (false negatives outside "confusion").
  o << indent << "\"excused\": [";
  for (std::size_t t = 0; t < labels.size(); ++t)
    o << (t ? ", " : "") << m.excusedOf(static_cast<LabelId>(t));
  o << "]\n";
}

}  // namespace

std::string toJson(const EvalCounts& c, const LabelSet& labels, EvalRules rules,
                   const std::string& frame_id) {
  std::ostringstream o;
  o << "{\n";
  o << "  \"schema\": \"terramrf.evaluation/1\",\n";
  if (!frame_id.empty()) o << "  \"frame\": " << jsonQuote(frame_id) << ",\n";
  o << "  \"rules\": " << jsonQuote(toString(rules)) << ",\n";
  o << "  \"tie_rule\": " << jsonQuote(kTieRule) << ",\n";
  o << "  \"labels\": [";
  for (std::size_t i = 0; i < labels.size(); ++i) {
    o << (i ? ", " : "") << jsonQuote(labels.name(static_cast<LabelId>(i)));
  }
  o << "],\n";
  o << "  \"counts\": {\n"
    << "    \"scans\": " << c.scans << ",\n"
    << "    \"frames_without_truth\": " << c.frames_without_truth << ",\n"
    << "    \"frames_failed\": " << c.frames_failed << ",\n"
    << "    \"frames_failed_after_evaluation\": " << c.frames_failed_after_evaluation << ",\n"
    << "    \"points\": " << c.points << ",\n"
    << "    \"labelled_points\": " << c.labelled_points << ",\n"
    << "    \"classified_points\": " << c.classified_points << ",\n"
    << "    \"points_outside_grid\": " << c.points_outside_grid << ",\n"
    << "    \"labelled_points_outside_grid\": " << c.labelled_points_outside_grid << ",\n"
    << "    \"labelled_points_unclassified\": " << c.labelled_points_unclassified << ",\n"
    << "    \"excused_points\": " << c.excused_points << ",\n"
    << "    \"scored_points\": " << c.scoredPoints() << ",\n"
    << "    \"cells_scored\": " << c.cells_scored << ",\n"
    << "    \"cells_labelled_unclassified\": " << c.cells_labelled_unclassified << ",\n"
    << "    \"cells_obstacle_rule\": " << c.cells_obstacle_rule << ",\n"
    << "    \"cells_tied\": " << c.cells_tied << ",\n"
    << "    \"grid_size_m\": " << jsonNumber(c.grid_size_m) << ",\n"
    << "    \"cell_m\": " << jsonNumber(c.cell_m) << "\n"
    << "  },\n";
  o << "  \"point_wise\": {\n";
  jsonScores(o, c, true, labels, "    ");
  o << "  },\n";
  o << "  \"cell_wise\": {\n";
  jsonScores(o, c, false, labels, "    ");
  o << "  }\n";
  o << "}\n";
  return o.str();
}

// ---- Markdown table -------------------------------------------------------------------------

namespace {

/// 26433792 -> "26,433,792" as in the paper's tables.
std::string grouped(uint64_t v) {
  std::string s = std::to_string(v);
  for (int i = static_cast<int>(s.size()) - 3; i > 0; i -= 3) s.insert(i, ",");
  return s;
}

std::string fixed(double v, int digits) {
  if (!std::isfinite(v)) return "–";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

std::string metres(double v) {
  if (!std::isfinite(v)) return "mixed";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

/// Paper 001 lists obstacle first; the other classes follow in id order.
std::vector<LabelId> tableOrder(const LabelSet& labels) {
  std::vector<LabelId> order;
  const int obstacle = labels.obstacle();
  if (obstacle > 0) order.push_back(static_cast<LabelId>(obstacle));
  for (std::size_t c = 1; c < labels.size(); ++c) {
    if (static_cast<int>(c) != obstacle) order.push_back(static_cast<LabelId>(c));
  }
  return order;
}

void scoreTable(std::ostringstream& o, const std::string& title, const ConfusionMatrix& m,
                const LabelSet& labels) {
  o << "| " << title << " | TP [No.] | FP [No.] | FN [No.] | Precision | Recall | TPR | FPR |\n";
  o << "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n";
  for (const LabelId c : tableOrder(labels)) {
    const ClassScores s = m.scores(c);
    o << "| " << labels.name(c) << " | " << grouped(s.tp) << " | " << grouped(s.fp) << " | "
      << grouped(s.fn) << " | " << fixed(s.precision(), 3) << " | " << fixed(s.recall(), 3) << " | "
      << fixed(s.tpr(), 3) << " | " << fixed(s.fpr(), 3) << " |\n";
  }
}

/// `excused`: a last column of each true class's excused items (point-wise tables).
void confusionTable(std::ostringstream& o, const std::string& title, const ConfusionMatrix& m,
                    const LabelSet& labels, bool excused) {
  // Predicted "unknown" is shown as its own column: labelled items left unclassified.
  o << "| " << title << ": true \\ predicted |";
  for (std::size_t p = 1; p < labels.size(); ++p) o << " " << labels.name(p) << " |";
  o << " unclassified |" << (excused ? " excused in obstacle cells (FN) |" : "") << "\n|---|";
  for (std::size_t p = 0; p < labels.size() + (excused ? 1 : 0); ++p) o << "---:|";
  o << "\n";
  for (std::size_t t = 1; t < labels.size(); ++t) {
    o << "| " << labels.name(t) << " |";
    for (std::size_t p = 1; p < labels.size(); ++p) {
      o << " " << grouped(m.at(static_cast<LabelId>(t), static_cast<LabelId>(p))) << " |";
    }
    o << " " << grouped(m.at(static_cast<LabelId>(t), labels::kUnknown)) << " |";
    if (excused) o << " " << grouped(m.excusedOf(static_cast<LabelId>(t))) << " |";
    o << "\n";
  }
}

}  // namespace

std::string toTable(const EvalCounts& c, const LabelSet& labels, EvalRules rules) {
  std::ostringstream o;
  const std::string g = metres(c.grid_size_m), s = metres(c.cell_m);
  o << "## Terrain classification evaluation (rules: " << toString(rules) << ")\n\n";
  o << "| Number of scans | " << grouped(c.scans) << " | 3D points [No.] | " << grouped(c.points)
    << " |\n";
  o << "| --- | ---: | --- | ---: |\n";
  o << "| Grid size [m×m] | " << g << "×" << g << " | Annotated points [No.] | "
    << grouped(c.labelled_points) << " |\n";
  o << "| Cell size [m×m] | " << s << "×" << s << " | Classified points [No.] | "
    << grouped(c.classified_points) << " |\n";
  o << "| Cells scored [No.] | " << grouped(c.cells_scored) << " | Points outside grid [No.] | "
    << grouped(c.points_outside_grid) << " |\n\n";

  scoreTable(o, "Point-wise", c.point_wise, labels);
  o << "\n";
  scoreTable(o, "Cell-wise", c.cell_wise, labels);
  o << "\n";
  confusionTable(o, "Point-wise", c.point_wise, labels, /*excused=*/true);
  o << "\n";
  confusionTable(o, "Cell-wise", c.cell_wise, labels, /*excused=*/false);
  o << "\n";

  o << "- Scored points: " << grouped(c.scoredPoints()) << "; labelled points outside the grid "
    << "(not scored): " << grouped(c.labelled_points_outside_grid)
    << "; labelled points in unclassified cells (FN): " << grouped(c.labelled_points_unclassified)
    << "; non-obstacle points excused in obstacle cells (FN of their class, not FP of "
    << "obstacle): " << grouped(c.excused_points) << "\n";
  o << "- Cells labelled but unclassified (FN): " << grouped(c.cells_labelled_unclassified)
    << "; cells made obstacle by a minority of obstacle points: " << grouped(c.cells_obstacle_rule)
    << "; cells decided by the tie rule: " << grouped(c.cells_tied) << "\n";
  o << "- Tie rule: " << kTieRule << "\n";
  if (c.frames_failed > 0)
    o << "- " << grouped(c.frames_failed) << " frames failed in the pipeline (not evaluated)\n";
  if (c.frames_failed_after_evaluation > 0)
    o << "- " << grouped(c.frames_failed_after_evaluation)
      << " frames failed in a later output after they were evaluated (counted here; the run "
         "reports them failed)\n";
  if (c.frames_without_truth > 0) {
    o << "- " << grouped(c.frames_without_truth) << " frames without ground truth (skipped)\n";
  }
  return o.str();
}

}  // namespace terramrf
