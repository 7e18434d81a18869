// Known-answer tests of the paper 001 §VI-B evaluation rules on hand-made 2×2 grids. Every
// expected number is derived by hand in the comments, not computed by the code under test.
#include "terramrf/evaluation.hpp"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <string>

#include "terramrf/errors.hpp"

namespace terramrf {
namespace {

using labels::kObstacle;
using labels::kRoad;
using labels::kRough;
using labels::kUnknown;

// size 1 m, cell 0.5 m → 2×2 cells, origin (−0.5, −0.5). Row grows with x, column with y:
// cell 0 = (row 0, col 0), 1 = (0, 1), 2 = (1, 0), 3 = (1, 1).
GridGeometry tinyGeometry(double cell_m = 0.5) {
  GridGeometry g;
  g.size_m = 2 * cell_m;
  g.cell_m = cell_m;
  return g;
}

struct Scene {
  Frame frame;
  TerrainGrid grid;
  explicit Scene(const std::string& id = "f0", double cell_m = 0.5) : grid(tinyGeometry(cell_m)) {
    frame.id = id;
  }
  /// Adds `n` points with ground truth `label` at the centre of `cell` (−1: outside the grid).
  void add(int cell, LabelId label, int n = 1) {
    const GridGeometry& g = grid.geometry();
    double x = 50, y = 50;
    if (cell >= 0) {
      const Eigen::Vector2d c = g.cellCentre(cell / 2, cell % 2);
      x = c.x();
      y = c.y();
    }
    for (int i = 0; i < n; ++i) {
      frame.points.push_back(static_cast<float>(x), static_cast<float>(y), 0.f, 0.f);
      frame.truth.label.push_back(label);
      frame.truth.raw.push_back(label);
    }
  }
  void predict(int cell, LabelId label) { grid.labels()[cell] = label; }
  /// Bins the points; call after the last add().
  const TerrainGrid& binned() {
    grid.binPoints(frame.points);
    return grid;
  }
};

TEST(ClassScores, RatiosAndUndefinedValues) {
  ClassScores s{6, 2, 3, 9};
  EXPECT_DOUBLE_EQ(s.precision(), 6.0 / 8.0);  // 6/(6+2)
  EXPECT_DOUBLE_EQ(s.recall(), 6.0 / 9.0);     // 6/(6+3)
  EXPECT_DOUBLE_EQ(s.tpr(), 6.0 / 9.0);
  EXPECT_DOUBLE_EQ(s.fpr(), 2.0 / 11.0);  // 2/(2+9)
  EXPECT_DOUBLE_EQ(s.f1(), 12.0 / 17.0);  // 2·6/(2·6+2+3)
  ClassScores none{};
  EXPECT_TRUE(std::isnan(none.precision()));
  EXPECT_TRUE(std::isnan(none.recall()));
  EXPECT_TRUE(std::isnan(none.fpr()));
  EXPECT_TRUE(std::isnan(none.f1()));
}

TEST(ClassScores, WilsonIntervalsHaveTheTextbookValues) {
  // Wilson (1927), z = 1.96: 50 of 100 → [0.4038, 0.5962]; 10 of 10 → [0.7225, 1].
  const Interval half = wilsonInterval(50, 100);
  EXPECT_NEAR(half.lo, 0.4038, 1e-4);
  EXPECT_NEAR(half.hi, 0.5962, 1e-4);
  const Interval all = wilsonInterval(10, 10);
  EXPECT_NEAR(all.lo, 0.7225, 1e-4);
  EXPECT_DOUBLE_EQ(all.hi, 1.0);
  EXPECT_DOUBLE_EQ(wilsonInterval(0, 10).lo, 0.0);  // not empty at 0 successes
  EXPECT_GT(wilsonInterval(0, 10).hi, 0.2);
  EXPECT_TRUE(std::isnan(wilsonInterval(0, 0).lo));
  // Narrower with more cells, around the same proportion.
  const Interval many = wilsonInterval(970, 1000);
  EXPECT_LT(many.hi - many.lo, wilsonInterval(97, 100).hi - wilsonInterval(97, 100).lo);
  const ClassScores s{6, 2, 3, 9};
  EXPECT_DOUBLE_EQ(s.precisionCi95().lo, wilsonInterval(6, 8).lo);
  EXPECT_DOUBLE_EQ(s.recallCi95().hi, wilsonInterval(6, 9).hi);
}

TEST(ClusteredProportion, EqualAllOrNothingClustersCountAsOneTrialLessThanTheirNumber) {
  // 10 cells of 100 points each, 7 cells all right and 3 all wrong: p̂ = 0.7, Σ(a − p̂n)² =
  // 7·30² + 3·70² = 21000, var = 10/9 · 21000 / 1000² = 0.02333…, n_eff = 0.21 / var = 9.
  ClusteredProportion c;
  for (int i = 0; i < 10; ++i) c.add(i < 7 ? 100 : 0, 100);
  EXPECT_DOUBLE_EQ(c.a, 700);
  EXPECT_DOUBLE_EQ(c.n, 1000);
  EXPECT_NEAR(c.effectiveTrials(), 9.0, 1e-9);
  EXPECT_NEAR(c.ci95().lo, wilsonIntervalOf(0.7, 9).lo, 1e-12);
  // Wilson over the 1000 points would be [0.671, 0.727]; nine trials give [0.40, 0.89].
  EXPECT_LT(c.ci95().lo, 0.45);
  EXPECT_GT(c.ci95().hi, 0.85);
  // Points that vary within their cells like independent trials keep their number: 200 cells
  // of 5 points, each cell 3 or 4 successes alternately (within-cell spread, none between
  // the pairs): n_eff is capped at the points.
  ClusteredProportion mixed;
  for (int i = 0; i < 200; ++i) mixed.add(i % 2 ? 3 : 4, 5);
  EXPECT_GT(mixed.effectiveTrials(), 999.0);
  // All successes: as many trials as cells, all won; none: undefined.
  ClusteredProportion all;
  for (int i = 0; i < 4; ++i) all.add(50, 50);
  EXPECT_DOUBLE_EQ(all.effectiveTrials(), 4.0);
  EXPECT_NEAR(all.ci95().lo, wilsonInterval(4, 4).lo, 1e-12);
  EXPECT_TRUE(std::isnan(ClusteredProportion{}.ci95().lo));
  // Sums merge across frames.
  ClusteredProportion half1, half2;
  for (int i = 0; i < 5; ++i) half1.add(i < 4 ? 100 : 0, 100);
  for (int i = 0; i < 5; ++i) half2.add(i < 3 ? 100 : 0, 100);
  half1 += half2;
  EXPECT_NEAR(half1.effectiveTrials(), 9.0, 1e-9);
}

TEST(ConfusionMatrix, OneVsRestCounts) {
  ConfusionMatrix m(4);
  m.add(kRoad, kRoad, 10);
  m.add(kRoad, kRough, 2);
  m.add(kRough, kRoad, 3);
  m.add(kRough, kRough, 5);
  m.add(kObstacle, kUnknown, 4);
  m.add(kObstacle, kObstacle, 7);
  // total 31. road: TP 10, FP 3 (rough→road), FN 2, TN 31−15 = 16.
  const ClassScores road = m.scores(kRoad);
  EXPECT_EQ(road.tp, 10u);
  EXPECT_EQ(road.fp, 3u);
  EXPECT_EQ(road.fn, 2u);
  EXPECT_EQ(road.tn, 16u);
  // obstacle: TP 7, FP 0, FN 4 (unclassified), TN 31−11 = 20.
  const ClassScores obs = m.scores(kObstacle);
  EXPECT_EQ(obs.tp, 7u);
  EXPECT_EQ(obs.fp, 0u);
  EXPECT_EQ(obs.fn, 4u);
  EXPECT_EQ(obs.tn, 20u);
  EXPECT_EQ(m.total(), 31u);
  ConfusionMatrix other(3);
  EXPECT_THROW(m += other, std::invalid_argument);
}

// Cell 0: 1 obstacle + 3 road points, predicted obstacle.
// Cell 1: 1 obstacle + 3 road points, predicted road.
// cellTruth on hand-made per-class counts (index = LabelId: unknown, road, rough, obstacle).
TEST(CellTruth, KnownAnswers) {
  const int obst = kObstacle;
  // No labelled point (unknown truth only): not scored.
  CellTruth t = cellTruth({5, 0, 0, 0}, obst, kRoad);
  EXPECT_EQ(t.label, kUnknown);
  EXPECT_EQ(t.labelled, 0u);
  // Majority; unknown-truth points neither count nor win.
  t = cellTruth({9, 1, 3, 0}, obst, kRoad);
  EXPECT_EQ(t.label, kRough);
  EXPECT_EQ(t.labelled, 4u);
  EXPECT_FALSE(t.tied);
  EXPECT_FALSE(t.obstacle_rule);
  // One obstacle point makes the cell obstacle, whatever is predicted; counted as the rule.
  t = cellTruth({0, 5, 0, 1}, obst, kRoad);
  EXPECT_EQ(t.label, kObstacle);
  EXPECT_TRUE(t.obstacle_rule);
  EXPECT_FALSE(t.tied);
  // Obstacle tied for the majority: obstacle, but neither the rule nor the tie decided.
  t = cellTruth({0, 2, 0, 2}, obst, kRoad);
  EXPECT_EQ(t.label, kObstacle);
  EXPECT_FALSE(t.obstacle_rule);
  EXPECT_FALSE(t.tied);
  // Tie without obstacle points: the predicted class if it is tied...
  t = cellTruth({0, 2, 2, 0}, obst, kRoad);
  EXPECT_EQ(t.label, kRoad);
  EXPECT_TRUE(t.tied);
  // ...else the tied class with the highest id.
  t = cellTruth({0, 2, 2, 0}, obst, kObstacle);
  EXPECT_EQ(t.label, kRough);
  EXPECT_TRUE(t.tied);
  t = cellTruth({0, 2, 2, 0}, obst, kUnknown);
  EXPECT_EQ(t.label, kRough);
  // Without an obstacle class (-1) an obstacle-id point is just a vote.
  t = cellTruth({0, 5, 0, 1}, -1, kRoad);
  EXPECT_EQ(t.label, kRoad);
  EXPECT_FALSE(t.obstacle_rule);
}

TEST(Evaluator, ObstacleAnyRuleAndExcusedPoints) {
  Scene s;
  s.add(0, kObstacle);
  s.add(0, kRoad, 3);
  s.add(1, kObstacle);
  s.add(1, kRoad, 3);
  s.predict(0, kObstacle);
  s.predict(1, kRoad);
  Evaluator ev(LabelSet::defaults());
  const EvalCounts c = ev.addFrame(s.binned(), s.frame);

  // Cell-wise: both cells are truly obstacle (one GT obstacle point suffices although road has
  // the majority): (obstacle, obstacle) and (obstacle, road).
  EXPECT_EQ(c.cells_scored, 2u);
  EXPECT_EQ(c.cells_obstacle_rule, 2u);
  EXPECT_EQ(c.cell_wise.at(kObstacle, kObstacle), 1u);
  EXPECT_EQ(c.cell_wise.at(kObstacle, kRoad), 1u);
  EXPECT_EQ(c.cell_wise.total(), 2u);
  // Point-wise: cell 0 → obstacle point TP, 3 road points excused ("not considered a FP" of
  // obstacle, but missed as road, as paper 001's tables count them: their FN exceed their FP by
  // about the points in such cells). Cell 1 → obstacle point (obstacle, road), 3 road points
  // (road, road). Scored 8.
  EXPECT_EQ(c.excused_points, 3u);
  EXPECT_EQ(c.point_wise.at(kObstacle, kObstacle), 1u);
  EXPECT_EQ(c.point_wise.at(kObstacle, kRoad), 1u);
  EXPECT_EQ(c.point_wise.at(kRoad, kRoad), 3u);
  EXPECT_EQ(c.point_wise.at(kRoad, kObstacle), 0u);
  EXPECT_EQ(c.point_wise.excusedAt(kRoad, kObstacle), 3u);
  EXPECT_EQ(c.point_wise.excusedOf(kRoad), 3u);
  EXPECT_EQ(c.scoredPoints(), 8u);

  // Point-wise obstacle: TP 1, FP 0, FN 1, TN 3 → P 1, R 0.5, FPR 0/3 = 0.
  ClassScores o = c.point_wise.scores(kObstacle);
  EXPECT_EQ(o.tp, 1u);
  EXPECT_EQ(o.fp, 0u);
  EXPECT_EQ(o.fn, 1u);
  EXPECT_EQ(o.tn, 3u);
  EXPECT_DOUBLE_EQ(o.precision(), 1.0);
  EXPECT_DOUBLE_EQ(o.recall(), 0.5);
  EXPECT_DOUBLE_EQ(o.fpr(), 0.0);
  // Point-wise road: TP 3, FP 1, FN 3 (the excused points), TN 1 → P 0.75, R 0.5, FPR 1/2.
  ClassScores r = c.point_wise.scores(kRoad);
  EXPECT_EQ(r.tp, 3u);
  EXPECT_EQ(r.fp, 1u);
  EXPECT_EQ(r.fn, 3u);
  EXPECT_EQ(r.tn, 1u);
  EXPECT_DOUBLE_EQ(r.precision(), 0.75);
  EXPECT_DOUBLE_EQ(r.recall(), 0.5);
  EXPECT_DOUBLE_EQ(r.fpr(), 0.5);
  // Point-wise intervals take the cell as the cluster; their sums are the matrix's counts.
  EXPECT_DOUBLE_EQ(c.point_precision[kRoad].a, 3);  // cell 1: 3 road points right ...
  EXPECT_DOUBLE_EQ(c.point_precision[kRoad].n, 4);  // ... of 4 (the obstacle point): TP + FP
  EXPECT_DOUBLE_EQ(c.point_precision[kRoad].clusters, 1);
  EXPECT_DOUBLE_EQ(c.point_precision[kObstacle].n, 1);  // cell 0: the excused road points are no FP
  EXPECT_DOUBLE_EQ(c.point_recall[kRoad].a, 3);         // TP
  EXPECT_DOUBLE_EQ(c.point_recall[kRoad].n, 6);         // TP + FN (the excused ones)
  EXPECT_DOUBLE_EQ(c.point_recall[kRoad].clusters, 2);
  EXPECT_DOUBLE_EQ(c.point_recall[kObstacle].n, 2);
  EXPECT_DOUBLE_EQ(c.point_recall[kRough].clusters, 0);
  // Road recall 3 of 6 in two all-or-nothing cells of 3: two cells → n_eff 1 (m − 1).
  EXPECT_NEAR(c.point_recall[kRoad].effectiveTrials(), 1.0, 1e-9);
  EXPECT_NEAR(c.ci95(true, kRoad).second.lo, wilsonIntervalOf(0.5, 1).lo, 1e-12);
  EXPECT_NEAR(c.ci95(false, kRoad).first.hi, c.cell_wise.scores(kRoad).precisionCi95().hi, 0);
  // Rough has no point: the excused road points are its true negatives.
  // Summed over the classes, FN exceed FP by the excused points (every other error is one FN
  // and one FP): the identity paper 001's Tables I–III satisfy with the points so excused.
  uint64_t fn = 0, fp = 0;
  for (const LabelId k : {kRoad, kRough, kObstacle}) {
    fn += c.point_wise.scores(k).fn;
    fp += c.point_wise.scores(k).fp;
  }
  EXPECT_EQ(fn - fp, c.excused_points);
  // Rough never occurs: TN 8 (the excused road points too), precision and recall undefined,
  // FPR 0/8 = 0.
  ClassScores g = c.point_wise.scores(kRough);
  EXPECT_EQ(g.tn, 8u);
  EXPECT_TRUE(std::isnan(g.precision()));
  EXPECT_TRUE(std::isnan(g.recall()));
  EXPECT_DOUBLE_EQ(g.fpr(), 0.0);
  // Cell-wise obstacle: TP 1, FN 1, FP 0, TN 0 → FPR 0/0 undefined. Road: FP 1, TN 1 → P 0.
  ClassScores co = c.cell_wise.scores(kObstacle);
  EXPECT_EQ(co.tn, 0u);
  EXPECT_TRUE(std::isnan(co.fpr()));
  EXPECT_DOUBLE_EQ(co.recall(), 0.5);
  ClassScores cr = c.cell_wise.scores(kRoad);
  EXPECT_DOUBLE_EQ(cr.precision(), 0.0);
  EXPECT_TRUE(std::isnan(cr.recall()));
  EXPECT_DOUBLE_EQ(cr.fpr(), 0.5);
}

// An obstacle cell predicted as something else does not excuse anything, and a non-obstacle
// prediction in a cell without GT obstacle points is scored normally.
TEST(Evaluator, ExcuseNeedsBothPredictedAndTrueObstacle) {
  Scene s;
  s.add(0, kRoad, 2);  // predicted obstacle, no GT obstacle point → 2 × (road, obstacle)
  s.predict(0, kObstacle);
  Evaluator ev(LabelSet::defaults());
  const EvalCounts c = ev.addFrame(s.binned(), s.frame);
  EXPECT_EQ(c.excused_points, 0u);
  EXPECT_EQ(c.point_wise.at(kRoad, kObstacle), 2u);
  EXPECT_EQ(c.cell_wise.at(kRoad, kObstacle), 1u);
  EXPECT_EQ(c.cells_obstacle_rule, 0u);
}

// Cell 0: 3 rough + 1 road, predicted road → cell truth rough (majority).
// Cell 3: 2 road + 1 rough, predicted road → cell truth road.
TEST(Evaluator, MajorityRule) {
  Scene s;
  s.add(0, kRough, 3);
  s.add(0, kRoad, 1);
  s.add(3, kRoad, 2);
  s.add(3, kRough, 1);
  s.predict(0, kRoad);
  s.predict(3, kRoad);
  Evaluator ev(LabelSet::defaults());
  const EvalCounts c = ev.addFrame(s.binned(), s.frame);
  EXPECT_EQ(c.cells_scored, 2u);
  EXPECT_EQ(c.cells_tied, 0u);
  EXPECT_EQ(c.cell_wise.at(kRough, kRoad), 1u);
  EXPECT_EQ(c.cell_wise.at(kRoad, kRoad), 1u);
  // Points: (rough, road) 3 + 1 = 4, (road, road) 1 + 2 = 3; no excuses.
  EXPECT_EQ(c.point_wise.at(kRough, kRoad), 4u);
  EXPECT_EQ(c.point_wise.at(kRoad, kRoad), 3u);
  EXPECT_EQ(c.scoredPoints(), 7u);
  // Cell-wise road: TP 1, FP 1 → P 0.5, R 1. Rough: FN 1 → R 0, P undefined.
  EXPECT_DOUBLE_EQ(c.cell_wise.scores(kRoad).precision(), 0.5);
  EXPECT_DOUBLE_EQ(c.cell_wise.scores(kRoad).recall(), 1.0);
  EXPECT_DOUBLE_EQ(c.cell_wise.scores(kRough).recall(), 0.0);
  EXPECT_TRUE(std::isnan(c.cell_wise.scores(kRough).precision()));
}

// Every cell holds as many road as rough points.
// Cell 0: predicted road   → road is among the tied → truth road (TP).
// Cell 1: predicted rough  → truth rough (TP).
// Cell 2: predicted obstacle (not tied) → truth = highest tied id = rough.
// Cell 3: 1 + 1, predicted unknown → truth rough, labelled but unclassified.
TEST(Evaluator, TieRuleAndUnclassifiedCells) {
  Scene s;
  for (int cell = 0; cell < 3; ++cell) {
    s.add(cell, kRoad, 2);
    s.add(cell, kRough, 2);
  }
  s.add(3, kRoad);
  s.add(3, kRough);
  s.predict(0, kRoad);
  s.predict(1, kRough);
  s.predict(2, kObstacle);
  s.predict(3, kUnknown);
  Evaluator ev(LabelSet::defaults());
  const EvalCounts c = ev.addFrame(s.binned(), s.frame);
  EXPECT_EQ(c.cells_tied, 4u);
  EXPECT_EQ(c.cells_scored, 4u);
  EXPECT_EQ(c.cell_wise.at(kRoad, kRoad), 1u);
  EXPECT_EQ(c.cell_wise.at(kRough, kRough), 1u);
  EXPECT_EQ(c.cell_wise.at(kRough, kObstacle), 1u);
  EXPECT_EQ(c.cell_wise.at(kRough, kUnknown), 1u);
  EXPECT_EQ(c.cells_labelled_unclassified, 1u);
  EXPECT_EQ(c.labelled_points_unclassified, 2u);
  // Classified points: cells 0–2, 4 points each = 12 (cell 3 is unknown).
  EXPECT_EQ(c.classified_points, 12u);
  // Points: no GT obstacle anywhere, so nothing is excused.
  EXPECT_EQ(c.excused_points, 0u);
  EXPECT_EQ(c.point_wise.at(kRoad, kRoad), 2u);
  EXPECT_EQ(c.point_wise.at(kRough, kRoad), 2u);
  EXPECT_EQ(c.point_wise.at(kRoad, kRough), 2u);
  EXPECT_EQ(c.point_wise.at(kRough, kRough), 2u);
  EXPECT_EQ(c.point_wise.at(kRoad, kObstacle), 2u);
  EXPECT_EQ(c.point_wise.at(kRough, kObstacle), 2u);
  EXPECT_EQ(c.point_wise.at(kRoad, kUnknown), 1u);
  EXPECT_EQ(c.point_wise.at(kRough, kUnknown), 1u);
  // Cell-wise rough: TP 1, FP 0, FN 2 (obstacle + unclassified), TN 1 → R 1/3.
  const ClassScores rough = c.cell_wise.scores(kRough);
  EXPECT_EQ(rough.fn, 2u);
  EXPECT_EQ(rough.tn, 1u);
  EXPECT_DOUBLE_EQ(rough.recall(), 1.0 / 3.0);
  // Cell-wise obstacle: FP 1, TN 3 → FPR 1/4, precision 0, recall undefined.
  const ClassScores obs = c.cell_wise.scores(kObstacle);
  EXPECT_DOUBLE_EQ(obs.fpr(), 0.25);
  EXPECT_DOUBLE_EQ(obs.precision(), 0.0);
  EXPECT_TRUE(std::isnan(obs.recall()));
}

// Cell 0: 5 unknown + 1 road, predicted road → unknown ignored, truth road, 1 point scored.
// Cell 1: 4 unknown only, predicted rough → not scored, but its points are classified.
// Cell 2: 2 road, predicted unknown → FN, unclassified.
// Outside: 1 road + 1 unknown point → counted, not scored.
TEST(Evaluator, UnknownTruthIgnoredAndOutsidePointsCounted) {
  Scene s;
  s.add(0, kUnknown, 5);
  s.add(0, kRoad, 1);
  s.add(1, kUnknown, 4);
  s.add(2, kRoad, 2);
  s.add(-1, kRoad, 1);
  s.add(-1, kUnknown, 1);
  s.predict(0, kRoad);
  s.predict(1, kRough);
  Evaluator ev(LabelSet::defaults());
  const EvalCounts c = ev.addFrame(s.binned(), s.frame);
  EXPECT_EQ(c.scans, 1u);
  EXPECT_EQ(c.points, 14u);             // 6 + 4 + 2 + 2
  EXPECT_EQ(c.labelled_points, 4u);     // 1 + 2 + 1
  EXPECT_EQ(c.classified_points, 10u);  // cells 0 and 1: 6 + 4
  EXPECT_EQ(c.points_outside_grid, 2u);
  EXPECT_EQ(c.labelled_points_outside_grid, 1u);
  EXPECT_EQ(c.cells_scored, 2u);  // cells 0 and 2
  EXPECT_EQ(c.cells_labelled_unclassified, 1u);
  EXPECT_EQ(c.labelled_points_unclassified, 2u);
  EXPECT_EQ(c.scoredPoints(), 3u);  // 1 in cell 0, 2 in cell 2
  EXPECT_EQ(c.point_wise.at(kRoad, kRoad), 1u);
  EXPECT_EQ(c.point_wise.at(kRoad, kUnknown), 2u);
  EXPECT_EQ(c.cell_wise.at(kRoad, kRoad), 1u);
  EXPECT_EQ(c.cell_wise.at(kRoad, kUnknown), 1u);
  EXPECT_DOUBLE_EQ(c.point_wise.scores(kRoad).recall(), 1.0 / 3.0);
  // Nothing was predicted rough on a scored item: rough FP 0.
  EXPECT_EQ(c.point_wise.scores(kRough).fp, 0u);
  EXPECT_DOUBLE_EQ(c.grid_size_m, 1.0);
  EXPECT_DOUBLE_EQ(c.cell_m, 0.5);
}

TEST(Evaluator, FrameWithoutTruthIsOnlyCounted) {
  Scene s;
  s.add(0, kRoad, 3);
  s.frame.truth = PointLabels{};
  s.predict(0, kRoad);
  Evaluator ev(LabelSet::defaults());
  const EvalCounts c = ev.addFrame(s.binned(), s.frame);
  EXPECT_EQ(c.frames_without_truth, 1u);
  EXPECT_EQ(c.scans, 0u);
  EXPECT_EQ(c.points, 0u);
  EXPECT_EQ(ev.total().frames_without_truth, 1u);
  EXPECT_EQ(ev.total().point_wise.total(), 0u);
}

TEST(Evaluator, AccumulationIsTheSumOfFrames) {
  Evaluator ev(LabelSet::defaults());
  // Frame a: cell 0 = 2 road predicted road; cell 1 = 1 obstacle + 1 rough predicted obstacle.
  Scene a("a");
  a.add(0, kRoad, 2);
  a.add(1, kObstacle);
  a.add(1, kRough);
  a.predict(0, kRoad);
  a.predict(1, kObstacle);
  const EvalCounts ca = ev.addFrame(a.binned(), a.frame);
  // Frame b: cell 0 = 3 road predicted rough; 1 rough outside.
  Scene b("b");
  b.add(0, kRoad, 3);
  b.add(-1, kRough);
  b.predict(0, kRough);
  const EvalCounts cb = ev.addFrame(b.binned(), b.frame);

  const EvalCounts& t = ev.total();
  EXPECT_EQ(t.scans, 2u);
  EXPECT_EQ(t.points, 8u);  // 4 + 4
  EXPECT_EQ(t.labelled_points, 8u);
  EXPECT_EQ(t.classified_points, 7u);  // 4 + 3
  EXPECT_EQ(t.points_outside_grid, 1u);
  EXPECT_EQ(t.excused_points, 1u);  // the rough point of frame a
  EXPECT_EQ(t.cells_scored, 3u);
  // Points: (road, road) 2, (obstacle, obstacle) 1, (road, rough) 3.
  EXPECT_EQ(t.point_wise.at(kRoad, kRoad), 2u);
  EXPECT_EQ(t.point_wise.at(kObstacle, kObstacle), 1u);
  EXPECT_EQ(t.point_wise.at(kRoad, kRough), 3u);
  EXPECT_EQ(t.point_wise.excusedAt(kRough, kObstacle), 1u);
  EXPECT_EQ(t.point_wise.total(), 7u);  // the excused point included
  // Cells: (road, road), (obstacle, obstacle), (road, rough).
  EXPECT_EQ(t.cell_wise.at(kRoad, kRough), 1u);
  EXPECT_EQ(t.cell_wise.total(), 3u);
  // Road point-wise over both: TP 2, FN 3 → recall 0.4.
  EXPECT_DOUBLE_EQ(t.point_wise.scores(kRoad).recall(), 0.4);

  EvalCounts sum(LabelSet::defaults().size());
  sum += ca;
  sum += cb;
  EXPECT_EQ(sum.point_wise, t.point_wise);
  EXPECT_EQ(sum.cell_wise, t.cell_wise);
  EXPECT_EQ(sum.points, t.points);
  EXPECT_DOUBLE_EQ(t.cell_m, 0.5);

  // A frame on another grid makes the geometry "mixed" (NaN).
  Scene c("c", 0.25);
  c.add(0, kRoad);
  c.predict(0, kRoad);
  ev.addFrame(c.binned(), c.frame);
  EXPECT_TRUE(std::isnan(ev.total().cell_m));
  EXPECT_TRUE(std::isnan(ev.total().grid_size_m));
}

TEST(Evaluator, LabelSetWithoutObstacleUsesMajorityOnly) {
  LabelSet ls({{"unknown", {0, 0, 0}}, {"ground", {1, 1, 1}}, {"wall", {2, 2, 2}}});
  Scene s;
  s.add(0, 1, 2);
  s.add(0, 2, 1);
  s.predict(0, 2);
  Evaluator ev(ls);
  const EvalCounts c = ev.addFrame(s.binned(), s.frame);
  EXPECT_EQ(c.cell_wise.at(1, 2), 1u);  // majority ground
  EXPECT_EQ(c.point_wise.at(1, 2), 2u);
  EXPECT_EQ(c.point_wise.at(2, 2), 1u);
  EXPECT_EQ(c.excused_points, 0u);
}

// A set of five classes with obstacle not last (ids: 1 road, 2 obstacle, 3 sidewalk, 4 rough):
// the obstacle rule follows the name, the majority is a plurality among three non-obstacle
// classes, and the tie rule's "highest id" is the id, not the position of obstacle.
TEST(Evaluator, OwnLabelSetWithObstacleInTheMiddle) {
  LabelSet ls({{"unknown", {0, 0, 0}},
               {"road", {1, 1, 1}},
               {"obstacle", {2, 2, 2}},
               {"sidewalk", {3, 3, 3}},
               {"rough", {4, 4, 4}}});
  ASSERT_EQ(ls.obstacle(), 2);
  Scene s;
  // Cell 0: 2 road, 3 sidewalk, 1 rough → plurality sidewalk (3 of 6, not a majority); predicted
  // sidewalk.
  s.add(0, 1, 2);
  s.add(0, 3, 3);
  s.add(0, 4, 1);
  s.predict(0, 3);
  // Cell 1: 4 rough, 1 obstacle → obstacle by the rule; predicted rough.
  s.add(1, 4, 4);
  s.add(1, 2, 1);
  s.predict(1, 4);
  // Cell 2: 2 road, 2 rough, predicted sidewalk → tie between road (1) and rough (4), the
  // predicted class is not among them: the higher id, rough.
  s.add(2, 1, 2);
  s.add(2, 4, 2);
  s.predict(2, 3);
  // Cell 3: 3 sidewalk and 1 obstacle point, predicted obstacle → obstacle; the sidewalk points
  // are excused.
  s.add(3, 3, 3);
  s.add(3, 2, 1);
  s.predict(3, 2);
  Evaluator ev(ls);
  const EvalCounts c = ev.addFrame(s.binned(), s.frame);
  EXPECT_EQ(c.cell_wise.at(3, 3), 1u);
  EXPECT_EQ(c.cell_wise.at(2, 4), 1u);
  EXPECT_EQ(c.cell_wise.at(4, 3), 1u);
  EXPECT_EQ(c.cell_wise.at(2, 2), 1u);
  EXPECT_EQ(c.cells_obstacle_rule, 2u);
  EXPECT_EQ(c.cells_tied, 1u);
  EXPECT_EQ(c.excused_points, 3u);
  EXPECT_EQ(c.point_wise.excusedAt(3, 2), 3u);
  // Point-wise sidewalk: TP 3 (cell 0), FP 2 + 1 (cell 0's road and rough) + 4 (cell 2), FN 3
  // (cell 3's excused points).
  const ClassScores sw = c.point_wise.scores(3);
  EXPECT_EQ(sw.tp, 3u);
  EXPECT_EQ(sw.fp, 7u);
  EXPECT_EQ(sw.fn, 3u);
  // Cell-wise obstacle: TP 1 (cell 3), FN 1 (cell 1), no FP.
  const ClassScores ob = c.cell_wise.scores(2);
  EXPECT_EQ(ob.tp, 1u);
  EXPECT_EQ(ob.fn, 1u);
  EXPECT_EQ(ob.fp, 0u);
}

// Obstacle points in a cell left unclassified: the cell is a missed obstacle (FN), and every
// labelled point in it is a false negative of its class, none a false positive of anything.
TEST(Evaluator, ObstaclePointsInAnUnclassifiedCellAreMissed) {
  Scene s;
  s.add(0, kObstacle, 2);
  s.add(0, kRoad, 5);
  s.predict(0, kUnknown);
  Evaluator ev(LabelSet::defaults());
  const EvalCounts c = ev.addFrame(s.binned(), s.frame);
  EXPECT_EQ(c.cells_scored, 1u);
  EXPECT_EQ(c.cells_labelled_unclassified, 1u);
  EXPECT_EQ(c.cell_wise.at(kObstacle, kUnknown), 1u);
  EXPECT_EQ(c.cell_wise.scores(kObstacle).fn, 1u);
  EXPECT_EQ(c.point_wise.scores(kObstacle).fn, 2u);
  EXPECT_EQ(c.point_wise.scores(kRoad).fn, 5u);
  EXPECT_EQ(c.excused_points, 0u);  // nothing is excused without an obstacle prediction
  for (const LabelId k : {kRoad, kRough, kObstacle}) EXPECT_EQ(c.point_wise.scores(k).fp, 0u);
  EXPECT_EQ(c.labelled_points_unclassified, 7u);
  EXPECT_EQ(c.classified_points, 0u);
  EXPECT_DOUBLE_EQ(c.point_precision[kObstacle].clusters, 0);  // no obstacle prediction
}

TEST(Evaluator, BadFramesThrowNamingTheFrameAndLeaveTotalsAlone) {
  Evaluator ev(LabelSet::defaults());
  Scene good("good");
  good.add(0, kRoad);
  good.predict(0, kRoad);
  ev.addFrame(good.binned(), good.frame);

  Scene s("000042");
  s.add(0, kRoad, 3);
  s.binned();
  s.frame.truth.label.pop_back();  // 2 labels for 3 points
  try {
    ev.addFrame(s.grid, s.frame);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("000042"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("2 labels for 3 points"), std::string::npos) << e.what();
  }

  Scene bad_id("bad_id");
  bad_id.add(0, 9);  // not a class of the default set
  EXPECT_THROW(ev.addFrame(bad_id.binned(), bad_id.frame), InputError);

  Scene unbinned("unbinned");
  unbinned.add(0, kRoad);  // grid never binned
  EXPECT_THROW(ev.addFrame(unbinned.grid, unbinned.frame), InputError);

  Scene bad_pred("bad_pred");
  bad_pred.add(0, kRoad);
  bad_pred.predict(1, 7);
  EXPECT_THROW(ev.addFrame(bad_pred.binned(), bad_pred.frame), InputError);

  EXPECT_EQ(ev.total().scans, 1u);
  EXPECT_EQ(ev.total().points, 1u);
  EXPECT_EQ(ev.total().point_wise.total(), 1u);
}

TEST(EvalRules, Names) {
  EXPECT_EQ(evalRulesFromString("paper001"), EvalRules::kPaper001);
  EXPECT_STREQ(toString(EvalRules::kPaper001), "paper001");
  EXPECT_THROW(evalRulesFromString("paper000"), std::invalid_argument);
}

TEST(EvaluationJson, ParsesBackWithTheHandDerivedValues) {
  // Same scene as ObstacleAnyRuleAndExcusedPoints; one label name needs escaping.
  LabelSet ls({{"unknown", {0, 0, 0}},
               {"ro\"ad\\x", {1, 1, 1}},
               {"rough", {2, 2, 2}},
               {"obstacle", {3, 3, 3}}});
  Scene s("fr\"1");
  s.add(0, kObstacle);
  s.add(0, kRoad, 3);
  s.add(1, kObstacle);
  s.add(1, kRoad, 3);
  s.add(-1, kRough);
  s.predict(0, kObstacle);
  s.predict(1, kRoad);
  Evaluator ev(ls);
  const EvalCounts c = ev.addFrame(s.binned(), s.frame);
  const std::string json = toJson(c, ls, EvalRules::kPaper001, s.frame.id);

  const YAML::Node n = YAML::Load(json);
  EXPECT_EQ(n["schema"].as<std::string>(), "terramrf.evaluation/1");
  EXPECT_EQ(n["frame"].as<std::string>(), "fr\"1");
  EXPECT_EQ(n["rules"].as<std::string>(), "paper001");
  EXPECT_EQ(n["tie_rule"].as<std::string>(), kTieRule);
  ASSERT_EQ(n["labels"].size(), 4u);
  EXPECT_EQ(n["labels"][1].as<std::string>(), "ro\"ad\\x");
  const YAML::Node k = n["counts"];
  EXPECT_EQ(k["scans"].as<int>(), 1);
  EXPECT_EQ(k["points"].as<int>(), 9);
  EXPECT_EQ(k["labelled_points"].as<int>(), 9);
  EXPECT_EQ(k["classified_points"].as<int>(), 8);
  EXPECT_EQ(k["points_outside_grid"].as<int>(), 1);
  EXPECT_EQ(k["excused_points"].as<int>(), 3);
  EXPECT_EQ(k["scored_points"].as<int>(), 8);  // the excused points included
  EXPECT_EQ(k["cells_scored"].as<int>(), 2);
  EXPECT_DOUBLE_EQ(k["grid_size_m"].as<double>(), 1.0);
  EXPECT_DOUBLE_EQ(k["cell_m"].as<double>(), 0.5);

  const YAML::Node pw = n["point_wise"]["classes"];
  ASSERT_EQ(pw.size(), 3u);  // road, rough, obstacle
  EXPECT_EQ(pw[0]["id"].as<int>(), 1);
  EXPECT_EQ(pw[0]["tp"].as<int>(), 3);
  EXPECT_EQ(pw[0]["fp"].as<int>(), 1);
  EXPECT_EQ(pw[0]["fn"].as<int>(), 3);  // the excused road points
  EXPECT_DOUBLE_EQ(pw[0]["precision"].as<double>(), 0.75);
  EXPECT_DOUBLE_EQ(pw[0]["recall"].as<double>(), 0.5);
  EXPECT_DOUBLE_EQ(pw[0]["fpr"].as<double>(), 0.5);
  EXPECT_EQ(pw[1]["name"].as<std::string>(), "rough");
  EXPECT_TRUE(pw[1]["precision"].IsNull());  // 0/0
  EXPECT_TRUE(pw[1]["recall"].IsNull());
  EXPECT_DOUBLE_EQ(pw[2]["recall"].as<double>(), 0.5);
  EXPECT_DOUBLE_EQ(pw[2]["tpr"].as<double>(), 0.5);
  const YAML::Node cw = n["cell_wise"]["classes"];
  EXPECT_TRUE(cw[2]["fpr"].IsNull());  // obstacle cells: FP 0, TN 0
  // Confusion [true][predicted]: point-wise obstacle row = [0, 1, 0, 1].
  const YAML::Node pm = n["point_wise"]["confusion"];
  ASSERT_EQ(pm.size(), 4u);
  EXPECT_EQ(pm[3][1].as<int>(), 1);
  EXPECT_EQ(pm[3][3].as<int>(), 1);
  EXPECT_EQ(pm[1][1].as<int>(), 3);
  EXPECT_EQ(pm[0][0].as<int>(), 0);
  EXPECT_EQ(n["cell_wise"]["confusion"][3][1].as<int>(), 1);
  // Excused points per true class, beside the matrix: the 3 road points.
  const YAML::Node px = n["point_wise"]["excused"];
  ASSERT_EQ(px.size(), 4u);
  EXPECT_EQ(px[1].as<int>(), 3);
  EXPECT_EQ(px[3].as<int>(), 0);
  EXPECT_EQ(n["cell_wise"]["excused"][1].as<int>(), 0);
}

TEST(EvaluationTable, ShapedLikePaper001) {
  Scene s;
  s.add(0, kRoad, 1234);
  s.add(1, kObstacle);
  s.predict(0, kRoad);
  s.predict(1, kObstacle);
  Evaluator ev(LabelSet::defaults());
  ev.addFrame(s.binned(), s.frame);
  const std::string t = toTable(ev.total(), LabelSet::defaults());
  EXPECT_NE(t.find("| Number of scans | 1 | 3D points [No.] | 1,235 |"), std::string::npos) << t;
  EXPECT_NE(t.find("| Grid size [m×m] | 1×1 | Annotated points [No.] | 1,235 |"), std::string::npos)
      << t;
  EXPECT_NE(t.find("| Cell size [m×m] | 0.5×0.5 | Classified points [No.] | 1,235 |"),
            std::string::npos)
      << t;
  // Point-wise road: TP 1234, FP 0, FN 0, TN 1 → P 1, R 1, TPR 1, FPR 0.
  EXPECT_NE(t.find("| road | 1,234 | 0 | 0 | 1.000 | 1.000 | 1.000 | 0.000 |"), std::string::npos)
      << t;
  // Rough never occurs: undefined ratios shown as "–".
  EXPECT_NE(t.find("| rough | 0 | 0 | 0 | – | – | – | 0.000 |"), std::string::npos) << t;
  // Obstacle rows come first, as in the paper.
  EXPECT_LT(t.find("| obstacle |"), t.find("| road |"));
  EXPECT_NE(t.find("Tie rule"), std::string::npos);
}

}  // namespace
}  // namespace terramrf
