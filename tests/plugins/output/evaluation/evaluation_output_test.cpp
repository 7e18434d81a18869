// The "evaluation" output plugin end to end on hand-made frames: files, stdout table, params.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <memory>
#include <string>

#include "terramrf/atomic_file.hpp"
#include "terramrf/errors.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

namespace fs = std::filesystem;
using labels::kObstacle;
using labels::kRoad;
using labels::kRough;

GridGeometry tinyGeometry() {
  GridGeometry g;
  g.size_m = 1.0;  // 2×2 cells of 0.5 m, origin (−0.5, −0.5)
  g.cell_m = 0.5;
  return g;
}

/// One frame plus its grid; points at the centres of the given cells (row-major 2×2).
struct Scene {
  Frame frame;
  TerrainGrid grid{tinyGeometry()};
  explicit Scene(const std::string& id) { frame.id = id; }
  void add(int cell, LabelId label, int n = 1) {
    const Eigen::Vector2d c = grid.geometry().cellCentre(cell / 2, cell % 2);
    for (int i = 0; i < n; ++i) {
      frame.points.push_back(static_cast<float>(c.x()), static_cast<float>(c.y()), 0.f, 0.f);
      frame.truth.label.push_back(label);
      frame.truth.raw.push_back(label);
    }
  }
  FrameContext context(const LabelSet& labels, std::size_t index) {
    grid.binPoints(frame.points);
    FrameContext ctx;
    ctx.frame = &frame;
    ctx.grid = &grid;
    ctx.labels = &labels;
    ctx.index = index;
    return ctx;
  }
};

class EvaluationOutputTest : public ::testing::Test {
 protected:
  std::unique_ptr<Output> make(const std::string& params) {
    PluginRegistry reg({test::pluginDir()});
    std::unique_ptr<Plugin> p = reg.create("evaluation");
    setParams(*p, params, pctx());
    auto* out = dynamic_cast<Output*>(p.get());
    EXPECT_NE(out, nullptr);
    p.release();
    return std::unique_ptr<Output>(out);
  }
  PluginContext pctx() const {
    PluginContext c;
    c.output_dir = dir.str();
    c.grid = tinyGeometry();
    c.labels = &labels;
    return c;
  }
  RunInfo info() const {
    RunInfo r;
    r.output_dir = dir.str();
    r.labels = &labels;
    r.grid = tinyGeometry();
    return r;
  }
  test::TempDir dir;
  LabelSet labels = LabelSet::defaults();
};

TEST_F(EvaluationOutputTest, WritesPerFrameAndSummaryFilesAndPrintsTheTable) {
  auto out = make("{subdir: ev, per_frame: true, rules: paper001}");
  out->begin(info());

  // Frame 000001: cell 0 = 1 obstacle + 3 road predicted obstacle (road excused),
  // cell 1 = 2 rough predicted road.
  Scene a("000001");
  a.add(0, kObstacle);
  a.add(0, kRoad, 3);
  a.add(1, kRough, 2);
  a.grid.labels()[0] = kObstacle;
  a.grid.labels()[1] = kRoad;
  out->write(a.context(labels, 0));

  // Frame 000002 has no ground truth: counted, no per-frame file.
  Scene b("000002");
  b.add(0, kRoad, 5);
  b.frame.truth = PointLabels{};
  b.grid.labels()[0] = kRoad;
  out->write(b.context(labels, 1));

  testing::internal::CaptureStdout();
  out->end(RunSummary{});
  const std::string printed = testing::internal::GetCapturedStdout();

  const fs::path ev = dir.path() / "ev";
  EXPECT_TRUE(fs::exists(ev / "000001.json"));
  EXPECT_FALSE(fs::exists(ev / "000002.json"));
  ASSERT_TRUE(fs::exists(ev / "summary.json"));
  ASSERT_TRUE(fs::exists(ev / "summary.md"));
  EXPECT_EQ(readFile((ev / "summary.md").string()), printed);

  const YAML::Node frame = YAML::LoadFile((ev / "000001.json").string());
  EXPECT_EQ(frame["frame"].as<std::string>(), "000001");
  EXPECT_EQ(frame["counts"]["excused_points"].as<int>(), 3);

  const YAML::Node s = YAML::LoadFile((ev / "summary.json").string());
  EXPECT_EQ(s["counts"]["scans"].as<int>(), 1);
  EXPECT_EQ(s["counts"]["frames_without_truth"].as<int>(), 1);
  EXPECT_EQ(s["counts"]["points"].as<int>(), 6);         // frame 000002 is not counted
  EXPECT_EQ(s["counts"]["scored_points"].as<int>(), 6);  // 1 obstacle + 3 road excused + 2 rough
  // Point-wise rough: 2 × (rough, road) → recall 0; road: FP 2, TP 0 → precision 0, and its 3
  // excused points are false negatives (recall 0), not false positives of obstacle.
  EXPECT_DOUBLE_EQ(s["point_wise"]["classes"][1]["recall"].as<double>(), 0.0);
  EXPECT_DOUBLE_EQ(s["point_wise"]["classes"][0]["precision"].as<double>(), 0.0);
  EXPECT_EQ(s["point_wise"]["classes"][0]["fn"].as<int>(), 3);
  EXPECT_EQ(s["point_wise"]["classes"][2]["fp"].as<int>(), 0);
  EXPECT_EQ(s["cell_wise"]["confusion"][2][1].as<int>(), 1);

  EXPECT_NE(printed.find("| Number of scans | 1 |"), std::string::npos) << printed;
  EXPECT_NE(printed.find("1 frames without ground truth"), std::string::npos) << printed;
  EXPECT_NE(printed.find("| road | 0 | 0 | 0 | 0 | 3 |"), std::string::npos)  // excused column
      << printed;
  EXPECT_NE(printed.find("| obstacle | 1 | 0 | 0 | 1.000 | 1.000 | 1.000 | 0.000 |"),
            std::string::npos)
      << printed;
}

TEST_F(EvaluationOutputTest, DefaultsAndNoPerFrameFiles) {
  auto out = make("{per_frame: false}");
  out->begin(info());
  Scene a("x");
  a.add(3, kRoad);
  a.grid.labels()[3] = kRoad;
  out->write(a.context(labels, 0));
  // "x" was evaluated and failed in a later output; "y" failed before reaching this output.
  RunSummary summary;
  summary.frames_ok = 0;
  summary.failed = {{"x", "[output later] disk full"}, {"y", "[read] bad file"}};
  testing::internal::CaptureStdout();
  out->end(summary);
  const std::string printed = testing::internal::GetCapturedStdout();
  EXPECT_NE(printed.find("- 1 frames failed in the pipeline (not evaluated)"), std::string::npos)
      << printed;
  const fs::path ev = dir.path() / "evaluation";  // default subdir
  ASSERT_TRUE(fs::exists(ev / "summary.json"));
  const YAML::Node counts = YAML::LoadFile((ev / "summary.json").string())["counts"];
  EXPECT_EQ(counts["frames_failed"].as<int>(), 1);
  // "x" is in the totals, and the summary says so: the run reports it failed.
  EXPECT_EQ(counts["frames_failed_after_evaluation"].as<int>(), 1);
  EXPECT_NE(printed.find("- 1 frames failed in a later output after they were evaluated"),
            std::string::npos)
      << printed;
  EXPECT_FALSE(fs::exists(ev / "x.json"));
}

TEST_F(EvaluationOutputTest, RejectsUnknownRulesAndBadSubdir) {
  EXPECT_NO_THROW(make("{}"));  // the plugin itself loads, so the throws below are about params
  auto message = [&](const std::string& params) -> std::string {
    try {
      make(params);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(message("{rules: paper000}").find("rules"), std::string::npos);
  EXPECT_NE(message("{subdir: ''}").find("subdir"), std::string::npos);
  EXPECT_NE(message("{subdir: /abs/path}").find("subdir"), std::string::npos);
}

TEST_F(EvaluationOutputTest, TruthCountMismatchNamesTheFrame) {
  auto out = make("{}");
  out->begin(info());
  Scene a("000777");
  a.add(0, kRoad, 4);
  FrameContext ctx = a.context(labels, 0);
  a.frame.truth.label.resize(3);
  try {
    out->write(ctx);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("000777"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace terramrf
