// ROC accumulation and AUC on hand-made scores with known answers, the scored cells and their
// truth against the Evaluator, and the local-energy fallback.
#include "terramrf/roc.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <map>
#include <random>

#include "terramrf/evaluation.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {
namespace {

TEST(RocAuc, PerfectSeparationIsOne) {
  EXPECT_DOUBLE_EQ(rocAuc({0.9f, 0.8f, 0.3f, 0.1f}, {true, true, false, false}), 1.0);
}

TEST(RocAuc, ReversedIsZero) {
  EXPECT_DOUBLE_EQ(rocAuc({0.9f, 0.8f, 0.3f, 0.1f}, {false, false, true, true}), 0.0);
}

TEST(RocAuc, AllTiedIsHalf) {
  EXPECT_DOUBLE_EQ(rocAuc({0.5f, 0.5f, 0.5f, 0.5f}, {true, false, true, false}), 0.5);
}

TEST(RocAuc, TiesEarnHalfCredit) {
  // Positives {0.9, 0.5}, negatives {0.5, 0.1}: 3 of 4 pairs ordered, 1 tied → 3.5 / 4.
  EXPECT_DOUBLE_EQ(rocAuc({0.9f, 0.5f, 0.5f, 0.1f}, {true, true, false, false}), 0.875);
}

TEST(RocAuc, UndefinedWithoutNegatives) {
  EXPECT_TRUE(std::isnan(rocAuc({0.1f, 0.2f}, {true, true})));
}

TEST(RocCurve, PointsOfAPerfectSeparation) {
  RocAccumulator acc(LabelSet::defaults());
  acc.add(labels::kRoad, 0.9f, true, true);
  acc.add(labels::kRoad, 0.8f, true, true);
  acc.add(labels::kRoad, 0.3f, false, false);
  acc.add(labels::kRoad, 0.1f, false, true);
  const RocCurve c = acc.curve(labels::kRoad);
  EXPECT_EQ(c.class_name, "road");
  EXPECT_EQ(c.positives, 2u);
  EXPECT_EQ(c.negatives, 2u);
  EXPECT_DOUBLE_EQ(c.auc, 1.0);
  ASSERT_EQ(c.points.size(), 5u);
  const double fpr[] = {0, 0, 0, 0.5, 1}, tpr[] = {0, 0.5, 1, 1, 1};
  for (int i = 0; i < 5; ++i) {
    EXPECT_DOUBLE_EQ(c.points[i].fpr, fpr[i]) << i;
    EXPECT_DOUBLE_EQ(c.points[i].tpr, tpr[i]) << i;
  }
  EXPECT_TRUE(std::isinf(c.points[0].threshold));
  // The hard labelling called both positives and one negative road.
  EXPECT_DOUBLE_EQ(c.operating_tpr, 1.0);
  EXPECT_DOUBLE_EQ(c.operating_fpr, 0.5);
}

TEST(RocCurve, TiedScoresAreOneDiagonalStep) {
  RocAccumulator acc(LabelSet::defaults());
  for (int i = 0; i < 3; ++i) acc.add(labels::kRough, 0.5f, true, false);
  for (int i = 0; i < 3; ++i) acc.add(labels::kRough, 0.5f, false, false);
  const RocCurve c = acc.curve(labels::kRough);
  ASSERT_EQ(c.points.size(), 2u);  // (0,0) → (1,1) in one step
  EXPECT_DOUBLE_EQ(c.points[1].fpr, 1.0);
  EXPECT_DOUBLE_EQ(c.points[1].tpr, 1.0);
  EXPECT_DOUBLE_EQ(c.auc, 0.5);
}

TEST(RocCurve, ThinningKeepsEndsAndAuc) {
  RocAccumulator acc(LabelSet::defaults());
  std::mt19937 rng(3);
  std::normal_distribution<float> n(0, 1);
  for (int i = 0; i < 2000; ++i)
    acc.add(labels::kObstacle, n(rng) + (i % 2 ? 1.f : 0.f), i % 2, false);
  const RocCurve full = acc.curve(labels::kObstacle);
  const RocCurve thin = acc.curve(labels::kObstacle, 50);
  EXPECT_LE(thin.points.size(), 50u);
  EXPECT_DOUBLE_EQ(thin.auc, full.auc);
  EXPECT_DOUBLE_EQ(thin.points.front().tpr, 0.0);
  EXPECT_DOUBLE_EQ(thin.points.back().tpr, 1.0);
  EXPECT_DOUBLE_EQ(thin.points.back().fpr, 1.0);
  EXPECT_GT(full.auc, 0.7);  // d' = 1 → AUC ≈ 0.76
  EXPECT_LT(full.auc, 0.82);
}

// A 2×2 grid (cells 1 m, grid 2 m, centred at 0): cell of (x, y) = row by x, column by y.
struct Scene {
  Frame frame;
  TerrainGrid grid;
  Scene() {
    GridGeometry g;
    g.size_m = 2;
    g.cell_m = 1;
    grid.reset(g);
  }
  void point(float x, float y, LabelId truth) {
    frame.points.push_back(x, y, 0, 0);
    frame.truth.label.push_back(truth);
  }
  void bin() {
    grid.binPoints(frame.points);
    grid.labels().assign(grid.cells(), labels::kUnknown);
  }
};

// Long runs: samples are merged into groups of equal score every kCompactAt samples. With few
// distinct scores (Gibbs marginals are counts over the sweeps) nothing is lost: the curve and
// the AUC are those of every sample.
TEST(RocAccumulator, MergingSamplesIntoGroupsChangesNothing) {
  RocAccumulator acc(LabelSet::defaults());
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> level(0, 999);
  std::vector<float> scores;
  std::vector<bool> positive;
  std::map<float, std::pair<uint64_t, uint64_t>, std::greater<float>> groups;  // score → pos, neg
  uint64_t op_tp = 0, op_fp = 0;
  const std::size_t n = 2 * RocAccumulator::kCompactAt + 12345;
  for (std::size_t i = 0; i < n; ++i) {
    const int l = level(rng);
    const float s = l / 999.f;
    const bool pos = (rng() % 1000)<static_cast<unsigned>(l), pred = s> 0.5f;
    acc.add(labels::kRoad, s, pos, pred);
    scores.push_back(s);
    positive.push_back(pos);
    ++(pos ? groups[s].first : groups[s].second);
    if (pred) ++(pos ? op_tp : op_fp);
  }
  const RocCurve c = acc.curve(labels::kRoad);
  EXPECT_EQ(c.score_bits_dropped, 0);
  EXPECT_EQ(acc.samples(labels::kRoad), n);
  EXPECT_EQ(c.auc, rocAuc(scores, positive));
  ASSERT_EQ(c.points.size(), groups.size() + 1);
  uint64_t tp = 0, fp = 0;
  std::size_t k = 1;
  for (const auto& [s, pn] : groups) {
    tp += pn.first;
    fp += pn.second;
    EXPECT_EQ(c.points[k].threshold, s);
    EXPECT_EQ(c.points[k].tp, tp);
    EXPECT_EQ(c.points[k].fp, fp);
    ++k;
  }
  EXPECT_EQ(c.positives, tp);
  EXPECT_EQ(c.negatives, fp);
  EXPECT_DOUBLE_EQ(c.operating_tpr, double(op_tp) / tp);
  EXPECT_DOUBLE_EQ(c.operating_fpr, double(op_fp) / fp);
}

// Continuous scores (energy margins) all differ: kept one by one, a long run took 8 bytes per
// scored cell and class without bound. Beyond kMaxGroups groups the scores are coarsened (low
// mantissa bits cleared), so the memory stays bounded; counts stay exact, the AUC moves only by
// the pairs that become ties, and the summary says so.
TEST(RocAccumulator, ContinuousScoresOfALongRunAreCoarsenedNotKeptWithoutBound) {
  RocAccumulator acc(LabelSet::defaults());
  std::mt19937 rng(4);
  std::normal_distribution<float> noise(0.f, 1.f);
  std::vector<float> scores;
  std::vector<bool> positive;
  const std::size_t n = 2 * RocAccumulator::kCompactAt;
  uint64_t pos_n = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const bool pos = rng() % 3 == 0;
    const float s = noise(rng) + (pos ? 1.5f : 0.f);
    acc.add(labels::kObstacle, s, pos, s > 0.75f);
    scores.push_back(s);
    positive.push_back(pos);
    pos_n += pos;
  }
  const RocCurve c = acc.curve(labels::kObstacle);
  EXPECT_GT(c.score_bits_dropped, 0);
  EXPECT_LE(c.points.size(), RocAccumulator::kMaxGroups + 1);
  EXPECT_EQ(c.positives, pos_n);
  EXPECT_EQ(c.negatives, n - pos_n);
  EXPECT_NEAR(c.auc, rocAuc(scores, positive), 1e-4);
  EXPECT_GT(c.auc, 0.8);
  EXPECT_NE(
      rocSummaryJson({c}).find("\"score_bits_dropped\": " + std::to_string(c.score_bits_dropped)),
      std::string::npos);
}

TEST(RocAccumulator, CellTruthFollowsPaper001AndScoresComeFromLayers) {
  Scene s;
  // cell 0 (x<0, y<0): road, road, obstacle → truth obstacle (one obstacle point suffices)
  s.point(-0.5f, -0.5f, labels::kRoad);
  s.point(-0.6f, -0.5f, labels::kRoad);
  s.point(-0.7f, -0.5f, labels::kObstacle);
  // cell 1 (x<0, y>0): road ×2, rough → road
  s.point(-0.5f, 0.5f, labels::kRoad);
  s.point(-0.5f, 0.6f, labels::kRoad);
  s.point(-0.5f, 0.7f, labels::kRough);
  // cell 2 (x>0, y<0): unknown only → not scored
  s.point(0.5f, -0.5f, labels::kUnknown);
  // cell 3 (x>0, y>0): road, rough tie → predicted class (rough) wins the tie
  s.point(0.5f, 0.5f, labels::kRoad);
  s.point(0.5f, 0.6f, labels::kRough);
  s.bin();
  s.grid.labels() = {labels::kObstacle, labels::kRoad, labels::kRoad, labels::kRough};
  Layer& road = s.grid.add(layers::score("road"));
  road = {0.1f, 0.9f, 0.5f, 0.4f};
  Layer& obst = s.grid.add(layers::score("obstacle"));
  obst = {0.8f, 0.2f, 0.5f, kNoData};  // cell 3 unscored for obstacle

  RocAccumulator acc(LabelSet::defaults());
  const RocFrameStats st = acc.addFrame(s.grid, s.frame, nullptr);
  EXPECT_EQ(st.source, ScoreSource::kScoreLayers);
  EXPECT_EQ(st.cells_scored, 3u);
  EXPECT_EQ(st.cells_without_score, 0u);
  EXPECT_EQ(acc.samples(labels::kRoad), 3u);
  EXPECT_EQ(acc.samples(labels::kObstacle), 2u);
  EXPECT_EQ(acc.samples(labels::kRough), 0u);
  const RocCurve r = acc.curve(labels::kRoad);
  EXPECT_EQ(r.positives, 1u);  // cell 1
  EXPECT_EQ(r.negatives, 2u);  // cells 0 (obstacle) and 3 (rough by the tie rule)
  EXPECT_DOUBLE_EQ(r.auc, 1.0);
  const RocCurve o = acc.curve(labels::kObstacle);
  EXPECT_EQ(o.positives, 1u);
  EXPECT_DOUBLE_EQ(o.auc, 1.0);
  EXPECT_EQ(acc.curves().size(), 2u);
}

TEST(RocAccumulator, FrameWithoutTruthAddsNothingAndBadSizesThrow) {
  Scene s;
  s.point(0.5f, 0.5f, labels::kRoad);
  s.bin();
  RocAccumulator acc(LabelSet::defaults());
  Frame no_truth = s.frame;
  no_truth.truth = {};
  EXPECT_EQ(acc.addFrame(s.grid, no_truth, nullptr).cells_scored, 0u);
  Frame bad = s.frame;
  bad.truth.label.push_back(labels::kRoad);
  EXPECT_THROW(acc.addFrame(s.grid, bad, nullptr), InputError);
  EXPECT_EQ(acc.cells_scored, 0u);
}

TEST(RocAccumulator, ScoresTheEvaluatorsCellsWithItsTruth) {
  // With a score for every class in every cell, each class's positives/negatives are the cells
  // the evaluation scores, split by its cell truth, and the operating point is its cell-wise
  // TPR/FPR: the ROC curves and the evaluation agree on which cells count and what they are.
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> cls(0, 3), few(0, 6);
  const LabelSet ls = LabelSet::defaults();
  int compared = 0;
  for (int trial = 0; trial < 50; ++trial) {
    Scene s;
    for (int cell = 0; cell < 4; ++cell) {
      const float x = cell < 2 ? -0.5f : 0.5f, y = cell % 2 ? 0.5f : -0.5f;
      for (int k = few(rng); k > 0; --k) s.point(x + 0.01f * k, y, static_cast<LabelId>(cls(rng)));
    }
    if (s.frame.points.empty()) continue;
    s.bin();
    for (auto& l : s.grid.labels()) l = static_cast<LabelId>(cls(rng));
    for (std::size_t c = 1; c < ls.size(); ++c)
      s.grid.add(layers::score(ls.name(static_cast<LabelId>(c)))).assign(4, 0.5f);
    Evaluator ev(ls);
    ev.addFrame(s.grid, s.frame);
    RocAccumulator acc(ls);
    const RocFrameStats st = acc.addFrame(s.grid, s.frame, nullptr);
    const EvalCounts& counts = ev.total();
    ASSERT_EQ(st.cells_scored, counts.cells_scored) << "trial " << trial;
    for (std::size_t c = 1; c < ls.size(); ++c) {
      const RocCurve r = acc.curve(static_cast<LabelId>(c));
      const ClassScores cs = counts.cell_wise.scores(static_cast<LabelId>(c));
      ASSERT_EQ(r.positives, cs.tp + cs.fn) << "trial " << trial << " class " << c;
      ASSERT_EQ(r.negatives, cs.fp + cs.tn) << "trial " << trial << " class " << c;
      if (r.positives > 0) {
        EXPECT_DOUBLE_EQ(r.operating_tpr, cs.tpr()) << "trial " << trial;
      }
      if (r.negatives > 0) {
        EXPECT_DOUBLE_EQ(r.operating_fpr, cs.fpr()) << "trial " << trial;
      }
      ++compared;
    }
  }
  EXPECT_GT(compared, 100);
}

TEST(LocalEnergyScores, MarginIsPositiveForTheBestLabel) {
  EnergyModel em;
  em.resize(1, 3, 2);
  em.active = {labels::kRoad, labels::kObstacle};
  em.beta = em.beta_diagonal = 0.5f;
  // cell 0 prefers road strongly, cell 1 mildly obstacle, cell 2 fixed.
  em.unary = {0.f, 4.f, 1.f, 0.f, 0.f, 0.f};
  em.fixed = {0, 0, 1};
  const std::vector<LabelId> labels = {labels::kRoad, labels::kObstacle, labels::kUnknown};
  const auto s = localEnergyScores(em, labels, 4);
  ASSERT_EQ(s.size(), 4u);
  EXPECT_TRUE(s[labels::kUnknown].empty());
  EXPECT_TRUE(s[labels::kRough].empty());
  // Cell 0: E(road) = 0 + 0.5 (neighbour obstacle differs) = 0.5; E(obst) = 4 − 0.5 = 3.5.
  EXPECT_FLOAT_EQ(s[labels::kRoad][0], 3.0f);
  EXPECT_FLOAT_EQ(s[labels::kObstacle][0], -3.0f);
  // Cell 1: E(road) = 1 − 0.5 = 0.5; E(obst) = 0 + 0.5 = 0.5: a tie.
  EXPECT_FLOAT_EQ(s[labels::kRoad][1], 0.0f);
  EXPECT_TRUE(std::isnan(s[labels::kRoad][2]));
}

// The scores are the margins of EnergyModel::localEnergy, to the bit, on grids with fixed cells
// (skipped as neighbours), cells whose label is not active (unscored) and unequal edge and
// diagonal weights.
TEST(LocalEnergyScores, SameBitsAsLocalEnergy) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    const int R = 3 + trial % 5, C = 2 + trial % 7, K = 1 + trial % 4;
    EnergyModel em;
    em.resize(R, C, K);
    for (int k = 0; k < K; ++k) em.active[k] = static_cast<LabelId>(k + 1);
    em.beta = 0.3f + 0.1f * (trial % 3);
    em.beta_diagonal = 0.7f * em.beta;
    std::uniform_real_distribution<float> u(-2.f, 2.f);
    for (float& x : em.unary) x = u(rng);
    std::vector<LabelId> labels(em.cells());
    for (std::size_t i = 0; i < em.cells(); ++i) {
      em.fixed[i] = rng() % 5 == 0;
      // Class 4 is not active when K < 4.
      labels[i] = em.fixed[i] ? labels::kUnknown : static_cast<LabelId>(1 + rng() % 4);
    }
    const auto s = localEnergyScores(em, labels, 5);
    ASSERT_EQ(s.size(), 5u);
    std::vector<uint8_t> lab(em.cells(), static_cast<uint8_t>(K));  // K: differs from every k
    for (std::size_t i = 0; i < em.cells(); ++i)
      if (labels[i] >= 1 && labels[i] <= K) lab[i] = static_cast<uint8_t>(labels[i] - 1);
    for (std::size_t i = 0; i < em.cells(); ++i) {
      const bool scored = !em.fixed[i] && labels[i] <= K;
      for (int k = 0; k < K; ++k) {
        const float got = s[k + 1][i];
        if (!scored) {
          EXPECT_TRUE(std::isnan(got)) << "trial " << trial << " cell " << i;
          continue;
        }
        double other = INFINITY;
        for (int j = 0; j < K; ++j)
          if (j != k) other = std::min(other, em.localEnergy(lab, static_cast<int>(i), j));
        const float want =
            K == 1 ? 0.f : static_cast<float>(other - em.localEnergy(lab, static_cast<int>(i), k));
        EXPECT_EQ(got, want) << "trial " << trial << " cell " << i << " k " << k;
      }
    }
  }
}

TEST(RocWriters, CsvSvgJson) {
  RocAccumulator acc(LabelSet::defaults());
  acc.add(labels::kRoad, 0.9f, true, true);
  acc.add(labels::kRoad, 0.1f, false, false);
  const auto curves = acc.curves();
  const std::string csv = rocCsv(curves, "run1");
  EXPECT_EQ(csv.rfind("run,class,threshold,fpr,tpr,tp,fp,positives,negatives\n", 0), 0u);
  EXPECT_NE(csv.find("run1,road,inf,0,0,0,0,1,1"), std::string::npos) << csv;
  const std::string svg = rocSvg(curves, LabelSet::defaults(), "a <title>");
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_NE(svg.find("<polyline"), std::string::npos);
  EXPECT_NE(svg.find("a &lt;title&gt;"), std::string::npos);
  EXPECT_NE(svg.find("AUC 1.000"), std::string::npos);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  const std::string js = rocSummaryJson(curves);
  EXPECT_NE(js.find("\"auc\": 1"), std::string::npos) << js;
}

TEST(RocWriters, ARateWithoutItsDenominatorIsEmptyNotZero) {
  // A class no cell truly holds has no true positive rate; writing 0 would draw a curve along
  // the x axis, as if the class had been missed everywhere.
  RocAccumulator acc(LabelSet::defaults());
  acc.add(labels::kObstacle, 0.9f, false, true);
  acc.add(labels::kObstacle, 0.2f, false, false);
  const RocCurve c = acc.curve(labels::kObstacle);
  EXPECT_FALSE(c.defined());
  ASSERT_EQ(c.points.size(), 3u);
  EXPECT_TRUE(std::isnan(c.points[2].tpr));
  EXPECT_DOUBLE_EQ(c.points[2].fpr, 1.0);
  const std::string csv = rocCsv({c}, "");
  EXPECT_NE(csv.find("obstacle,0.200000003,1,,0,2,0,2\n"), std::string::npos) << csv;
}

TEST(RocWriters, CsvThresholdsStayDistinct) {
  // Two scores one float step apart are two points of the curve, and two rows of the CSV.
  RocAccumulator acc(LabelSet::defaults());
  acc.add(labels::kRoad, 1.0f, true, true);
  acc.add(labels::kRoad, 0.99999994f, false, false);
  const std::string csv = rocCsv(acc.curves(), "");
  EXPECT_NE(csv.find("road,1,"), std::string::npos) << csv;
  EXPECT_NE(csv.find("road,0.99999994,"), std::string::npos) << csv;
}

}  // namespace
}  // namespace terramrf
