#pragma once
// Per-class ROC curves of a labelling (paper 000 §5, Figure 6): for class c, every scored cell
// contributes its score for c (an optimiser's `score.<c>` layer, higher = more confident) and
// whether its true class is c. Sweeping a threshold over the scores gives (FPR, TPR) pairs.
//
// The cells and their truth are those of the cell-wise evaluation (paper 001 §VI-B rules,
// cellTruth in evaluation.hpp): a cell is scored if it holds a labelled point; its true class is
// obstacle if it holds a ground-truth obstacle point, else the majority class, ties by the
// evaluation's tie rule. So the hard labelling's (FPR, TPR) — the "operating point" — is the
// cell-wise TPR/FPR of the evaluation restricted to cells that carry a score. Rules and file
// formats: docs/compare.md.
#include <cstdint>
#include <string>
#include <vector>

#include "terramrf/energy_model.hpp"
#include "terramrf/evaluation.hpp"
#include "terramrf/frame.hpp"
#include "terramrf/label_set.hpp"
#include "terramrf/terrain_grid.hpp"

namespace terramrf {

/// One threshold of a curve: cells with score ≥ threshold are called class c.
struct RocPoint {
  double threshold = 0;  ///< score; +inf for the (0, 0) start
  uint64_t tp = 0, fp = 0;
  double tpr = 0, fpr = 0;
};

struct RocCurve {
  std::string class_name;
  LabelId class_id = 0;
  uint64_t positives = 0;  ///< scored cells whose truth is the class
  uint64_t negatives = 0;  ///< scored cells whose truth is another class
  /// From (0, 0) to (1, 1) by decreasing threshold; tied scores form one step (a diagonal
  /// segment). Possibly thinned to `max_points` (the AUC is always from every sample).
  std::vector<RocPoint> points;
  /// Area under the curve = P(score of a positive > score of a negative) + ½ P(equal);
  /// NaN when there are no positives or no negatives.
  double auc = 0;
  /// 0: every score as the optimiser gave it. Otherwise so many low mantissa bits of each score
  /// were cleared to keep the accumulator's memory bounded (RocAccumulator): scores that then
  /// agree form one step and count as ties in the AUC.
  int score_bits_dropped = 0;
  /// (FPR, TPR) of the hard labelling on the same cells; NaN if undefined.
  double operating_fpr = 0, operating_tpr = 0;
  bool defined() const { return positives > 0 && negatives > 0; }
};

/// Where a frame's scores came from.
enum class ScoreSource { kNone, kScoreLayers, kLocalEnergy };
const char* toString(ScoreSource s);

/// What ROC accumulation did with one frame.
struct RocFrameStats {
  ScoreSource source = ScoreSource::kNone;
  uint64_t cells_scored = 0;  ///< cells with a labelled point (the evaluation's scored cells)
  uint64_t cells_without_score = 0;  ///< of those, cells with no finite score (e.g. fixed cells)
};

/// Score layers the grid carries, indexed by LabelId (nullptr where the class has none).
std::vector<const Layer*> scoreLayers(const TerrainGrid& grid, const LabelSet& labels);

/// Fallback scores when an optimiser writes no score layers: for each active label k of the
/// energy model and each optimised cell, the local energy margin
///   s_k = min_{j≠k} E_c(j) − E_c(k)
/// with E_c the eq. 12 local energy given the neighbours' final labels (from `labels`, the grid's
/// label layer). Positive where k is the cell's best label; monotone in the conditional
/// probability P(k | neighbours) ∝ exp(−E_c(k)) up to the other labels' energies, and free of the
/// underflow that makes exp(−E) tie at 0 or 1. Indexed by LabelId (size `num_classes`); classes
/// that are not active and fixed cells are NaN / empty. Returns an empty vector if the model is
/// empty or does not match the grid.
std::vector<Layer> localEnergyScores(const EnergyModel& em, const std::vector<LabelId>& labels,
                                     std::size_t num_classes);

/// Accumulates (score, truth) samples per class over frames; curves are computed on demand.
class RocAccumulator {
 public:
  explicit RocAccumulator(const LabelSet& labels);

  /// One sample of class `c`: `score` (NaN is not allowed: skip unscored cells), `positive` =
  /// the cell's truth is c, `predicted` = the hard labelling gave c.
  void add(LabelId c, float score, bool positive, bool predicted);

  /// Adds the scored cells of one frame. `scores[c]` is class c's score layer or nullptr (see
  /// scoreLayers / localEnergyScores). A frame without truth adds nothing. Throws InputError
  /// naming the frame if truth, grid and points disagree in size (nothing added then).
  RocFrameStats addFrame(const TerrainGrid& grid, const Frame& frame,
                         const std::vector<const Layer*>& scores, ScoreSource source);

  /// Convenience: score layers if the grid has any, else (if `energy` is given and not empty)
  /// localEnergyScores, else nothing (stats.source = kNone).
  RocFrameStats addFrame(const TerrainGrid& grid, const Frame& frame, const EnergyModel* energy);

  /// Most points a curve may be asked to keep (the `roc` output's and a sweep's `max_points`).
  static constexpr int kMaxCurvePoints = 10'000'000;

  /// Curve of class `c`. `max_points` > 0 thins the stored points (never the AUC).
  RocCurve curve(LabelId c, std::size_t max_points = 0) const;
  /// Curves of every class that received samples, in id order.
  std::vector<RocCurve> curves(std::size_t max_points = 0) const;

  uint64_t samples(LabelId c) const;
  /// Samples kept one by one per class before they are merged into groups of equal score.
  static constexpr std::size_t kCompactAt = std::size_t(1) << 21;
  /// Most groups kept per class: beyond it the scores are coarsened (RocCurve::score_bits_dropped)
  /// until at most half as many remain. With kCompactAt, 40 MB per class whatever the run's length
  /// (every sample kept took 8 bytes: 0.14 MB per KITTI frame, 5 GB for an hour at 10 Hz).
  static constexpr std::size_t kMaxGroups = std::size_t(1) << 20;
  const LabelSet& labels() const { return labels_; }
  /// Frames that contributed, by score source; cells seen without a score.
  uint64_t frames_with_layers = 0, frames_with_energy_fallback = 0, frames_without_scores = 0;
  uint64_t cells_scored = 0, cells_without_score = 0;

 private:
  struct Sample {
    float score;
    bool positive;
  };
  /// Samples of one score (after coarsening), highest score first in PerClass::groups.
  struct Group {
    float score;
    uint64_t pos, neg;
  };
  struct PerClass {
    std::vector<Sample> recent;  ///< not yet merged into groups
    std::vector<Group> groups;   ///< exact unless bits_dropped > 0
    int bits_dropped = 0;
    uint64_t count = 0, predicted_pos = 0, predicted_neg = 0;
  };
  /// Merges `recent` into `groups`, coarsening while there are more than kMaxGroups.
  static void compact(PerClass& pc);
  /// `pc`'s groups with its recent samples merged in, without changing it.
  static std::vector<Group> allGroups(const PerClass& pc);
  LabelSet labels_;
  std::vector<PerClass> per_class_;  // [LabelId]
};

/// Area under an ROC curve given as samples; the same number RocCurve::auc holds. Exposed for
/// tests: `scores` and `positive` have equal length.
double rocAuc(const std::vector<float>& scores, const std::vector<bool>& positive);

/// CSV: class,threshold,fpr,tpr,tp,fp,positives,negatives (one row per curve point). A `run`
/// column is prepended when `run` is not empty.
std::string rocCsv(const std::vector<RocCurve>& curves, const std::string& run = "");

/// Self-contained SVG plot: axes FPR/TPR in [0, 1] with a 0.1 grid, the chance diagonal, one
/// polyline per curve in its class colour, the operating point as a dot, a legend with AUCs.
std::string rocSvg(const std::vector<RocCurve>& curves, const LabelSet& labels,
                   const std::string& title);

/// JSON array of the curves' summaries (class, positives, negatives, auc, operating point) —
/// not the points, which are in the CSV. Undefined numbers are null.
std::string rocSummaryJson(const std::vector<RocCurve>& curves);

}  // namespace terramrf
