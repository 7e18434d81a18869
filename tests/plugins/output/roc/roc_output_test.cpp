// Output plugin "roc" driven with hand-made frames: score layers give a known AUC; without score
// layers it falls back to the local energy margin or, with fallback: skip, says there is no ROC.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>

#include "terramrf/atomic_file.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {
namespace fs = std::filesystem;

// 2×2 grid: truth road in cells 0–1, obstacle in cells 2–3.
struct Scene {
  Frame frame;
  TerrainGrid grid;
  FrameContext ctx;
  LabelSet labels = LabelSet::defaults();
  Scene() {
    GridGeometry g;
    g.size_m = 2;
    g.cell_m = 1;
    grid.reset(g);
    const float xs[] = {-0.5f, -0.5f, 0.5f, 0.5f}, ys[] = {-0.5f, 0.5f, -0.5f, 0.5f};
    for (int c = 0; c < 4; ++c) {
      frame.points.push_back(xs[c], ys[c], 0, 0);
      frame.truth.label.push_back(c < 2 ? labels::kRoad : labels::kObstacle);
    }
    frame.id = "000000";
    grid.binPoints(frame.points);
    grid.labels() = {labels::kRoad, labels::kObstacle, labels::kObstacle, labels::kObstacle};
    ctx.frame = &frame;
    ctx.grid = &grid;
    ctx.labels = &labels;
  }
};

std::unique_ptr<Output> makeRoc(PluginRegistry& reg, const std::string& params,
                                const std::string& out, const LabelSet& labels) {
  auto p = reg.create("roc");
  PluginContext pc;
  pc.output_dir = out;
  pc.labels = &labels;
  setParams(*p, params, pc);
  std::unique_ptr<Output> o(static_cast<Output*>(p.release()));
  RunInfo info;
  info.output_dir = out;
  info.labels = &labels;
  info.config_path = "test";
  o->begin(info);
  return o;
}

TEST(RocOutput, ScoreLayersGiveTheKnownAuc) {
  test::TempDir dir;
  PluginRegistry reg({test::pluginDir()});
  Scene s;
  // Road scores separate perfectly; obstacle scores are reversed.
  s.grid.add("score.road") = {0.9f, 0.8f, 0.2f, 0.1f};
  s.grid.add("score.obstacle") = {0.9f, 0.8f, 0.2f, 0.1f};
  auto roc = makeRoc(reg, "{}", dir.str(), s.labels);
  roc->write(s.ctx);
  roc->end({});
  const YAML::Node js = YAML::LoadFile(dir.str() + "/roc/summary.json");
  EXPECT_EQ(js["frames_with_score_layers"].as<int>(), 1);
  ASSERT_EQ(js["curves"].size(), 2u);
  EXPECT_EQ(js["curves"][0]["class"].as<std::string>(), "road");
  EXPECT_DOUBLE_EQ(js["curves"][0]["auc"].as<double>(), 1.0);
  EXPECT_EQ(js["curves"][1]["class"].as<std::string>(), "obstacle");
  EXPECT_DOUBLE_EQ(js["curves"][1]["auc"].as<double>(), 0.0);
  // Operating point of road: 1 of 2 road cells labelled road, no false road.
  EXPECT_DOUBLE_EQ(js["curves"][0]["operating_tpr"].as<double>(), 0.5);
  EXPECT_DOUBLE_EQ(js["curves"][0]["operating_fpr"].as<double>(), 0.0);
  const std::string csv = readFile(dir.str() + "/roc/roc.csv");
  EXPECT_EQ(csv.rfind("class,threshold,fpr,tpr", 0), 0u);
  EXPECT_NE(readFile(dir.str() + "/roc/roc.svg").find("<polyline"), std::string::npos);
}

TEST(RocOutput, FallsBackToTheLocalEnergyOrSkips) {
  PluginRegistry reg({test::pluginDir()});
  Scene s;
  EnergyModel& em = s.ctx.energy;
  em.resize(2, 2, 2);
  em.active = {labels::kRoad, labels::kObstacle};
  em.beta = em.beta_diagonal = 0.1f;
  em.unary = {0, 3, 1, 2, 3, 0, 2, 0};  // cells 0,1 favour road, 2,3 obstacle
  {
    test::TempDir dir;
    auto roc = makeRoc(reg, "{fallback: local_energy}", dir.str(), s.labels);
    roc->write(s.ctx);
    roc->end({});
    const YAML::Node js = YAML::LoadFile(dir.str() + "/roc/summary.json");
    EXPECT_EQ(js["frames_with_energy_fallback"].as<int>(), 1);
    EXPECT_DOUBLE_EQ(js["curves"][0]["auc"].as<double>(), 1.0);  // unaries rank road perfectly
  }
  {
    test::TempDir dir;
    auto roc = makeRoc(reg, "{fallback: skip, subdir: r}", dir.str(), s.labels);
    roc->write(s.ctx);
    roc->end({});
    const YAML::Node js = YAML::LoadFile(dir.str() + "/r/summary.json");
    EXPECT_EQ(js["frames_without_scores"].as<int>(), 1);
    EXPECT_EQ(js["curves"].size(), 0u);
    EXPECT_NE(js["note"].as<std::string>().find("no ROC"), std::string::npos);
  }
}

TEST(RocOutput, RejectsAnAbsoluteSubdir) {
  PluginRegistry reg({test::pluginDir()});
  auto p = reg.create("roc");
  PluginContext pc;
  EXPECT_THROW(setParams(*p, "{subdir: /tmp/x}", pc), std::runtime_error);
}

}  // namespace
}  // namespace terramrf
