#pragma once
// Scoring a labelled grid against per-point ground truth with the rules of paper 001 §VI-B
// (point-wise and cell-wise precision/recall with the obstacle exceptions) plus the per-class
// TPR/FPR of paper 000 §5. The rules as implemented are spelled out in docs/evaluation.md.
//
// Everything is kept as confusion matrices (true × predicted counts); per-class TP/FP/FN/TN are
// derived from them, so totals over frames are plain sums and a later `compare` can add runs.
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "terramrf/frame.hpp"
#include "terramrf/label_set.hpp"
#include "terramrf/terrain_grid.hpp"

namespace terramrf {

/// A two-sided confidence interval of a proportion; NaN bounds when there were no trials.
struct Interval {
  double lo, hi;
};

/// Wilson score interval of `successes` out of `trials` at normal quantile `z` (1.96: 95 %).
/// Unlike p ± z·σ it stays inside [0, 1] and is not empty at 0 or n successes. It treats the
/// trials as independent; neighbouring cells of a scan are not (the MRF smooths them), so read it
/// as a lower bound on the uncertainty of one scan's precision or recall.
Interval wilsonInterval(uint64_t successes, uint64_t trials, double z = 1.959964);

/// The same for a proportion p̂ of `trials` that need not be whole (an effective sample size).
Interval wilsonIntervalOf(double p_hat, double trials, double z = 1.959964);

/// A proportion Σa_i / Σn_i whose items come in clusters i that share one decision: the points of
/// a cell all get the cell's class, so they are not independent trials. Sums over clusters that
/// merge across frames; the interval is Wilson's at the effective sample size of the ratio
/// estimator's cluster-robust variance (Kish's design effect), so a precision decided by a few
/// large cells gets the width of a few trials, not of thousands of points.
struct ClusteredProportion {
  double clusters = 0;                          ///< clusters with n_i > 0
  double a = 0, n = 0, aa = 0, nn = 0, an = 0;  ///< Σa_i, Σn_i, Σa_i², Σn_i², Σa_i·n_i

  void add(double ai, double ni) {
    if (ni <= 0) return;
    clusters += 1;
    a += ai, n += ni, aa += ai * ai, nn += ni * ni, an += ai * ni;
  }
  ClusteredProportion& operator+=(const ClusteredProportion& o);
  /// Effective number of independent trials (≤ n; the number of clusters when every cluster
  /// is all or nothing and p̂ is 0 or 1); NaN without trials.
  double effectiveTrials() const;
  /// 95 % Wilson interval at effectiveTrials().
  Interval ci95() const { return wilsonIntervalOf(n > 0 ? a / n : 0.0, effectiveTrials()); }
};

/// Counts for one class, one-vs-rest over the scored items (points or cells).
struct ClassScores {
  uint64_t tp = 0;  ///< truly and predicted this class
  uint64_t fp = 0;  ///< predicted this class, truly another
  uint64_t fn = 0;  ///< truly this class, predicted another (including unknown = unclassified)
  uint64_t tn = 0;  ///< neither truly nor predicted this class

  /// TP/(TP+FP); NaN when undefined (0/0).
  double precision() const;
  /// TP/(TP+FN); NaN when undefined. Paper 000's true positive rate is the same number.
  double recall() const;
  double tpr() const { return recall(); }
  /// FP/(FP+TN) (paper 000 §5); NaN when undefined.
  double fpr() const;
  /// F1 = 2·TP/(2·TP+FP+FN), the harmonic mean of precision and recall; NaN when undefined.
  double f1() const;
  /// 95 % Wilson intervals of precision and recall (wilsonInterval).
  Interval precisionCi95() const { return wilsonInterval(tp, tp + fp); }
  Interval recallCi95() const { return wilsonInterval(tp, tp + fn); }
};

/// Square matrix of counts indexed [true LabelId][predicted LabelId]. The predicted column
/// labels::kUnknown holds items in cells that were left unclassified; the true row kUnknown is
/// always zero because unknown ground truth is not scored.
///
/// Beside it, a second matrix of the same shape holds excused items (paper 001 §VI-B: a
/// non-obstacle point in a cell rightly predicted obstacle "is not considered a FP"): each is a
/// false negative of its true class, as the paper's tables count it, but neither a false
/// positive nor a true negative of the class predicted.
class ConfusionMatrix {
 public:
  explicit ConfusionMatrix(std::size_t labels = 0)
      : k_(labels), m_(labels * labels, 0), x_(labels * labels, 0) {}

  std::size_t size() const { return k_; }
  uint64_t at(LabelId truth, LabelId predicted) const { return m_[truth * k_ + predicted]; }
  void add(LabelId truth, LabelId predicted, uint64_t n = 1) { m_[truth * k_ + predicted] += n; }
  /// Excused items of true class `truth` in cells predicted `predicted` (see above).
  uint64_t excusedAt(LabelId truth, LabelId predicted) const { return x_[truth * k_ + predicted]; }
  void addExcused(LabelId truth, LabelId predicted, uint64_t n = 1) {
    x_[truth * k_ + predicted] += n;
  }
  /// Excused items of true class `truth`, whatever was predicted.
  uint64_t excusedOf(LabelId truth) const;
  /// Number of scored items (sum of all entries, excused ones included).
  uint64_t total() const;
  /// One-vs-rest counts of class `c`.
  ClassScores scores(LabelId c) const;
  /// Element-wise sum; throws std::invalid_argument if the sizes differ.
  ConfusionMatrix& operator+=(const ConfusionMatrix& o);
  bool operator==(const ConfusionMatrix& o) const { return k_ == o.k_ && m_ == o.m_ && x_ == o.x_; }

 private:
  std::size_t k_;
  std::vector<uint64_t> m_;
  std::vector<uint64_t> x_;  ///< excused items, [true][predicted]
};

/// Rule sets an evaluation can follow. Only paper 001's for now; the enum keeps the door open.
enum class EvalRules { kPaper001 };
const char* toString(EvalRules r);
/// Parses "paper001"; throws std::invalid_argument listing the known names otherwise.
EvalRules evalRulesFromString(const std::string& name);

/// How a cell's true class is chosen when no ground-truth obstacle point is in it and two or more
/// classes share the largest point count. Reported in the outputs.
inline constexpr const char* kTieRule =
    "if the predicted class is among the tied classes it is taken as true (paper 001: a cell is "
    "correct when >= 50% of its points share its class); otherwise the tied class with the "
    "highest id (default ids are ordered by caution: rough over road)";

/// The true class of one cell and how it was decided.
struct CellTruth {
  LabelId label = labels::kUnknown;  ///< kUnknown: no labelled point, the cell is not scored
  uint64_t labelled = 0;             ///< points in the cell whose truth is not unknown
  bool tied = false;                 ///< no obstacle point, and kTieRule chose among the largest
  bool obstacle_rule = false;        ///< obstacle by one GT obstacle point although obstacle
                                     ///< points were not the majority
};

/// True class of one cell (paper 001 §VI-B) from the counts of its points per true class (index =
/// LabelId; index 0, unknown truth, is ignored): obstacle if `obstacle_id` > 0 and the cell holds
/// one such point, else the majority; among tied classes `predicted` if it is tied, else the
/// highest id (kTieRule). The one rule of the cell-wise evaluation and of the ROC curves.
CellTruth cellTruth(const std::vector<uint64_t>& per_class, int obstacle_id, LabelId predicted);

/// Everything an evaluation counts. Sums over frames with +=.
struct EvalCounts {
  explicit EvalCounts(std::size_t labels = 0)
      : point_wise(labels), cell_wise(labels), point_precision(labels), point_recall(labels) {}

  ConfusionMatrix point_wise;  ///< scored points: true × predicted class of their cell
  ConfusionMatrix cell_wise;   ///< scored cells: true × predicted class

  // ---- paper 001 table header -------------------------------------------------------------
  uint64_t scans = 0;                 ///< frames evaluated (with ground truth)
  uint64_t frames_without_truth = 0;  ///< frames skipped because they carry no labels
  /// Frames of the run that failed in the pipeline before they were evaluated (set by whoever
  /// runs the evaluation: the evaluator never sees them), so totals say what they leave out.
  uint64_t frames_failed = 0;
  /// Frames evaluated (and counted in these totals) that then failed in a later output: the run
  /// reports them failed, so the totals say they hold them.
  uint64_t frames_failed_after_evaluation = 0;
  uint64_t points = 0;                ///< 3D points in the evaluated frames
  uint64_t labelled_points = 0;       ///< ground truth not unknown ("annotated points")
  uint64_t classified_points = 0;     ///< points (any truth) in cells predicted not unknown
  uint64_t points_outside_grid = 0;   ///< any truth; not classified, not scored
  // ---- where the labelled points went -------------------------------------------------------
  uint64_t labelled_points_outside_grid = 0;  ///< not scored
  uint64_t labelled_points_unclassified = 0;  ///< in cells predicted unknown; scored as FN
  uint64_t excused_points = 0;  ///< non-obstacle points in predicted-obstacle cells holding GT
                                ///< obstacle points: FN of their class, not FP of obstacle
  // ---- cells --------------------------------------------------------------------------------
  uint64_t cells_scored = 0;                 ///< cells holding at least one labelled point
  uint64_t cells_labelled_unclassified = 0;  ///< scored cells predicted unknown (FN)
  uint64_t cells_obstacle_rule = 0;  ///< scored cells made obstacle by >= 1 GT obstacle point
                                     ///< although obstacle points were not the majority
  uint64_t cells_tied = 0;           ///< scored cells whose truth needed the tie rule
  // ---- geometry (NaN if the evaluated frames used different grids, 0 if none yet) ----------
  double grid_size_m = 0;  ///< side of the square grid [m]
  double cell_m = 0;       ///< side of a cell [m]

  /// Point-wise precision and recall of each class (index = LabelId) with the cell as the
  /// cluster, for their intervals: Wilson's over points would treat every point as independent.
  std::vector<ClusteredProportion> point_precision, point_recall;

  uint64_t scoredPoints() const { return point_wise.total(); }
  /// 95 % intervals of precision (first) and recall (second) of class c: cell-wise Wilson's
  /// over cells, point-wise Wilson's at the effective number of trials with the cell as the
  /// cluster (ClusteredProportion).
  std::pair<Interval, Interval> ci95(bool point_wise_level, LabelId c) const;
  /// Sums counts and matrices; geometry stays if equal, becomes NaN if it differs.
  EvalCounts& operator+=(const EvalCounts& o);
};

/// Accumulates the evaluation of a run frame by frame.
class Evaluator {
 public:
  explicit Evaluator(const LabelSet& labels, EvalRules rules = EvalRules::kPaper001);

  /// Scores one frame: the predicted class of each cell is grid.labels(), points are taken from
  /// the grid's CSR point lists and grid.cellOfPoint() (-1 = outside), the true class of point i
  /// is frame.truth.label[i]. A frame without truth only increments frames_without_truth.
  /// Returns this frame's counts and adds them to total(). Throws InputError naming the frame
  /// if truth, grid and points disagree in size or hold ids outside the label set; total() is
  /// then unchanged.
  EvalCounts addFrame(const TerrainGrid& grid, const Frame& frame);

  const EvalCounts& total() const { return total_; }
  const LabelSet& labels() const { return labels_; }
  EvalRules rules() const { return rules_; }

 private:
  LabelSet labels_;
  EvalRules rules_;
  EvalCounts total_;
};

/// JSON document of the counts (schema "terramrf.evaluation/1", documented in
/// docs/evaluation.md). Undefined ratios are null. `frame_id` is included when not empty.
std::string toJson(const EvalCounts& counts, const LabelSet& labels,
                   EvalRules rules = EvalRules::kPaper001, const std::string& frame_id = "");

/// Markdown report shaped like paper 001 Table I: header counts, point-wise and cell-wise
/// TP/FP/FN/precision/recall plus TPR/FPR per class, then both confusion matrices. Undefined
/// ratios print as "–".
std::string toTable(const EvalCounts& counts, const LabelSet& labels,
                    EvalRules rules = EvalRules::kPaper001);

}  // namespace terramrf
