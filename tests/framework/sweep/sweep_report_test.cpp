// Known-answer tests of compare's report writers on a hand-made SweepResult: every number
// below is derived by hand from the counts and times given, not read back from the code.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include "sweep_internal.hpp"  // framework/src: selection scoring
#include "terramrf/sweep.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

std::string readFile(const std::string& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Cell-wise counts of one run: 10 obstacle cells of which 9 found (1 called road), 2 road cells
/// called obstacle, 20 road cells right, 5 rough cells right.
EvalCounts counts(uint64_t obstacle_found) {
  EvalCounts c(4);
  c.scans = 3;
  c.cell_wise.add(labels::kObstacle, labels::kObstacle, obstacle_found);
  c.cell_wise.add(labels::kObstacle, labels::kRoad, 10 - obstacle_found);
  c.cell_wise.add(labels::kRoad, labels::kObstacle, 2);
  c.cell_wise.add(labels::kRoad, labels::kRoad, 20);
  c.cell_wise.add(labels::kRough, labels::kRough, 5);
  return c;
}

SweepResult handMade() {
  SweepResult r;
  r.name = "hand";
  r.labels = LabelSet::defaults();
  r.datasets = {"d"};
  r.feature_sets = {"L", "L+H"};
  r.optimisers = {"icm"};
  for (const char* f : {"L", "L+H"}) {
    RunRecord x;
    x.dataset = "d";
    x.feature_set = f;
    x.optimiser = "icm";
    x.frames = x.frames_ok = 3;
    x.counts = counts(std::string(f) == "L" ? 9 : 10);
    x.times.processing =
        std::string(f) == "L" ? std::vector<double>{2, 4, 6} : std::vector<double>{10, 10, 13};
    x.times.features = {1, 1, 1};
    x.times.mrf = {1, 3, 5};
    x.times.total = x.times.processing;
    r.runs.push_back(x);
  }
  return r;
}

// results.json and summary.md said when they were written (the current time): the report of
// the same runs differed on every writing. SOURCE_DATE_EPOCH fixes that time; a bad value is an
// error naming the variable.
TEST(SweepReport, SourceDateEpochIsTheCreationTime) {
  test::TempDir dir;
  {
    test::ScopedEnv epoch("SOURCE_DATE_EPOCH", "1700000000");
    writeSweepReport(handMade(), dir.str() + "/a");
    std::this_thread::sleep_for(std::chrono::milliseconds(1100));  // another second
    writeSweepReport(handMade(), dir.str() + "/b");
    EXPECT_EQ(sweep_detail::creationTime(), "2023-11-14T22:13:20Z");
  }
  {
    test::ScopedEnv epoch("SOURCE_DATE_EPOCH", "0");
    EXPECT_EQ(sweep_detail::creationTime(), "1970-01-01T00:00:00Z");
  }
  {
    test::ScopedEnv epoch("SOURCE_DATE_EPOCH", "");  // empty: unset, the current time
    EXPECT_NE(sweep_detail::creationTime(), "1970-01-01T00:00:00Z");
  }
  {
    test::ScopedEnv epoch("SOURCE_DATE_EPOCH", "2023-11-14");
    EXPECT_THROW(
        {
          try {
            writeSweepReport(handMade(), dir.str() + "/c");
          } catch (const std::runtime_error& e) {
            EXPECT_NE(std::string(e.what()).find("environment variable SOURCE_DATE_EPOCH: "
                                                 "'2023-11-14' is not a time"),
                      std::string::npos)
                << e.what();
            throw;
          }
        },
        std::runtime_error);
  }
  for (const char* f : {"results.json", "summary.md"}) {
    SCOPED_TRACE(f);
    const std::string a = readFile(dir.str() + "/a/" + f);
    EXPECT_EQ(a, readFile(dir.str() + "/b/" + f));
    EXPECT_NE(a.find("2023-11-14T22:13:20Z"), std::string::npos) << a;
  }
  EXPECT_NE(readFile(dir.str() + "/a/results.json").find("\"created\": \"2023-11-14T22:13:20Z\""),
            std::string::npos);
  EXPECT_NE(readFile(dir.str() + "/a/summary.md").find("- created: 2023-11-14T22:13:20Z"),
            std::string::npos);
}

TEST(SweepReport, AccuracyTableHasTheHandDerivedRates) {
  const SweepResult r = handMade();
  const std::string t = accuracyTable(r, "d", "icm");
  // Road, L: TP 20, FN 2 (called obstacle), FP 1 (the missed obstacle), TN 5 + 9 = 14 (rough
  // and the obstacles found) → TPR 20/22 = 90.9 %, FPR 1/15 = 6.7 %. L+H: FP 0, TN 15 → 0.0 %.
  EXPECT_NE(t.find("| Road/TPR | 90.9 % | 90.9 % |"), std::string::npos) << t;
  EXPECT_NE(t.find("| Road/FPR | 6.7 % | 0.0 % |"), std::string::npos) << t;
  // Rough: TPR 5/5; FPR 0/32 (L) and 0/32.
  EXPECT_NE(t.find("| Rough/TPR | 100.0 % | 100.0 % |"), std::string::npos) << t;
  // Obstacle, L: 9/10 = 90.0 %, FPR 2 of the 27 non-obstacle cells = 7.4 %; L+H 100.0 %, 7.4 %.
  EXPECT_NE(t.find("| Obstacle/TPR | 90.0 % | 100.0 % |"), std::string::npos) << t;
  EXPECT_NE(t.find("| Obstacle/FPR | 7.4 % | 7.4 % |"), std::string::npos) << t;
  EXPECT_EQ(t.find("†"), std::string::npos);  // no frame failed
}

TEST(SweepReport, RuntimeTableHasTheHandDerivedStatistics) {
  const SweepResult r = handMade();
  const std::string t = runtimeTable(r, "d");
  // L: 2, 4, 6 ms → mean 4.0, sample std 2.0, max 6.0, min 2.0; features 1.0, MRF (1+3+5)/3.
  EXPECT_NE(t.find("| L | 4.0 ms | 2.0 ms | 6.0 ms | 2.0 ms | 3 | 1.0 ms | 3.0 ms |"),
            std::string::npos)
      << t;
  // L+H: 10, 10, 13 → mean 11.0, std √((1 + 1 + 4)/2) = 1.73.
  EXPECT_NE(t.find("| L+H | 11.0 ms | 1.7 ms | 13.0 ms | 10.0 ms | 3 |"), std::string::npos) << t;
}

TEST(SweepReport, CsvFilesHaveTheHandDerivedNumbers) {
  const SweepResult r = handMade();
  test::TempDir dir;
  writeSweepReport(r, dir.str());
  const std::string ev = readFile(dir.str() + "/evaluation.csv");
  // Cell-wise obstacle of L: TP 9, FP 2, FN 1, TN 25 (20 + 5); precision 9/11, recall 0.9.
  // Wilson 95 % of 9/11: centre (0.8182 + 3.8415/22)/(1 + 3.8415/11) = 0.9928/1.3492 =
  // 0.7358, half-width 1.96·√(0.8182·0.1818/11 + 3.8415/484)/1.3492 = 0.2128 → [0.5230,
  // 0.9486].
  const std::string row = "d,icm,L,ok,cell,obstacle,9,2,1,25,0.818182,0.9,";
  const auto at = ev.find(row);
  ASSERT_NE(at, std::string::npos) << ev;
  const std::string line = ev.substr(at, ev.find('\n', at) - at);
  std::vector<std::string> f;
  std::stringstream ss(line);
  for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
  ASSERT_EQ(f.size(), 23u) << line;
  EXPECT_NEAR(std::stod(f[19]), 0.5230, 5e-4) << line;
  EXPECT_NEAR(std::stod(f[20]), 0.9486, 5e-4) << line;
  const std::string rt = readFile(dir.str() + "/runtime.csv");
  EXPECT_NE(rt.find("d,L,icm,ok,3,4,2,6,2,4,1,3,4\n"), std::string::npos) << rt;
}

// Validation data without rough cells. A: road and obstacle F1 0.95 each, and one cell called
// rough; B: 0.90 each, never rough. Averaged over what each predicted, A scored (0.95 + 0.95 +
// 0) / 3 = 0.633 and lost to B's 0.90; over the classes of the truth A wins with 0.95.
TEST(SweepSelectScore, MacroF1AveragesOverTheClassesOfTheTruthForEveryCandidate) {
  const LabelSet labels = LabelSet::defaults();
  auto counts = [](uint64_t right, uint64_t wrong, bool stray_rough) {
    EvalCounts c(4);
    // F1 = 2·TP / (2·TP + FP + FN): 190 right and 10 cells swapped each way give 380/400.
    c.cell_wise.add(labels::kRoad, labels::kRoad, right);
    c.cell_wise.add(labels::kObstacle, labels::kObstacle, right);
    c.cell_wise.add(labels::kRoad, labels::kObstacle, wrong);
    c.cell_wise.add(labels::kObstacle, labels::kRoad, wrong);
    if (stray_rough) c.cell_wise.add(labels::kRoad, labels::kRough, 1);
    return c;
  };
  const std::vector<EvalCounts> both = {counts(190, 10, true), counts(180, 20, false)};
  const std::vector<LabelId> classes = sweep_detail::truthClasses(both, {"", ""}, labels.size());
  EXPECT_EQ(classes, (std::vector<LabelId>{labels::kRoad, labels::kObstacle}));
  const double a = sweep_detail::selectionScore(both[0], labels, "macro_f1", classes);
  const double b = sweep_detail::selectionScore(both[1], labels, "macro_f1", classes);
  // A: road TP 190, FP 10, FN 10 + 1 → 380/401; obstacle 380/400. B: 360/400 each.
  EXPECT_NEAR(a, (380.0 / 401 + 380.0 / 400) / 2, 1e-12);
  EXPECT_NEAR(b, 0.9, 1e-12);
  EXPECT_GT(a, b);
  // A candidate that failed (a note) does not bring classes of its own.
  EvalCounts rough_only(4);
  rough_only.cell_wise.add(labels::kRough, labels::kRough, 5);
  EXPECT_EQ(
      sweep_detail::truthClasses({rough_only, both[1]}, {"training failed", ""}, labels.size()),
      (std::vector<LabelId>{labels::kRoad, labels::kObstacle}));
  EXPECT_NEAR(sweep_detail::selectionScore(both[0], labels, "f1_obstacle", classes), 0.95, 1e-12);
}

}  // namespace
}  // namespace terramrf
