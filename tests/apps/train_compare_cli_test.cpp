// The train and compare commands (apps/terramrf/cmd_train.cpp, cmd_compare.cpp) called as
// functions: argument handling and exit statuses. The logic itself is tested in
// tests/framework/sweep.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "commands.hpp"
#include "terramrf/atomic_file.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {
namespace fs = std::filesystem;
using cli::Args;

std::string put(const test::TempDir& dir, const std::string& name, const std::string& text) {
  const std::string p = dir.str() + "/" + name;
  std::ofstream(p) << text;
  return p;
}

const char* kTrainConfig = R"(version: 1
grid: {size_m: 30, cell_m: 0.5}
source: {type: simulator, params: {seed: 7, frames: 1, enable_camera: false, azimuth_step_deg: 0.4}}
stages:
  - {name: pre, type: eigen_preclass}
  - {name: hdiff, type: height_difference}
outputs:
  - {type: feature_stats, params: {features: [height_diff, normal_eigenvalue], min_sigma: [0.02, 0.0001]}}
)";

TEST(TrainCli, UsageErrors) {
  EXPECT_EQ(cli::cmdTrain({}), cli::kUsage);
  test::TempDir dir;
  const std::string config = put(dir, "t.yaml", kTrainConfig);
  EXPECT_EQ(cli::cmdTrain({config}), cli::kUsage);  // no --out
  EXPECT_EQ(cli::cmdTrain({config, "--out", dir.str() + "/m.yaml", "--bogus"}), cli::kUsage);
}

TEST(TrainCli, BadConfigIsAUsageError) {
  test::TempDir dir;
  const std::string config =
      put(dir, "t.yaml", "version: 1\nsorce: {type: simulator}\nstages: []\n");
  EXPECT_EQ(cli::cmdTrain({config, "--out", dir.str() + "/m.yaml", "--no-progress"}), cli::kUsage);
  EXPECT_FALSE(fs::exists(dir.str() + "/m.yaml"));
}

TEST(TrainCli, WritesTheModel) {
  test::TempDir dir;
  const std::string config = put(dir, "t.yaml", kTrainConfig);
  const std::string model = dir.str() + "/m.yaml";
  EXPECT_EQ(cli::cmdTrain({config, "--out", model, "--no-progress"}), cli::kOk);
  ASSERT_TRUE(fs::exists(model));
  EXPECT_NE(readFile(model).find("trained_from:"), std::string::npos);
}

TEST(CompareCli, DryRunAndBadSweep) {
  test::TempDir dir;
  const std::string sweep = put(dir, "s.yaml", R"(version: 1
datasets:
  a: {type: simulator, params: {seed: 7, frames: 1, enable_camera: false}}
  b: {type: simulator, params: {seed: 1, frames: 1, enable_camera: false}}
split: {train: [a], test: [b]}
feature_sets:
  L: {stages: [{name: hdiff, type: height_difference}], features: [height_diff]}
optimisers: [icm, not_built]
)");
  EXPECT_EQ(cli::cmdCompare({sweep, "--dry-run"}), cli::kOk);
  const std::string bad = put(dir, "bad.yaml", "version: 1\ndatasets: {}\n");
  EXPECT_EQ(cli::cmdCompare({bad, "--no-progress"}), cli::kUsage);
  EXPECT_EQ(cli::cmdCompare({}), cli::kUsage);
  EXPECT_EQ(cli::cmdCompare({sweep, "--what"}), cli::kUsage);
}

}  // namespace
}  // namespace terramrf
