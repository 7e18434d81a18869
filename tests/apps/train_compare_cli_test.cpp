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
  for (const char* n : {"5x", "-1", "0", "abc"})
    EXPECT_EQ(cli::cmdTrain({config, "--out", dir.str() + "/m.yaml", "--limit", n}), cli::kUsage)
        << n;
  EXPECT_FALSE(fs::exists(dir.str() + "/m.yaml"));
}

TEST(CliOptions, CountsAreWholeNumbersOrAnError) {
  // std::stoul read "5x" as 5 and "-1" as 2^64-1 (no limit at all).
  Args a = {"--limit", "12", "--first=0"};
  std::size_t limit = 0, first = 7;
  EXPECT_TRUE(cli::takeCount(a, "--limit", "run", 1, limit));
  EXPECT_TRUE(cli::takeCount(a, "--first", "run", 0, first));
  EXPECT_EQ(limit, 12u);
  EXPECT_EQ(first, 0u);
  EXPECT_TRUE(a.empty());
  std::size_t untouched = 3;
  EXPECT_TRUE(cli::takeCount(a, "--limit", "run", 1, untouched));  // absent: left alone
  EXPECT_EQ(untouched, 3u);
  for (const char* bad : {"5x", "-1", "1.5", "99999999999999999999999", "0"}) {
    Args b = {"--limit", bad};
    std::size_t v = 3;
    EXPECT_FALSE(cli::takeCount(b, "--limit", "run", 1, v)) << bad;
    EXPECT_EQ(v, 3u) << bad;
  }
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

/// A one-frame simulator sweep with the given `optimisers:` value (on line 8).
std::string sweepWithOptimisers(const std::string& optimisers) {
  return R"(version: 1
datasets:
  a: {type: simulator, params: {seed: 7, frames: 1, enable_camera: false}}
  b: {type: simulator, params: {seed: 1, frames: 1, enable_camera: false}}
split: {train: [a], test: [b]}
feature_sets:
  L: {stages: [{name: hdiff, type: height_difference}], features: [height_diff]}
optimisers: )" + optimisers + "\n";
}

TEST(CompareCli, DryRunAndBadSweep) {
  test::TempDir dir;
  const std::string sweep = put(dir, "s.yaml", sweepWithOptimisers("[icm, not_built]"));
  EXPECT_EQ(cli::cmdCompare({sweep, "--dry-run"}), cli::kOk);
  const std::string bad = put(dir, "bad.yaml", "version: 1\ndatasets: {}\n");
  EXPECT_EQ(cli::cmdCompare({bad, "--no-progress"}), cli::kUsage);
  EXPECT_EQ(cli::cmdCompare({}), cli::kUsage);
  EXPECT_EQ(cli::cmdCompare({sweep, "--what"}), cli::kUsage);
  EXPECT_EQ(cli::cmdCompare({sweep, "--dry-run", "--limit", "abc"}), cli::kUsage);
  EXPECT_EQ(cli::cmdCompare({sweep, "--dry-run", "--limit", "-1"}), cli::kUsage);
}

TEST(CompareCli, ATypoInAPluginTypeIsAnErrorNotASkippedRun) {
  // A type nothing installed resembles is a plugin not built yet: its runs are skipped. One a
  // letter away from an installed plugin is a typo.
  test::TempDir dir;
  const std::string sweep = put(dir, "typo.yaml", sweepWithOptimisers("[icm, icmm]"));
  testing::internal::CaptureStderr();
  EXPECT_EQ(cli::cmdCompare({sweep, "--dry-run"}), cli::kUsage);
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("typo.yaml:8:19: stage 'icmm' (icmm): plugin type 'icmm' is not installed "
                     "(did you mean 'icm'?)"),
            std::string::npos)
      << err;
}

TEST(ValidateCli, ChecksASweepAsASweep) {
  test::TempDir dir;
  const std::string sweep = put(dir, "s.yaml", sweepWithOptimisers("[icm, not_built]"));
  testing::internal::CaptureStdout();
  EXPECT_EQ(cli::cmdValidate({sweep}), cli::kOk);
  const std::string out = testing::internal::GetCapturedStdout();
  EXPECT_NE(out.find("s.yaml: ok (sweep 's': 1 run(s), 1 skipped"), std::string::npos) << out;
  EXPECT_NE(out.find("skip b × L × not_built"), std::string::npos) << out;

  // The sweep's own checks, not the pipeline's: a typo is reported where compare reports it.
  // Frames past the source's end: refused by validate as by train (validate used to say ok).
  const std::string past = put(dir, "past.yaml",
                               std::string(kTrainConfig) +
                                   "split:\n  train: [{frames: [0, 0]}]\n"
                                   "  test: [{frames: [1, 1]}]\n");
  testing::internal::CaptureStderr();
  EXPECT_EQ(cli::cmdValidate({past}), cli::kUsage);
  const std::string past_err = testing::internal::GetCapturedStderr();
  EXPECT_NE(past_err.find("asks for frame 1 but the source has 1 frame(s)"), std::string::npos)
      << past_err;
  const std::string typo = put(dir, "typo.yaml", sweepWithOptimisers("[icm, icmm]"));
  testing::internal::CaptureStderr();
  EXPECT_EQ(cli::cmdValidate({typo}), cli::kUsage);
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("typo.yaml:8:19: stage 'icmm' (icmm): plugin type 'icmm' is not installed"),
            std::string::npos)
      << err;
  EXPECT_EQ(cli::cmdValidate({sweep, "--data", dir.str()}), cli::kUsage);
  EXPECT_EQ(cli::cmdValidate({sweep, "extra"}), cli::kUsage);
}

// A train config's split: is checked by validate as train checks it (before, validate said ok and
// train then failed on the typo); a folder is said to be one.
TEST(ValidateCli, ChecksATrainConfigsSplitAndRefusesAFolder) {
  test::TempDir dir;
  const std::string ok = put(dir, "ok.yaml",
                             std::string(kTrainConfig) +
                                 "split:\n  train: [{frames: [0, 0]}]\n"
                                 "  test: [{params: {seed: 1}}]\n");
  testing::internal::CaptureStdout();
  EXPECT_EQ(cli::cmdValidate({ok}), cli::kOk);
  EXPECT_EQ(testing::internal::GetCapturedStdout().find("note:"), std::string::npos);
  // Other frames of the world trained on: valid, with the note `train` prints.
  const std::string same = put(dir, "same.yaml",
                               test::edited(kTrainConfig, "frames: 1,", "frames: 2,") +
                                   "split:\n  train: [{frames: [0, 0]}]\n"
                                   "  test: [{frames: [1, 1]}]\n");
  testing::internal::CaptureStdout();
  EXPECT_EQ(cli::cmdValidate({same}), cli::kOk);
  const std::string out = testing::internal::GetCapturedStdout();
  EXPECT_NE(out.find("note: test item"), std::string::npos) << out;
  EXPECT_NE(out.find("in other frames"), std::string::npos) << out;
  const std::string typo =
      put(dir, "typo.yaml", std::string(kTrainConfig) + "split:\n  trian: [{frames: [0, 0]}]\n");
  testing::internal::CaptureStderr();
  EXPECT_EQ(cli::cmdValidate({typo}), cli::kUsage);
  std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("typo.yaml:10:3: unknown key 'trian' in split (did you mean 'train'?)"),
            std::string::npos)
      << err;
  const std::string overlap = put(dir, "overlap.yaml",
                                  std::string(kTrainConfig) +
                                      "split:\n  train: [{frames: [0, 0]}]\n"
                                      "  test: [{frames: [0, 0]}]\n");
  testing::internal::CaptureStderr();
  EXPECT_EQ(cli::cmdValidate({overlap}), cli::kUsage);
  err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("overlaps train item"), std::string::npos) << err;
  testing::internal::CaptureStderr();
  EXPECT_EQ(cli::cmdValidate({dir.str()}), cli::kUsage);
  err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find(dir.str() + ": config file is a folder; expected a YAML file"),
            std::string::npos)
      << err;
}

TEST(ValidateCli, TheWrongKindOfFileIsOneErrorNamingTheCommand) {
  // Before, each command listed every key of the other kind as unknown and its own as missing:
  // eleven errors for configs/sweeps/simulator.yaml given to run, none saying what was wrong.
  test::TempDir dir;
  const std::string sweep = put(dir, "s.yaml", sweepWithOptimisers("[icm]"));
  const std::string config = put(dir, "t.yaml", kTrainConfig);
  auto only_error = [](const std::string& err, const std::string& what) {
    EXPECT_NE(err.find(what), std::string::npos) << err;
    EXPECT_NE(err.find("\n1 error(s) in "), std::string::npos) << err;
  };
  testing::internal::CaptureStderr();
  EXPECT_EQ(cli::cmdTrain({sweep, "--out", dir.str() + "/m.yaml", "--no-progress"}), cli::kUsage);
  only_error(testing::internal::GetCapturedStderr(),
             "s.yaml:1:1: this is a sweep (it has 'datasets', 'feature_sets', 'optimisers'): "
             "run it with 'terramrf compare'");
  testing::internal::CaptureStderr();
  EXPECT_EQ(cli::cmdRun({sweep, "--out", dir.str() + "/out", "--no-progress"}), cli::kUsage);
  only_error(testing::internal::GetCapturedStderr(), "s.yaml:1:1: this is a sweep");
  testing::internal::CaptureStderr();
  EXPECT_EQ(cli::cmdCompare({config, "--dry-run"}), cli::kUsage);
  only_error(testing::internal::GetCapturedStderr(),
             "t.yaml:1:1: this is a pipeline config (it has 'source', 'stages'): run it with "
             "'terramrf run' or 'terramrf train'");
  EXPECT_FALSE(fs::exists(dir.str() + "/m.yaml"));
  EXPECT_FALSE(fs::exists(dir.str() + "/out"));
}

}  // namespace
}  // namespace terramrf
