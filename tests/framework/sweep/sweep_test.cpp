// compare/train as a library: split validation (overlap rejected with the file and the item),
// file:line:col diagnostics for bad sweep keys, a tiny simulator sweep end to end, and training
// a model that potts_gaussian loads, with provenance.
#include "terramrf/sweep.hpp"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "terramrf/atomic_file.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"
#include "terramrf/stop_request.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {
namespace fs = std::filesystem;

std::string put(const test::TempDir& dir, const std::string& name, const std::string& text) {
  const std::string p = dir.str() + "/" + name;
  std::ofstream(p) << text;
  return p;
}

// Small, fast simulator scans (no camera, coarse azimuth).
const char* kSim = "enable_camera: false, azimuth_step_deg: 0.4";

std::string tinySweep(const std::string& optimisers) {
  return std::string(R"(version: 1
name: tiny
grid: {size_m: 30, cell_m: 0.5}
datasets:
  sim_train: {type: simulator, params: {seed: 7, frames: 2, )") +
         kSim + R"(}}
  sim_test:  {type: simulator, params: {seed: 1, frames: 1, )" +
         kSim + R"(}}
split:
  train: [{dataset: sim_train, frames: [0, 1]}]
  test: [sim_test]
common_stages:
  - {name: pre, type: eigen_preclass}
feature_sets:
  L0:
    stages: [{name: hdiff, type: height_difference}]
    features: [height_diff, normal_eigenvalue]
    min_sigma: [0.02, 0.0001]
  L:
    extends: L0
    stages: [{name: rough, type: roughness}]
    features: [roughness]
    min_sigma: [0.005]
optimisers:
)" + optimisers +
         R"(
energy: {type: potts_gaussian, params: {alpha: 1.0, beta: 0.8, preclass_layer: preclass}}
)";
}

/// `dir`/seq: scan 000000 (with labels) of the shared sequence `fixture`, and a truncated 000001.
void goodAndTruncatedScan(const test::TempDir& dir, const std::string& fixture) {
  const std::string seq = dir.str() + "/seq";
  fs::create_directories(seq + "/velodyne");
  fs::create_directories(seq + "/labels");
  const std::string from = test::dataPath(fixture);
  fs::copy_file(from + "/velodyne/000000.bin", seq + "/velodyne/000000.bin");
  fs::copy_file(from + "/labels/000000.label", seq + "/labels/000000.label");
  std::ofstream(seq + "/velodyne/000001.bin") << "12345";  // not a multiple of 16 bytes
}

ConfigError expectConfigError(const std::string& sweep) {
  try {
    planSweep(sweep, {test::pluginDir()});
  } catch (const ConfigError& e) {
    return e;
  }
  ADD_FAILURE() << "expected a ConfigError for " << sweep;
  return ConfigError({});
}

/// Runs a sweep without a progress bar, logging into `log`.
SweepResult runQuiet(const std::string& sweep, const std::string& out, std::ostringstream& log) {
  CompareOptions o;
  o.sweep_path = sweep;
  o.output_dir = out;
  o.progress = false;
  o.plugin_dirs = {test::pluginDir()};
  o.log = &log;
  return runSweep(o);
}

// ---- split ----------------------------------------------------------------------------------

TEST(SweepSplit, OverlappingFramesOfTheSameSimulatorWorldAreRejected) {
  test::TempDir dir;
  const std::string sweep = put(dir, "overlap.yaml",
                                std::string(R"(version: 1
datasets:
  sim_a: {type: simulator, params: {seed: 7, frames: 4, )") +
                                    kSim + R"(}}
  sim_b: {type: simulator, params: {seed: 7, frames: 6, )" +
                                    kSim + R"(}}
split:
  train: [{dataset: sim_a, frames: [0, 3]}]
  test:
    - {dataset: sim_b, frames: [2, 5]}
feature_sets:
  L: {stages: [{name: hdiff, type: height_difference}], features: [height_diff]}
optimisers: {icm: {type: icm}}
)");
  const ConfigError e = expectConfigError(sweep);
  ASSERT_EQ(e.diagnostics().size(), 1u) << e.what();
  const Diagnostic& d = e.diagnostics()[0];
  EXPECT_EQ(d.file, sweep);
  EXPECT_EQ(d.line, 8);  // the test item
  EXPECT_EQ(d.column, 7);
  EXPECT_NE(d.message.find("test item 'sim_b'"), std::string::npos) << d.message;
  EXPECT_NE(d.message.find("overlaps train item 'sim_a'"), std::string::npos) << d.message;
  EXPECT_NE(d.message.find("frames 2-3 in both"), std::string::npos) << d.message;
  EXPECT_NE(std::string(e.what()).find(sweep + ":8:7:"), std::string::npos) << e.what();
}

/// A sweep training on simulator params `a` and testing on `b` ("seed: 7, ..." without braces)
/// must be refused as one world on both sides.
void expectSameSimulatorWorld(const std::string& a, const std::string& b) {
  test::TempDir dir;
  const std::string sweep =
      put(dir, "seed.yaml",
          "version: 1\ndatasets:\n  a: {type: simulator, params: {" + a + ", frames: 2, " + kSim +
              "}}\n  b: {type: simulator, params: {" + b + ", frames: 2, " + kSim + R"(}}
split: {train: [a], test: [b]}
feature_sets:
  L: {stages: [{name: hdiff, type: height_difference}], features: [height_diff]}
optimisers: [icm]
)");
  const ConfigError e = expectConfigError(sweep);
  ASSERT_EQ(e.diagnostics().size(), 1u) << e.what();
  EXPECT_NE(e.diagnostics()[0].message.find("(simulator seed 7), all frames in both"),
            std::string::npos)
      << e.what();
}

TEST(SweepSplit, TheSameSeedWithOtherNoiseIsTheSameWorld) {
  expectSameSimulatorWorld("seed: 7, rough_noise_m: 0.05", "seed: 7, rough_noise_m: 0.2");
}

// A seed written otherwise is the same world: 07, '7' and +7 are seed 7 to the simulator, so they
// must be to the overlap check too (compared as written, the test world was trained on).
TEST(SweepSplit, TheSameSeedWrittenOtherwiseIsTheSameWorld) {
  for (const char* spelling : {"07", "'7'", "+7"}) {
    SCOPED_TRACE(spelling);
    expectSameSimulatorWorld("seed: 7", std::string("seed: ") + spelling);
  }
}

TEST(SweepSplit, DisjointRangesAndOtherSeedsAreAccepted) {
  test::TempDir dir;
  const std::string sweep = put(dir, "ok.yaml",
                                std::string(R"(version: 1
datasets:
  sim: {type: simulator, params: {seed: 7, frames: 4, )") +
                                    kSim + R"(}}
  other: {type: simulator, params: {seed: 8, frames: 2, )" +
                                    kSim + R"(}}
split:
  train: [{dataset: sim, frames: [0, 1]}, other]
  test: [{dataset: sim, frames: [2, 3]}]
feature_sets:
  L: {stages: [{name: hdiff, type: height_difference}], features: [height_diff]}
optimisers: {icm: {type: icm}, later: {type: not_built_yet}}
)");
  const SweepPlan plan = planSweep(sweep, {test::pluginDir()});
  ASSERT_EQ(plan.runs.size(), 1u);
  EXPECT_EQ(plan.runs[0], "sim × L × icm");
  ASSERT_EQ(plan.skipped.size(), 1u);
  EXPECT_NE(plan.skipped[0].second.find("'not_built_yet' is not installed"), std::string::npos);
  // Accepted, but said: the test frames are of the world the model was learnt on.
  ASSERT_EQ(plan.notes.size(), 1u);
  EXPECT_NE(plan.notes[0].find("test item 'sim' (frames 2-3 of simulator seed 7) and train item "
                               "'sim' (frames 0-1 of simulator seed 7) read the same recording "
                               "(simulator seed 7) in other frames: allowed, but frames of one "
                               "drive share its ground and objects"),
            std::string::npos)
      << plan.notes[0];
}

// Items named alike (one dataset with other `params:`, or the same item twice) shared a label:
// their runs wrote one folder (runs/<label>__F__O) and the tables showed the first item twice.
TEST(SweepSplit, ItemsOfOneDatasetAreNamedApartByWhatDiffers) {
  test::TempDir dir;
  const std::string sweep = put(dir, "alike.yaml",
                                std::string(R"(version: 1
datasets:
  sim_train: {type: simulator, params: {seed: 7, frames: 2, )") +
                                    kSim + R"(}}
  sim_test: {type: simulator, params: {seed: 1, frames: 2, )" +
                                    kSim + R"(}}
split:
  train: [sim_train]
  test:
    - {dataset: sim_test, params: {range_noise_m: 0.0}}
    - {dataset: sim_test, params: {range_noise_m: 0.3}}
    - sim_test
    - sim_test
    - {dataset: sim_test, frames: 1}
    - {dataset: sim_test, frames: 1, params: {azimuth_step_deg: 0.5}}
feature_sets:
  L: {stages: [{name: hdiff, type: height_difference}], features: [height_diff]}
optimisers: {icm: {type: icm}}
)");
  const SweepPlan plan = planSweep(sweep, {test::pluginDir()});
  EXPECT_EQ(plan.runs, (std::vector<std::string>{
                           "sim_test range_noise_m=0.0 × L × icm",
                           "sim_test range_noise_m=0.3 × L × icm",
                           "sim_test #3 × L × icm",
                           "sim_test #4 × L × icm",
                           "sim_test[1-1] azimuth_step_deg=0.4 × L × icm",
                           "sim_test[1-1] azimuth_step_deg=0.5 × L × icm",
                       }));
}

// A run's folder joins three names with "__": each unique, the joined ones may still be equal.
TEST(SweepSplit, RunsWhoseFolderNamesJoinAlikeAreRejected) {
  test::TempDir dir;
  const std::string sweep = put(dir, "join.yaml",
                                std::string(R"(version: 1
datasets:
  sim_train: {type: simulator, params: {seed: 7, frames: 1, )") +
                                    kSim + R"(}}
  a__b: {type: simulator, params: {seed: 1, frames: 1, )" +
                                    kSim + R"(}}
  a: {type: simulator, params: {seed: 2, frames: 1, )" +
                                    kSim + R"(}}
split:
  train: [sim_train]
  test: [a__b, a]
feature_sets:
  c: {stages: [{name: hdiff, type: height_difference}], features: [height_diff]}
  b__c: {stages: [{name: hdiff, type: height_difference}], features: [height_diff]}
optimisers: {icm: {type: icm}}
)");
  const ConfigError e = expectConfigError(sweep);
  ASSERT_EQ(e.diagnostics().size(), 1u) << e.what();
  EXPECT_EQ(e.diagnostics()[0].line, 8);  // the test items
  EXPECT_NE(e.diagnostics()[0].message.find(
                "run 'a × b__c × icm' and run 'a__b × c × icm' would both write "
                "runs/a__b__c__icm and roc/a__b__c__icm.*"),
            std::string::npos)
      << e.what();
}

TEST(SweepSplit, ARangePastTheEndOfItsSourceIsAnError) {
  test::TempDir dir;
  // Clamping it would run fewer frames than the sweep says, without a word.
  const std::string sweep = put(dir, "past_end.yaml",
                                std::string(R"(version: 1
datasets:
  sim: {type: simulator, params: {seed: 7, frames: 2, )") +
                                    kSim + R"(}}
  other: {type: simulator, params: {seed: 8, frames: 2, )" +
                                    kSim + R"(}}
split:
  train: [other]
  test: [{dataset: sim, frames: [0, 9]}]
feature_sets:
  L: {stages: [{name: hdiff, type: height_difference}], features: [height_diff]}
optimisers: {icm: {type: icm}}
)");
  const ConfigError e = expectConfigError(sweep);
  ASSERT_EQ(e.diagnostics().size(), 1u) << e.what();
  EXPECT_EQ(e.diagnostics()[0].line, 7);
  EXPECT_NE(e.diagnostics()[0].message.find(
                "split item 'sim' asks for frames 0-9 but the source has 2 frame(s) (0–1)"),
            std::string::npos)
      << e.what();
}

TEST(SweepSplit, SameDataFolderOverlapsAndNestedFoldersToo) {
  test::TempDir dir;
  const std::string root = test::dataPath("semantickitti_seq00_000000-000005");
  const std::string sweep = put(dir, "real.yaml",
                                R"(version: 1
datasets:
  seq00: {type: semantickitti, params: {path: )" +
                                    root + R"(}}
  seq00_inner: {type: semantickitti, params: {path: )" +
                                    root + R"(/sequences/00}}
split:
  train: [{dataset: seq00, frames: [0, 1]}]
  test: [{dataset: seq00, frames: [1, 2]}, seq00_inner]
feature_sets:
  L: {stages: [{name: hdiff, type: height_difference}], features: [height_diff]}
optimisers: [icm]
)");
  const ConfigError e = expectConfigError(sweep);
  ASSERT_EQ(e.diagnostics().size(), 2u) << e.what();
  EXPECT_EQ(e.diagnostics()[0].line, 7);
  EXPECT_NE(e.diagnostics()[0].message.find("frame 1 in both"), std::string::npos) << e.what();
  EXPECT_NE(e.diagnostics()[1].message.find("contains the other"), std::string::npos) << e.what();
}

// ---- diagnostics ----------------------------------------------------------------------------

TEST(SweepDiagnostics, BadKeysAndParametersHaveFileLineColumn) {
  test::TempDir dir;
  const std::string sweep = put(dir, "bad.yaml",
                                std::string(R"(version: 1
datasets:
  sim: {type: simulator, params: {seed: 7, frames: 2, )") +
                                    kSim + R"(}}
split:
  train: [{dataset: sim, frames: [0, 0]}]
  test: [{dataset: sim, frams: [1, 1]}]
feature_set:
  L: {stages: [{name: rough, type: roughness, params: {windw: 5}}], features: [roughness]}
optimisers: {icm: {type: icm}}
)");
  const ConfigError e = expectConfigError(sweep);
  const std::string all = e.what();
  EXPECT_NE(all.find(sweep + ":6:25: unknown key 'frams' in split item (did you mean 'frames'?)"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find(sweep + ":7:1: unknown key 'feature_set' in the sweep (did you mean "
                             "'feature_sets'?)"),
            std::string::npos)
      << all;
}

// Each malformed part of a sweep is reported at its place before anything runs. These paths had
// no test (coverage): one entry per check, each in a sweep that is otherwise the tiny one.
TEST(SweepDiagnostics, EachMalformedPartIsReportedAtItsPlace) {
  test::TempDir dir;
  const std::string base = tinySweep("  icm: {type: icm}");
  const std::string train = "train: [{dataset: sim_train, frames: [0, 1]}]";
  const std::string l_set = "  L:\n    extends: L0\n";
  const std::string energy =
      "energy: {type: potts_gaussian, params: {alpha: 1.0, beta: 0.8, preclass_layer: preclass}}";
  const std::string l0_features = "    features: [height_diff, normal_eigenvalue]\n";
  struct Case {
    std::string text, token;
    int nth;
    std::string message;
  };
  const std::vector<Case> cases = {
      // split
      {test::edited(base, "frames: [0, 1]", "frames: [0, x]"), "x]", 1,
       "frames: expected a frame index >= 0, got 'x'"},
      {test::edited(base, "frames: [0, 1]", "frames: -1"), "-1", 1,
       "frames: expected a frame index >= 0, got '-1'"},
      {test::edited(base, "frames: [0, 1]", "frames: [0, 1, 2]"), "[0, 1, 2]", 1,
       "frames: expected [first, last] (inclusive frame indices) or one index"},
      {test::edited(base, "frames: [0, 1]", "frames: [1, 0]"), "[1, 0]", 1,
       "frames: last (0) is before first (1)"},
      {test::edited(base, "frames: [0, 1]}", "frames: [0, 1], params: three}"), "three", 1,
       "split item 'params' must be a map of source parameters"},
      // A dataset's params that are not a map were dropped without a word (and with a split
      // item's params added to them, yaml-cpp threw "operator[] call on a scalar").
      {test::edited(
           base,
           "sim_test:  {type: simulator, params: {seed: 1, frames: 1, " + std::string(kSim) + "}}",
           "sim_test:  {type: simulator, params: three}"),
       "three", 1, "stage 'sim_test' (simulator): 'params' must be a map of parameter: value"},
      {test::edited(test::edited(base,
                                 "sim_test:  {type: simulator, params: {seed: 1, frames: 1, " +
                                     std::string(kSim) + "}}",
                                 "sim_test:  {type: simulator, params: three}"),
                    "test: [sim_test]", "test: [{dataset: sim_test, params: {seed: 2}}]"),
       "three", 1, "stage 'sim_test' (simulator): 'params' must be a map of parameter: value"},
      {test::edited(base, "test: [sim_test]", "test: [[sim_test]]"), "[sim_test]", 1,
       "split item: expected a dataset name or {dataset, frames, params}"},
      {test::edited(base, "test: [sim_test]", "test: [{frames: 0}]"), "{frames: 0}", 1,
       "split item needs 'dataset: <name>' (one of the datasets section)"},
      {test::edited(base, "test: [sim_test]", "test: [{dataset: sim_test, path: nowhere}]"),
       "{dataset: sim_test, path", 1, "data folder '" + dir.str() + "/nowhere' does not exist"},
      {test::edited(base, "split:\n  " + train + "\n  test: [sim_test]\n", "split: three\n"),
       "three", 1, "'split' must be a map {train: [...], test: [...]}"},
      {test::edited(base, "  test: [sim_test]\n",
                    "  test: [sim_test]\n  folds: [[{dataset: sim_train, frames: 0}], []]\n"),
       "[]]", 1, "split.folds: fold 2 is empty"},
      // stages and feature sets
      {test::edited(base, "common_stages:\n  - {name: pre, type: eigen_preclass}",
                    "common_stages: {name: pre, type: eigen_preclass}"),
       "{name: pre", 1, "common_stages: expected a list of stage entries {name, type, params}"},
      {test::edited(base, l_set, "  L: [roughness]\n  L2:\n    extends: L0\n"), "[roughness]", 1,
       "feature set 'L': expected {stages: [...], features: [...]}"},
      {test::edited(base, l0_features + "    min_sigma: [0.02, 0.0001]\n", ""),
       "stages: [{name: hdiff", 1,
       "feature set 'L0': 'features' must list the feature layers the energy uses"},
      {test::edited(base, "min_sigma: [0.02, 0.0001]", "min_sigma: [0.02, 0.0001, 0.1]"),
       "[0.02, 0.0001, 0.1]", 1,
       "feature set 'L0': min_sigma has 3 values for 2 features (with those of 'extends'); give "
       "one value, or one per feature"},
      {test::edited(base, l_set, l_set + "    train: []\n"), "[]", 1,
       "feature set 'L': 'train' must be a non-empty list of split items"},
      {test::edited(base, l_set, l_set + "    model: nowhere.yaml\n"), "nowhere.yaml", 1,
       "feature set 'L': model '" + dir.str() + "/nowhere.yaml' does not exist"},
      // energy, training, outputs, roc
      {test::edited(base, energy, "energy: potts_gaussian"), "potts_gaussian", 1,
       "'energy' must be an entry {name, type, params}"},
      {test::edited(base, "params: {alpha: 1.0", "params: {model: m.yaml, alpha: 1.0"), "m.yaml", 1,
       "energy: 'model' is set per feature set by compare; remove it here"},
      {test::edited(base, "params: {alpha: 1.0", "params: {alpah: 1.0"), "alpah", 1,
       "stage 'mrf' (potts_gaussian): unknown parameter 'alpah' (did you mean "
       "'alpha'?)"},
      {test::edited(base, energy, "energy: {type: potts_gaussian, params: strong}"), "strong", 1,
       "stage 'mrf' (potts_gaussian): 'params' must be a map of parameter: value"},
      {base + "training: three\n", "three", 1,
       "'training' must be a map of feature_stats parameters"},
      {base + "outputs: {type: grid_png}\n", "{type: grid_png}", 1,
       "'outputs' must be a list of output entries (added to every test run)"},
      {base + "outputs: [{type: grid_png, params: {subdri: x}}]\n", "subdri", 1,
       "stage 'grid_png' (grid_png): unknown parameter 'subdri' (did you mean 'subdir'?)"},
      {base + "outputs: [{type: grid_png, params: three}]\n", "three", 1,
       "stage 'grid_png' (grid_png): 'params' must be a map of parameter: value"},
      {base + "roc: three\n", "three", 1, "'roc' must be a map {max_points, fallback}"},
      {base + "roc: {max_points: one}\n", "one", 1,
       "roc.max_points: expected an integer from 2 to 10000000"},
      {base + "roc: {max_points: 20000000}\n", "20000000", 1,
       "roc.max_points: expected an integer from 2 to 10000000"},
      {base + "roc: {fallback: maybe}\n", "maybe", 1,
       "roc.fallback: expected 'local_energy' or 'skip', got 'maybe'"},
      // select
      {base + "select: three\n", "three", 1, "'select' must be a map {training: {param: [values]}"},
      {base + "select: {energy: three}\n", "three", 1,
       "select.energy: expected a map parameter: [candidate values]"},
      {base + "select: {stages: three}\n", "three", 1,
       "select.stages: expected a map stage name: {param: [candidate values]}"},
      {base + "select: {stages: {rough: three}}\n", "three", 1,
       "select.stages.rough: expected a map parameter: [candidate values]"},
      {base + "select: {stages: {rough: {window: 3}}}\n", "3}", 1,
       "select.stages.rough.window: expected a non-empty list of candidate values, e.g. [1, 2]"},
      {base + "select: {stages: {rough: {window: []}}}\n", "[]", 1,
       "select.stages.rough.window: expected a non-empty list of candidate values, e.g. [1, 2]"},
      {base + "select: {score: macro_f1}\n", "{score", 1,
       "select: list candidate values under 'training' (feature_stats parameters), 'energy' "
       "(energy parameters) or 'stages' (parameters of a feature set's stage)"},
      {base + "select: {energy: {beta: [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9]}, training: "
              "{components: [1, 2, 3, 4, 5, 6, 7, 8]}}\n",
       "{energy", 1,
       "select: the listed values make more than 64 candidates (each is trained and validated per "
       "feature set); list fewer"},
      {base + "select: {energy: {beta: [0.4, 0.8]}, tie: 2}\n", "2}", 1,
       "select.tie: expected a score difference in [0, 1), e.g. 0.001"},
      {test::edited(base, "  icm: {type: icm}", "  icm: {type: icm}\n  qp: {type: qpbo_solver}") +
           "select: {energy: {beta: [0.4, 0.8]}, optimiser: qp}\n",
       "qp}", 1,
       "select: optimiser 'qp', which scores the candidates, is not installed (plugin type "
       "'qpbo_solver' is not installed)"},
      {test::edited(base, "{name: rough, type: roughness}",
                    "{name: rough, type: roughness, params: {window: 3}}") +
           "select: {stages: {rough: {window: [1, 2]}}}\n",
       "window: [1", 1,
       "select.stages.rough.window: also set in feature set 'L' (line 19); give it in one place "
       "(select's values replace it)"},
      {test::edited(base, "    min_sigma: [0.005]\n",
                    "    min_sigma: [0.005]\n  M:\n    stages: [{name: hdiff, type: roughness}]\n"
                    "    features: [roughness]\n") +
           "select: {stages: {hdiff: {window: [1, 2]}}}\n",
       "hdiff: {window", 1,
       "select.stages.hdiff: stage 'hdiff' is a height_difference in feature set 'L0' and a "
       "roughness in 'M'; candidate values need one type"},
  };
  int k = 0;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.message);
    const std::string sweep = put(dir, "bad" + std::to_string(k++) + ".yaml", c.text);
    const std::string all = expectConfigError(sweep).what();
    const std::string at = test::positionOf(c.text, c.token, c.nth);
    EXPECT_NE(all.find(sweep + ":" + at + ": " + c.message), std::string::npos)
        << "expected at " << at << ":\n"
        << all << "\nin:\n"
        << c.text;
  }
}

// Found by fuzzing: a dataset with `type: null` was reported without a position (split items use
// copies of the dataset's entry, which keep no mark of their own), once per item that uses it.
// A class of the sweep's label set that no training cell shows: the model lacks it, and every
// run says so at the sweep's energy entry (not at 1:1 of the configuration generated for the
// run), without a second message about what the missing energy stage would have written. The
// simulator's truth reaches the set's classes by name.
TEST(SweepDiagnostics, AClassTheTrainingDataLacksFailsTheRunsAtTheEnergyEntry) {
  test::TempDir dir;
  const std::string labels =
      "labels:\n  - {name: unknown, color: [0, 0, 0]}\n  - {name: road, color: [1, 1, 1]}\n"
      "  - {name: kerb, color: [2, 2, 2]}\n  - {name: rough, color: [3, 3, 3]}\n"
      "  - {name: obstacle, color: [4, 4, 4]}\n";
  const std::string text =
      test::edited(tinySweep("  icm: {type: icm}"), "datasets:\n", labels + "datasets:\n");
  const std::string sweep = put(dir, "kerb.yaml", text);
  std::ostringstream log;
  const SweepResult r = runQuiet(sweep, dir.str() + "/out", log);
  EXPECT_EQ(r.exitCode(), 3);
  EXPECT_NE(log.str().find("no statistics for kerb.height_diff"), std::string::npos) << log.str();
  ASSERT_FALSE(r.runs.empty());
  for (const auto& x : r.runs) {
    EXPECT_EQ(x.status, RunRecord::Status::kFailed);
    EXPECT_EQ(x.reason.find(sweep + ":" + test::positionOf(text, "type: potts_gaussian") +
                            ": stage 'mrf' (potts_gaussian): parameter 'model': "),
              0u)
        << x.reason;
    EXPECT_NE(x.reason.find("has no entry for class 'kerb'"), std::string::npos) << x.reason;
    EXPECT_EQ(x.reason.find("which no earlier stage writes"), std::string::npos) << x.reason;
  }
  const YAML::Node model = YAML::LoadFile(dir.str() + "/out/models/L0.yaml");
  EXPECT_FALSE(model["classes"]["kerb"]);
  // Rough ground learnt as rough (by id it had been the obstacles): far flatter than obstacles.
  EXPECT_LT(model["classes"]["rough"]["height_diff"]["mean"].as<double>(),
            0.25 * model["classes"]["obstacle"]["height_diff"]["mean"].as<double>());
}

// Found by fuzzing, likewise: a dataset without a required parameter was reported without a
// position; it is reported at the dataset, which the message names.
TEST(SweepDiagnostics, ADatasetWithoutARequiredParameterIsNamedAtItsPlace) {
  test::TempDir dir;
  const std::string text =
      test::edited(tinySweep("  icm: {type: icm}"), "sim_test:  {type: simulator",
                   "sim_test:  {type: pointcloud_file, params: {}}\n  unused: {type: simulator");
  const std::string sweep = put(dir, "no_path.yaml", text);
  const std::string all = expectConfigError(sweep).what();
  EXPECT_NE(all.find(sweep + ":" + test::positionOf(text, "type: pointcloud_file") +
                     ": stage 'sim_test' (pointcloud_file): missing required parameter 'path'"),
            std::string::npos)
      << all;
}

TEST(SweepDiagnostics, ADatasetWithAnEmptyTypeIsNamedOnceAtItsPlace) {
  test::TempDir dir;
  std::string text = test::edited(tinySweep("  icm: {type: icm}"), "sim_test:  {type: simulator",
                                  "sim_test:  {type: ~");
  text = test::edited(text, "test: [sim_test]", "test: [sim_test, {dataset: sim_test, frames: 0}]");
  const std::string sweep = put(dir, "null_type.yaml", text);
  const std::string all = expectConfigError(sweep).what();
  const std::string want = sweep + ":" + test::positionOf(text, "~") +
                           ": stage 'sim_test': 'type' is empty; expected the plugin type name";
  const std::size_t first = all.find(want);
  EXPECT_NE(first, std::string::npos) << all;
  EXPECT_EQ(all.find("'type' is empty", first + want.size()), std::string::npos) << all;
}

// A stream (Source::streaming(): frames as they arrive, how many unknown) can be neither split by
// frame index nor read again by every run: compare refuses it at its dataset's type, train at
// its source's, before anything runs. Before, size() of a stream would have said 0 frames.
TEST(SweepDiagnostics, AStreamingDatasetIsRefusedAtItsPlace) {
  test::TempDir dir;
  const std::string text = test::edited(
      tinySweep("  icm: {type: icm}"), "sim_test:  {type: simulator",
      "sim_test:  {type: test_synthetic_stream, params: {frames: 2}}\n  unused: {type: simulator");
  const std::string sweep = put(dir, "stream.yaml", text);
  const std::vector<std::string> dirs = {
      test::pluginDir(), std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_stream"};
  try {
    planSweep(sweep, dirs);
    ADD_FAILURE() << "a streaming dataset was taken";
  } catch (const ConfigError& e) {
    ASSERT_EQ(e.diagnostics().size(), 1u) << e.what();
    EXPECT_EQ(e.diagnostics()[0].str(),
              sweep + ":" + test::positionOf(text, "test_synthetic_stream") +
                  ": dataset 'sim_test' (source test_synthetic_stream) is a stream "
                  "(Source::streaming(): frames as they arrive, how many unknown); train and "
                  "compare need a batch they can read again and split by frame index: give a "
                  "source (or parameters) that indexes its frames, or run the stream with "
                  "'terramrf run'");
  }

  const std::string config_text =
      "version: 1\n"
      "source: {type: test_synthetic_stream, params: {frames: 2}}\n"
      "stages:\n"
      "  - {name: hdiff, type: height_difference}\n"
      "outputs:\n"
      "  - {type: feature_stats, params: {features: [height_diff]}}\n";
  const std::string config = put(dir, "train.yaml", config_text);
  TrainOptions o;
  o.config_path = config;
  o.model_out = dir.str() + "/m.yaml";
  o.progress = false;
  o.plugin_dirs = dirs;
  std::ostringstream log;
  o.log = &log;
  try {
    trainModel(o);
    ADD_FAILURE() << "trained on a stream";
  } catch (const ConfigError& e) {
    ASSERT_EQ(e.diagnostics().size(), 1u) << e.what();
    EXPECT_EQ(e.diagnostics()[0].file, config);
    EXPECT_NE(e.diagnostics()[0].str().find(config + ":" +
                                            test::positionOf(config_text, "test_synthetic_stream") +
                                            ": source 'test_synthetic_stream' is a stream"),
              std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(fs::exists(o.model_out));
}

TEST(SweepDiagnostics, UnknownStageParameterPointsIntoTheSweep) {
  test::TempDir dir;
  const std::string sweep = put(dir, "bad2.yaml",
                                std::string(R"(version: 1
datasets:
  a: {type: simulator, params: {seed: 7, frames: 1, )") +
                                    kSim + R"(}}
  b: {type: simulator, params: {seed: 8, frames: 1, )" +
                                    kSim + R"(}}
split: {train: [a], test: [b]}
feature_sets:
  L:
    stages:
      - {name: rough, type: roughness, params: {windw: 5}}
    features: [roughness, no_such_layer]
optimisers: {icm: {type: icm}}
)");
  const ConfigError e = expectConfigError(sweep);
  const std::string all = e.what();
  EXPECT_NE(all.find(sweep + ":9:49: stage 'rough' (roughness): unknown parameter 'windw' (did you "
                             "mean 'window'?)"),
            std::string::npos)
      << all;
}

TEST(SweepDiagnostics, FeatureNoStageWritesIsReported) {
  test::TempDir dir;
  const std::string sweep = put(dir, "bad3.yaml",
                                std::string(R"(version: 1
datasets:
  a: {type: simulator, params: {seed: 7, frames: 1, )") +
                                    kSim + R"(}}
  b: {type: simulator, params: {seed: 8, frames: 1, )" +
                                    kSim + R"(}}
split: {train: [a], test: [b]}
feature_sets:
  L:
    stages: [{name: hdiff, type: height_difference}]
    features: [height_diff, roughness]
optimisers: {icm: {type: icm}}
)");
  const ConfigError e = expectConfigError(sweep);
  ASSERT_EQ(e.diagnostics().size(), 1u) << e.what();
  EXPECT_EQ(e.diagnostics()[0].line, 9);
  EXPECT_NE(e.diagnostics()[0].message.find("feature 'roughness' is not written"),
            std::string::npos)
      << e.what();
}

// A source may bring grid layers made elsewhere (an LCM log with grid_layers): a feature set may
// use them as features, and its stages may read them, with no stage writing them. Each item the
// set runs on is checked against its own source; the error names the item and what it brings.
TEST(SweepDiagnostics, FeaturesAndReadsMayComeFromTheItemsSources) {
  test::TempDir dir;
  const std::string head = "plugin_path: [" + std::string(TERRAMRF_TEST_PLUGIN_DIR) +
                           "/synthetic_source]\n" + R"(version: 1
datasets:
  made: {type: test_synthetic, params: {frames: 3, grid_layers: [made_a, made_b]}}
  bare: {type: test_synthetic, params: {frames: 1, spacing_m: 0.3}}
split: {train: [{dataset: made, frames: [0, 1]}], test: [{dataset: made, frames: [2, 2]}]}
optimisers: {icm: {type: icm}}
feature_sets:
)";
  const std::string good = head + R"(  G:
    stages: [{name: lt, type: log_transform, params: {input: made_b}}]
    features: [made_a, log_made_b]
)";
  EXPECT_NO_THROW(planSweep(put(dir, "good.yaml", good), {test::pluginDir()}));

  const std::string typo = test::edited(good, "features: [made_a,", "features: [made_c,");
  const std::string typo_path = put(dir, "typo.yaml", typo);
  ConfigError e = expectConfigError(typo_path);
  ASSERT_EQ(e.diagnostics().size(), 1u) << e.what();
  EXPECT_EQ(e.diagnostics()[0].str(),
            typo_path + ":" + test::positionOf(typo, "[made_c") +
                ": feature set 'G': feature 'made_c' is not written by any of its or the common "
                "stages nor brought by the source of made (frames 0-1) (brought: made_a, "
                "made_b) (written: log_made_b)");

  // A test item whose source brings no layers: its runs could not read them.
  const std::string bare =
      test::edited(good, "test: [{dataset: made, frames: [2, 2]}]", "test: [bare]");
  const std::string bare_path = put(dir, "bare.yaml", bare);
  e = expectConfigError(bare_path);
  ASSERT_EQ(e.diagnostics().size(), 2u) << e.what();
  EXPECT_EQ(
      e.diagnostics()[0].str(),
      bare_path + ":" + test::positionOf(bare, "{name: lt") +
          ": stage 'lt' (log_transform): reads 'made_b', which no earlier stage writes "
          "(available here: @points) (in the runs on bare (all frames), whose source brings no "
          "layers)");
  EXPECT_EQ(e.diagnostics()[1].message,
            "feature set 'G': feature 'made_a' is not written by any of its or the common "
            "stages (written: log_made_b) (in the runs on bare (all frames), whose source brings "
            "no layers)");

  // Validation items are checked only for the sets select: chooses for: without select: the
  // validation item's source, which brings no layers, is never run with this set.
  const std::string val = test::edited(good, "test: [{dataset: made, frames: [2, 2]}]}",
                                       "test: [{dataset: made, frames: [2, 2]}], validation: "
                                       "[bare]}");
  EXPECT_NO_THROW(planSweep(put(dir, "val.yaml", val), {test::pluginDir()}));
  // With select: it is, and refused.
  e = expectConfigError(
      put(dir, "val_select.yaml", val + "select: {training: {components: [1, 2]}}\n"));
  EXPECT_NE(std::string(e.what()).find(
                "(in the runs on bare (all frames), whose source brings no layers)"),
            std::string::npos)
      << e.what();

  // Training items: a set's own train: list is checked, and none for a set that brings its
  // model (it is not trained).
  const std::string own_train =
      test::edited(good, "    features: [made_a, log_made_b]\n",
                   "    features: [made_a, log_made_b]\n    train: [bare]\n");
  e = expectConfigError(put(dir, "own_train.yaml", own_train));
  EXPECT_NE(std::string(e.what()).find("(in the runs on bare (all frames), whose source brings "
                                       "no layers)"),
            std::string::npos)
      << e.what();
  const std::string model = dir.str() + "/given_model.yaml";
  std::ofstream(model) << "classes: {}\n";
  const std::string given =
      test::edited(test::edited(good, "split: {train: [{dataset: made, frames: [0, 1]}], ",
                                "split: {train: [bare], "),
                   "    features: [made_a, log_made_b]\n",
                   "    features: [made_a, log_made_b]\n    model: " + model + "\n");
  EXPECT_NO_THROW(planSweep(put(dir, "given.yaml", given), {test::pluginDir()}));

  // A source that cannot be made (its log is missing) is the one error: what it would bring is
  // unknown, so the features are not judged on top of it.
  const std::string missing = test::edited(
      good, "  made: {type: test_synthetic, params: {frames: 3, grid_layers: [made_a, made_b]}}",
      "  made: {type: lcm_log, params: {path: " + dir.str() +
          "/none.lcm, points_channel: P, grid_channel: G, grid_layers: [made_a, made_b]}}");
  e = expectConfigError(put(dir, "missing.yaml", missing));
  ASSERT_EQ(e.diagnostics().size(), 1u) << e.what();
  EXPECT_NE(e.diagnostics()[0].message.find("none.lcm' does not exist"), std::string::npos)
      << e.what();
}

// Training items whose sources bring a feature with different origins (logs of two senders
// configured otherwise) cannot make one model: training fails naming both items and the feature.
// Alike, the model records the origin; where one item does not know it, it records none.
TEST(SweepTraining, ItemsThatBringAFeatureComputedOtherwiseMakeNoModel) {
  test::TempDir dir;
  const auto sweep = [&](const std::string& second_origin) {
    return "plugin_path: [" + std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_source]\n" +
           R"(version: 1
datasets:
  one: {type: test_synthetic, params: {frames: 1, grid_layers: [made_a], layer_origin: '{stage: x, window: 1}'}}
  two: {type: test_synthetic, params: {frames: 1, spacing_m: 0.2, grid_layers: [made_a], layer_origin: ')" +
           second_origin + R"('}}
  tst: {type: test_synthetic, params: {frames: 1, spacing_m: 0.3, grid_layers: [made_a], layer_origin: '{stage: x, window: 1}'}}
split: {train: [one, two], test: [tst]}
optimisers: {icm: {type: icm}}
feature_sets:
  G: {stages: [], features: [made_a], min_sigma: [1]}
)";
  };
  std::ostringstream log;
  SweepResult r =
      runQuiet(put(dir, "two.yaml", sweep("{stage: x, window: 2}")), dir.str() + "/o1", log);
  EXPECT_NE(log.str().find("training items 'one' and 'two' bring feature 'made_a' computed "
                           "otherwise ({stage: x, window: 1} against {stage: x, window: 2})"),
            std::string::npos)
      << log.str();
  EXPECT_FALSE(fs::exists(dir.str() + "/o1/models/G.yaml"));
  std::ostringstream log2;
  r = runQuiet(put(dir, "same.yaml", sweep("{stage: x, window: 1}")), dir.str() + "/o2", log2);
  YAML::Node model = YAML::LoadFile(dir.str() + "/o2/models/G.yaml");
  ASSERT_TRUE(model["feature_origins"]) << log2.str();
  EXPECT_EQ(model["feature_origins"]["made_a"]["window"].as<int>(), 1);
  // An item between them that does not know the origin: the model records none, and the two
  // that know it otherwise are still told apart.
  const auto withUnknown = [&](const std::string& second_origin) {
    std::string t = sweep(second_origin);
    t = test::edited(t, "  tst:",
                     "  none: {type: test_synthetic, params: {frames: 1, spacing_m: 0.25, "
                     "grid_layers: [made_a]}}\n  tst:");
    return test::edited(t, "train: [one, two]", "train: [one, none, two]");
  };
  std::ostringstream log3;
  runQuiet(put(dir, "unknown.yaml", withUnknown("{stage: x, window: 2}")), dir.str() + "/o3", log3);
  EXPECT_NE(log3.str().find("training items 'one' and 'two' bring feature 'made_a' computed "
                            "otherwise"),
            std::string::npos)
      << log3.str();
  std::ostringstream log4;
  runQuiet(put(dir, "unknown_same.yaml", withUnknown("{stage: x, window: 1}")), dir.str() + "/o4",
           log4);
  model = YAML::LoadFile(dir.str() + "/o4/models/G.yaml");
  EXPECT_FALSE(model["feature_origins"] && model["feature_origins"]["made_a"]) << log4.str();
}

// A feature set's stages run after common_stages, and the runner runs only the leading
// egomotion stages before it builds the grid: one listed in a feature set after a common feature
// stage ran after binning, and the pose and points it set never reached the grid. Run configs
// refused that order; sweeps ran it. Now refused as the sweep is loaded, at the stage's entry,
// by the check run configs use.
TEST(SweepDiagnostics, AnEgomotionStageAfterTheCommonFeatureStagesIsRefused) {
  test::TempDir dir;
  const std::string ego_dir = std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_egomotion";
  const std::string text = test::edited(
      "plugin_path: [" + ego_dir + "]\n" + tinySweep("  icm: {type: icm}"),
      "    stages: [{name: hdiff, type: height_difference}]",
      "    stages: [{name: ego, type: test_egomotion}, {name: hdiff, type: height_difference}]");
  const std::string sweep = put(dir, "late_ego.yaml", text);
  const ConfigError e = expectConfigError(sweep);
  // Once, though feature set L extends L0 and so has the stage too.
  ASSERT_EQ(e.diagnostics().size(), 1u) << e.what();
  EXPECT_EQ(e.diagnostics()[0].str(),
            sweep + ":" + test::positionOf(text, "{name: ego") +
                ": stage 'ego' (test_egomotion): egomotion stages must come before "
                "feature/energy/optimiser stages (the grid is built after the pose is known); "
                "this one follows 'pre' (eigen_preclass), so it would run on a grid already "
                "built without it");
  // First in common_stages it runs before the grid: accepted.
  const std::string first =
      test::edited("plugin_path: [" + ego_dir + "]\n" + tinySweep("  icm: {type: icm}"),
                   "common_stages:\n", "common_stages:\n  - {name: ego, type: test_egomotion}\n");
  EXPECT_NO_THROW(planSweep(put(dir, "first_ego.yaml", first), {test::pluginDir()}));
}

// Each run's pipeline counts what its source writes: a stage that reads the frame's pose runs
// over the simulator, which gives every frame one, and fails the runs over a source without
// poses, at the stage's entry in the sweep. The check never asked the source, so every run and
// the training failed ("reads '@pose', which no earlier stage writes").
TEST(SweepDiagnostics, AStageThatReadsThePoseRunsWhereTheSourceWritesIt) {
  test::TempDir dir;
  const std::string plugins = std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_egomotion, " +
                              TERRAMRF_TEST_PLUGIN_DIR + "/synthetic_source";
  std::string text = "plugin_path: [" + plugins + "]\n" + tinySweep("  icm: {type: icm}");
  text = test::edited(text, "datasets:\n",
                      "datasets:\n  flat: {type: test_synthetic, params: {frames: 1}}\n");
  text = test::edited(text, "test: [sim_test]", "test: [sim_test, flat]");
  text = test::edited(text, "common_stages:\n",
                      "common_stages:\n  - {name: ego, type: test_egomotion, params: {step_m: 0, "
                      "declared_reads: ['@pose']}}\n");
  const std::string sweep = put(dir, "pose.yaml", text);
  std::ostringstream log;
  const SweepResult r = runQuiet(sweep, dir.str() + "/out", log);
  ASSERT_EQ(r.runs.size(), 4u) << log.str();
  for (const auto& x : r.runs) {
    if (x.dataset == "sim_test") {
      EXPECT_EQ(x.status, RunRecord::Status::kOk) << x.key() << ": " << x.reason;
      continue;
    }
    EXPECT_EQ(x.status, RunRecord::Status::kFailed) << x.key();
    EXPECT_EQ(x.reason.rfind(sweep + ":" + test::positionOf(text, "{name: ego") +
                                 ": stage 'ego' (test_egomotion): reads '@pose', which neither "
                                 "source '",
                             0),
              0u)
        << x.reason;
    EXPECT_NE(x.reason.find("(test_synthetic) nor an earlier stage writes"), std::string::npos)
        << x.reason;
  }
}

TEST(SweepDiagnostics, RepeatedNamesAreRejectedBecauseOneWouldBeIgnoredOrOverwritten) {
  test::TempDir dir;
  // A repeated key: yaml-cpp keeps both, lookups find the first.
  ConfigError e =
      expectConfigError(put(dir, "dup_key.yaml", tinySweep("  icm: {type: icm}\n  icm: gibbs")));
  ASSERT_EQ(e.diagnostics().size(), 1u) << e.what();
  EXPECT_EQ(e.diagnostics()[0].line, 24);
  EXPECT_NE(e.diagnostics()[0].message.find("duplicate key 'icm' (first at line 23)"),
            std::string::npos)
      << e.what();
  // The list form repeats a name without repeating a key.
  e = expectConfigError(put(dir, "dup_list.yaml", tinySweep("  - icm\n  - icm")));
  ASSERT_EQ(e.diagnostics().size(), 1u) << e.what();
  EXPECT_EQ(e.diagnostics()[0].line, 24);
  EXPECT_NE(e.diagnostics()[0].message.find("optimiser 'icm' has the same name as 'icm' (line 23)"),
            std::string::npos)
      << e.what();
  // Names that become the same folder name.
  std::string text = tinySweep("  icm: {type: icm}");
  text.replace(text.find("  L0:"), 5, "  L_0:");
  text.replace(text.find("extends: L0"), 11, "extends: L_0");
  text.replace(text.find("  L:"), 4, "  \"L 0\":");
  e = expectConfigError(put(dir, "dup_file.yaml", text));
  ASSERT_EQ(e.diagnostics().size(), 1u) << e.what();
  EXPECT_EQ(e.diagnostics()[0].line, 17);
  EXPECT_NE(e.diagnostics()[0].message.find(
                "feature set 'L 0' has the same file name as 'L_0' (line 13)"),
            std::string::npos)
      << e.what();
}

TEST(SweepDiagnostics, EveryParameterValueIsCheckedBeforeAnythingRunsAtItsPlace) {
  // The energy and feature_stats are configured only when a run starts; a bad value must not
  // wait until every model has been trained, nor be reported at line 1 of a generated config.
  test::TempDir dir;
  const std::string sweep = put(dir, "values.yaml",
                                std::string(R"(version: 1
datasets:
  a: {type: simulator, params: {seed: 7, frames: 1, )") +
                                    kSim + R"(}}
  b: {type: simulator, params: {seed: 8, frames: 1, enable_camera: fals}}
split: {train: [a], test: [{dataset: b, params: {range_noise_m: loud}}]}
feature_sets:
  L: {stages: [{name: hdiff, type: height_difference}], features: [height_diff]}
optimisers:
  icm: {type: icm, params: {max_sweep: 3}}
energy: {type: potts_gaussian, params: {beta: high, alpha: -1}}
training: {min_purity: 7}
)");
  const ConfigError e = expectConfigError(sweep);
  const std::string all = e.what();
  for (const std::string& want :
       {sweep + ":9:29: stage 'icm' (icm): unknown parameter 'max_sweep' (did you mean "
                "'max_sweeps'?)",
        sweep + ":10:47: energy.params.beta: expected float, got 'high'",
        sweep + ":10:60: energy.params.alpha: value -1 out of range",
        sweep + ":11:24: training.min_purity: value 7 out of range: expected in [0.5, 1]"})
    EXPECT_NE(all.find(want), std::string::npos) << "want: " << want << "\ngot:\n" << all;
  // The sources are made once the rest is clean; their parameters keep their positions too.
  std::string text = readFile(sweep);
  text = text.substr(0, text.find("optimisers:")) + "optimisers: {icm: {type: icm}}\n";
  const ConfigError e2 = expectConfigError(put(dir, "values2.yaml", text));
  const std::string all2 = e2.what();
  EXPECT_NE(all2.find(":4:68: stage 'b' (simulator): parameter 'enable_camera': expected "
                      "bool"),
            std::string::npos)
      << all2;
  EXPECT_NE(all2.find(":5:65: stage 'b' (simulator): parameter 'range_noise_m': "
                      "expected float, got 'loud'"),
            std::string::npos)
      << all2;
}

// ---- a tiny sweep end to end ----------------------------------------------------------------

TEST(SweepRun, TinySimulatorSweepWritesTheTables) {
  test::TempDir dir;
  PluginRegistry reg({test::pluginDir()});
  const bool have_gibbs = reg.find("gibbs") != nullptr;
  const std::string sweep = put(dir, "tiny.yaml", tinySweep(R"(  icm: {type: icm}
  gibbs: {type: gibbs, params: {sweeps: 12, burn_in: 4, seed: 3}}
  later: {type: alpha_expansion_not_built})"));
  CompareOptions o;
  o.sweep_path = sweep;
  o.output_dir = dir.str() + "/out";
  o.progress = false;
  o.plugin_dirs = {test::pluginDir()};
  std::ostringstream log;
  o.log = &log;
  const SweepResult r = runSweep(o);
  EXPECT_EQ(r.exitCode(), 0) << log.str();
  ASSERT_EQ(r.runs.size(), 6u);
  EXPECT_EQ(r.feature_sets, (std::vector<std::string>{"L0", "L"}));
  ASSERT_EQ(r.models.size(), 2u);
  for (const auto& m : r.models) {
    EXPECT_TRUE(m.trained) << m.reason;
    EXPECT_EQ(m.labelled_frames, 2u);
  }
  for (const auto& x : r.runs) {
    SCOPED_TRACE(x.key() + ": " + x.reason);
    if (x.optimiser == "later" || (x.optimiser == "gibbs" && !have_gibbs)) {
      EXPECT_EQ(x.status, RunRecord::Status::kSkipped);
      EXPECT_NE(x.reason.find("is not installed"), std::string::npos);
      continue;
    }
    ASSERT_EQ(x.status, RunRecord::Status::kOk);
    EXPECT_EQ(x.frames_ok, 1u);
    EXPECT_EQ(x.counts.scans, 1u);
    EXPECT_GT(x.counts.cells_scored, 100u);
    // One scan: its per-scan counts are the total.
    ASSERT_EQ(x.per_scan.size(), 1u);
    EXPECT_EQ(x.per_scan[0].second.cells_scored, x.counts.cells_scored);
    ASSERT_EQ(x.energies.size(), 1u);
    EXPECT_TRUE(std::isfinite(x.energies[0].recomputed));
    EXPECT_NEAR(x.energies[0].recomputed, x.energies[0].reported,
                1e-4 * std::fabs(x.energies[0].reported) + 1e-3);
    EXPECT_LE(x.energies[0].recomputed, x.energies[0].initial + 1e-3);
    ASSERT_EQ(x.times.processing.size(), 1u);
    EXPECT_GT(x.times.processing[0], 0.0);
    EXPECT_EQ(x.score_source,
              x.optimiser == "icm" ? ScoreSource::kLocalEnergy : ScoreSource::kScoreLayers);
    ASSERT_FALSE(x.roc.empty());
    std::size_t obstacle_curves = 0;
    for (const auto& c : x.roc)
      if (c.class_name == "obstacle") {
        EXPECT_GT(c.auc, 0.8);
        ++obstacle_curves;
      }
    EXPECT_EQ(obstacle_curves, 1u);
    // Road is found: the laser features separate it from obstacles in the simulator.
    EXPECT_GT(x.counts.cell_wise.scores(labels::kRoad).tpr(), 0.5);
  }
  const std::string out = o.output_dir;
  for (const char* f :
       {"summary.md", "accuracy.md", "accuracy.csv", "runtime.md", "runtime.csv", "evaluation.md",
        "evaluation.csv", "per_scan.md", "per_scan.csv", "energies.md", "energies.csv", "roc_auc.csv", "results.json",
        "models/L.yaml", "models/L0.yaml", "sweep.yaml", "roc/sim_test__L__icm.svg",
        "roc/sim_test__L__icm.csv", "runs/sim_test__L__icm/resolved_config.yaml"})
    EXPECT_TRUE(fs::exists(out + "/" + f)) << f;
  const std::string acc = readFile(out + "/accuracy.md");
  EXPECT_NE(acc.find("| Class/value | L0 | L |"), std::string::npos) << acc;
  EXPECT_NE(acc.find("| Road/TPR |"), std::string::npos);
  EXPECT_NE(acc.find("| Obstacle/FPR |"), std::string::npos);
  EXPECT_NE(acc.find("skipped"), std::string::npos);  // the optimiser that is not built
  const std::string per_scan = readFile(out + "/per_scan.csv");
  EXPECT_EQ(per_scan.rfind("dataset,feature_set,optimiser,frame,level,class,", 0), 0u) << per_scan;
  EXPECT_NE(per_scan.find("sim_test,L,icm,"), std::string::npos) << per_scan;
  EXPECT_NE(readFile(out + "/per_scan.md").find("| dataset | feature set | optimiser | scan |"),
            std::string::npos);
  const std::string rt = readFile(out + "/runtime.md");
  EXPECT_NE(rt.find("| Mode | Mean | Std. dev. | Max | Min |"), std::string::npos) << rt;
  EXPECT_NE(rt.find("| L0 (icm) |"), std::string::npos) << rt;
  // Test runs are timed for that table: no reader thread ran beside their stages.
  const std::string timing = readFile(out + "/runs/sim_test__L__icm/timing.md");
  EXPECT_NE(timing.find("| read wait |"), std::string::npos) << timing;
  EXPECT_EQ(timing.find("read up to"), std::string::npos) << timing;
  const std::string summary = readFile(out + "/summary.md");
  EXPECT_NE(summary.find("alpha_expansion_not_built' is not installed"), std::string::npos);
  EXPECT_NE(summary.find("Point-wise"), std::string::npos);  // paper 001 tables
  if (have_gibbs)
    EXPECT_NE(readFile(out + "/energies.md").find("≤ every other optimiser on"), std::string::npos);
  // results.json is valid JSON (YAML reads JSON) with every run.
  const YAML::Node js = YAML::LoadFile(out + "/results.json");
  EXPECT_EQ(js["schema"].as<std::string>(), "terramrf.compare/1");
  EXPECT_EQ(js["runs"].size(), 6u);
  // The generated run config is what was run: it loads and names the trained model.
  EXPECT_NE(
      readFile(out + "/runs/sim_test__L__icm/resolved_config.yaml").find(out + "/models/L.yaml"),
      std::string::npos);
}

// Two test items of one dataset with other `params:` used to share a run folder and a label:
// the second run overwrote the first's files, and accuracy.md showed the first item twice.
TEST(SweepRun, TestItemsOfOneDatasetWithOtherParamsKeepTheirOwnRunsAndTables) {
  test::TempDir dir;
  std::string text = tinySweep("  icm: {type: icm}");
  text.replace(text.find("  test: [sim_test]"), std::string("  test: [sim_test]").size(),
               "  test: [{dataset: sim_test, params: {range_noise_m: 0.0}},\n"
               "         {dataset: sim_test, params: {range_noise_m: 0.5}}]");
  const std::string sweep = put(dir, "noise.yaml", text);
  std::ostringstream log;
  const SweepResult r = runQuiet(sweep, dir.str() + "/out", log);
  EXPECT_EQ(r.exitCode(), 0) << log.str();
  const std::string a = "sim_test range_noise_m=0.0", b = "sim_test range_noise_m=0.5";
  EXPECT_EQ(r.datasets, (std::vector<std::string>{a, b}));
  const RunRecord* ra = r.find(a, "L", "icm");
  const RunRecord* rb = r.find(b, "L", "icm");
  ASSERT_TRUE(ra && rb);
  EXPECT_NE(ra->output_dir, rb->output_dir);
  EXPECT_FALSE(ra->counts.cell_wise == rb->counts.cell_wise);  // half a metre of range noise
  for (const RunRecord* x : {ra, rb})
    EXPECT_TRUE(fs::exists(x->output_dir + "/resolved_config.yaml")) << x->output_dir;
  EXPECT_NE(readFile(ra->output_dir + "/resolved_config.yaml").find("range_noise_m: 0.0"),
            std::string::npos);
  EXPECT_NE(readFile(rb->output_dir + "/resolved_config.yaml").find("range_noise_m: 0.5"),
            std::string::npos);
  const std::string acc = readFile(dir.str() + "/out/accuracy.md");
  const std::size_t ha = acc.find("### " + a + ", optimiser icm");
  const std::size_t hb = acc.find("### " + b + ", optimiser icm");
  ASSERT_NE(ha, std::string::npos) << acc;
  ASSERT_NE(hb, std::string::npos) << acc;
  // Each heading has its own run's table (the first item's was shown twice).
  auto table = [&](std::size_t heading) {
    const std::size_t from = acc.find("\n|", heading);
    return acc.substr(from, acc.find("\n\n", from + 1) - from);
  };
  EXPECT_NE(table(ha), table(hb)) << acc;
  EXPECT_TRUE(fs::exists(dir.str() + "/out/roc/sim_test_range_noise_m_0.5__L__icm.csv"));
}

TEST(SweepRun, AFeatureSetsEnergyParametersApplyToItsRunsAndToTheSetsThatExtendIt) {
  test::TempDir dir;
  // L0's energy pays every cell to be an obstacle; L extends L0 and sets the cost back; L2
  // extends L0 and keeps it.
  std::string text = tinySweep("  icm: {type: icm}");
  text.replace(text.find("    min_sigma: [0.02, 0.0001]\n"),
               std::string("    min_sigma: [0.02, 0.0001]\n").size(),
               "    min_sigma: [0.02, 0.0001]\n    energy: {class_cost: [0, 0, -1000]}\n");
  text.replace(text.find("    min_sigma: [0.005]\n"),
               std::string("    min_sigma: [0.005]\n").size(),
               "    min_sigma: [0.005]\n    energy: {class_cost: [0, 0, 0]}\n"
               "  L2:\n    extends: L0\n");
  const std::string sweep = put(dir, "per_set_energy.yaml", text);
  std::ostringstream log;
  const std::string out = dir.str() + "/out";
  const SweepResult r = runQuiet(sweep, out, log);
  ASSERT_EQ(r.exitCode(), 0) << log.str();
  ASSERT_EQ(r.runs.size(), 3u);
  for (const auto& x : r.runs) {
    SCOPED_TRACE(x.feature_set);
    ASSERT_EQ(x.status, RunRecord::Status::kOk) << x.reason;
    const double road = x.counts.cell_wise.scores(labels::kRoad).tpr();
    const std::string resolved =
        readFile(out + "/runs/sim_test__" + x.feature_set + "__icm/resolved_config.yaml");
    if (x.feature_set == "L") {
      EXPECT_GT(road, 0.5);
      EXPECT_EQ(resolved.find("-1000"), std::string::npos) << resolved;
    } else {
      EXPECT_EQ(road, 0.0);  // every cell an obstacle
      EXPECT_NE(resolved.find("-1000"), std::string::npos) << resolved;
    }
    // The sweep's own energy parameters still hold.
    EXPECT_NE(resolved.find("preclass_layer: preclass"), std::string::npos) << resolved;
  }
}

// A feature set may bring a model learnt elsewhere: its runs use that file as it is, and no
// training happens for it (the other set is still trained).
TEST(SweepRun, AModelGivenInTheSweepIsUsedAndNotTrained) {
  test::TempDir dir;
  const std::string model = test::sourceDir() + "/configs/models/laser_simulator.yaml";
  std::string text = test::edited(tinySweep("  icm: {type: icm}"), "    min_sigma: [0.005]\n",
                                  "    min_sigma: [0.005]\n    model: " + model + "\n");
  const std::string sweep = put(dir, "given.yaml", text);
  std::ostringstream log;
  const std::string out = dir.str() + "/out";
  const SweepResult r = runQuiet(sweep, out, log);
  ASSERT_EQ(r.exitCode(), 0) << log.str();
  ASSERT_EQ(r.models.size(), 2u);
  for (const ModelRecord& m : r.models) {
    SCOPED_TRACE(m.feature_set);
    if (m.feature_set == "L") {
      EXPECT_FALSE(m.trained);
      EXPECT_EQ(m.path, model);
      EXPECT_EQ(m.reason, "given in the sweep");
      EXPECT_EQ(m.frames, 0u);
    } else {
      EXPECT_TRUE(m.trained);
      EXPECT_EQ(m.frames, 2u);
    }
  }
  for (const auto& x : r.runs) {
    SCOPED_TRACE(x.feature_set);
    ASSERT_EQ(x.status, RunRecord::Status::kOk) << x.reason;
    const std::string resolved =
        readFile(out + "/runs/sim_test__" + x.feature_set + "__icm/resolved_config.yaml");
    EXPECT_EQ(resolved.find(model) != std::string::npos, x.feature_set == "L") << resolved;
  }
  const std::string summary = readFile(out + "/summary.md");
  EXPECT_NE(summary.find("| L | " + model + " | given in the sweep |"), std::string::npos)
      << summary;
}

// With every model given, nothing is trained, so split.train may be left out; while one feature
// set still learns its model, it may not.
TEST(SweepRun, SplitTrainIsOptionalWhenEveryFeatureSetBringsItsModel) {
  test::TempDir dir;
  const std::string model = test::sourceDir() + "/configs/models/laser_simulator.yaml";
  std::string text = test::edited(tinySweep("  icm: {type: icm}"),
                                  "  train: [{dataset: sim_train, frames: [0, 1]}]\n", "");
  text = test::edited(text, "    min_sigma: [0.02, 0.0001]\n",
                      "    min_sigma: [0.02, 0.0001]\n    model: " + model + "\n");
  const std::string both = put(dir, "both_given.yaml",
                               test::edited(text, "    min_sigma: [0.005]\n",
                                            "    min_sigma: [0.005]\n    model: " + model + "\n"));
  std::ostringstream log;
  const SweepResult r = runQuiet(both, dir.str() + "/out", log);
  ASSERT_EQ(r.exitCode(), 0) << log.str();
  EXPECT_TRUE(r.train_items.empty());
  for (const ModelRecord& m : r.models) EXPECT_FALSE(m.trained) << m.feature_set;
  EXPECT_NE(readFile(dir.str() + "/out/summary.md")
                .find("- train split: none (every feature set brings its model or train list)"),
            std::string::npos);
  // L (which extends L0) learns its model: the split must say from what.
  const std::string one = put(dir, "one_given.yaml", text);
  const std::string all = expectConfigError(one).what();
  EXPECT_NE(all.find("split: missing 'train: [...]'"), std::string::npos) << all;
}

TEST(SweepDiagnostics, AFeatureSetsEnergyParametersAreCheckedAtTheirPlace) {
  test::TempDir dir;
  std::string text = tinySweep("  icm: {type: icm}");
  const std::string l0 = "    min_sigma: [0.02, 0.0001]\n";
  text.replace(text.find(l0), l0.size(),
               l0 + "    energy: {betta: 1, model: m.yaml, alpha: -2, class_cost: [0, 0, 0]}\n");
  const std::string l = "    min_sigma: [0.005]\n";
  text.replace(text.find(l), l.size(), l + "    energy: 3\n");
  text += "select: {energy: {class_cost: [[0, 0, 0], [0, 0, -1]]}}\n";
  const std::string sweep = put(dir, "bad_set_energy.yaml", text);
  const ConfigError e = expectConfigError(sweep);
  const std::string all = e.what();
  const std::size_t at = text.find("    energy: {betta");
  const std::string line = std::to_string(std::count(text.begin(), text.begin() + at, '\n') + 1);
  EXPECT_NE(all.find(sweep + ":" + line +
                     ":14: unknown key 'betta' in feature set 'L0' energy (did you mean 'beta'?)"),
            std::string::npos)
      << all;
  EXPECT_NE(
      all.find("feature set 'L0' energy: 'model' is set per feature set by compare; remove it"),
      std::string::npos)
      << all;
  EXPECT_EQ(all.find("unknown key 'model'"), std::string::npos) << all;  // said once
  EXPECT_NE(all.find("feature set 'L0' energy.alpha"), std::string::npos) << all;
  EXPECT_NE(all.find("out of range"), std::string::npos) << all;
  EXPECT_NE(all.find("feature set 'L': 'energy' must be a map of energy parameters"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("select.energy.class_cost: also set in feature set 'L0' energy; give it in "
                     "one place"),
            std::string::npos)
      << all;
}

// ---- select: parameters chosen on a validation split -------------------------------------------

/// tinySweep with a validation world (seed 3) and `select_yaml` appended.
/// `sweep` with its dataset `name` replaced by the SemanticKITTI scans of the shared `data`
/// folder, read without their labels.
std::string readWithoutLabels(std::string sweep, const std::string& name, const std::string& data) {
  const std::size_t at = sweep.find("  " + name + ":");
  sweep.replace(at, sweep.find('\n', at) - at,
                "  " + name + ": {type: semantickitti, params: {use_labels: false, path: " +
                    test::dataPath(data) + "}}");
  return sweep;
}

/// Runs `sweep` with dataset `name` read from `data` without labels (readWithoutLabels): some
/// runs fail for it (exit status 3).
SweepResult runWithoutLabels(const test::TempDir& dir, const std::string& sweep,
                             const std::string& name, const std::string& data,
                             std::ostringstream& log) {
  const std::string path = put(dir, "unlabelled.yaml", readWithoutLabels(sweep, name, data));
  SweepResult r = runQuiet(path, dir.str() + "/out", log);
  EXPECT_EQ(r.exitCode(), 3);
  return r;
}

/// Every test run of `r` failed because select could score no candidate.
void expectEveryRunFailedForWantOfACandidate(const SweepResult& r) {
  ASSERT_FALSE(r.runs.empty());
  for (const auto& x : r.runs) {
    EXPECT_EQ(x.status, RunRecord::Status::kFailed);
    EXPECT_NE(
        x.reason.find("select: no candidate could be scored on the validation split (first: "),
        std::string::npos)
        << x.reason;
  }
}

std::string selectSweep(const std::string& select_yaml) {
  std::string s = tinySweep("  icm: {type: icm}");
  const std::string test_line = "  test: [sim_test]\n";
  s.replace(s.find(test_line), test_line.size(), "  validation: [sim_val]\n" + test_line);
  const std::string ds = "  sim_test:";
  s.insert(s.find(ds), std::string("  sim_val: {type: simulator, params: {seed: 3, frames: 1, ") +
                           kSim + "}}\n");
  return s + select_yaml;
}

TEST(SweepSelect, TheBestCandidateOnValidationIsUsedForTheTestRuns) {
  test::TempDir dir;
  // The first candidate makes every cell an obstacle (a huge bonus for that class): it must lose.
  const std::string sweep = put(dir, "select.yaml", selectSweep(R"(select:
  energy: {class_cost: [[0, 0, -1000], [0, 0, 0]]}
)"));
  // --dry-run lists the validation runs: feature sets × candidates × validation items.
  const SweepPlan plan = planSweep(sweep, {test::pluginDir()});
  ASSERT_EQ(plan.selection_runs.size(), 4u);
  EXPECT_EQ(plan.selection_runs[0], "L0: sim_val × icm [class_cost=[0, 0, -1000]]");
  std::ostringstream log;
  const std::string out = dir.str() + "/out";
  const SweepResult r = runQuiet(sweep, out, log);
  ASSERT_EQ(r.exitCode(), 0) << log.str();
  EXPECT_EQ(r.validation_items, (std::vector<std::string>{"sim_val (all frames)"}));
  ASSERT_EQ(r.selections.size(), 2u);  // L0 and L
  for (const auto& s : r.selections) {
    SCOPED_TRACE(s.feature_set);
    ASSERT_EQ(s.candidates,
              (std::vector<std::string>{"class_cost=[0, 0, -1000]", "class_cost=[0, 0, 0]"}));
    EXPECT_EQ(s.optimiser, "icm");  // the first optimiser, by default
    ASSERT_EQ(s.scores.size(), 2u);
    EXPECT_LT(s.scores[0], s.scores[1]);
    EXPECT_EQ(s.chosen, 1);
    EXPECT_EQ(s.counts[1].scans, 1u);  // scored on the validation scan, not on the test scan
    // Training does not depend on the energy: both candidates used one model.
    EXPECT_EQ(s.models[0], s.models[1]);
  }
  for (const auto& m : r.models) EXPECT_EQ(m.selected, "class_cost=[0, 0, 0]");
  const std::string run_cfg = readFile(out + "/runs/sim_test__L__icm/resolved_config.yaml");
  EXPECT_NE(run_cfg.find("class_cost: [0.0, 0.0, 0.0]"), std::string::npos) << run_cfg;
  EXPECT_NE(run_cfg.find(out + "/models/L.yaml"), std::string::npos);
  const std::string csv = readFile(out + "/selection.csv");
  EXPECT_EQ(csv.rfind("feature_set,optimiser,score_name,candidate,chosen,score,f1_road,", 0), 0u)
      << csv;
  EXPECT_NE(csv.find("L,icm,macro_f1,\"class_cost=[0, 0, 0]\",1,"), std::string::npos) << csv;
  const std::string summary = readFile(out + "/summary.md");
  EXPECT_NE(summary.find("## Parameters selected on validation"), std::string::npos);
  EXPECT_NE(summary.find("selected on validation: class_cost=[0, 0, 0]"), std::string::npos);
  const YAML::Node js = YAML::LoadFile(out + "/results.json");
  EXPECT_EQ(js["selection"].size(), 2u);
  EXPECT_EQ(js["selection"][1]["chosen"].as<std::string>(), "class_cost=[0, 0, 0]");
  // The models name the validation data as held out, with the test data.
  const YAML::Node model = YAML::LoadFile(out + "/models/L.yaml");
  EXPECT_EQ(model["trained_from"]["held_out"][1].as<std::string>(),
            "sim_val (all frames, validation)");
}

TEST(SweepSelect, CandidatesTrainedAlikeTieAndTheFirstListedWins) {
  test::TempDir dir;
  // Same training, two spellings of the defaults: equal scores.
  const std::string sweep = put(dir, "tie.yaml", selectSweep(R"(select:
  training: {min_labelled_points: [3, 3]}
  tie: 0
)"));
  std::ostringstream log;
  const SweepResult r = runQuiet(sweep, dir.str() + "/out", log);
  ASSERT_EQ(r.exitCode(), 0) << log.str();
  ASSERT_EQ(r.selections.size(), 2u);
  EXPECT_EQ(r.selections[0].scores[0], r.selections[0].scores[1]);
  EXPECT_EQ(r.selections[0].chosen, 0);
}

// Stage parameters are candidates too: each one's features are computed with its values, in
// training, validation and the test runs; a feature set without the stage is not selected.
TEST(SweepSelect, StageParametersAreChosenPerFeatureSetAndUsedByTheTestRuns) {
  test::TempDir dir;
  const std::string sweep = put(dir, "stages.yaml", selectSweep(R"(select:
  stages: {rough: {window: [1, 6]}}
)"));
  const SweepPlan plan = planSweep(sweep, {test::pluginDir()});
  ASSERT_EQ(plan.selection_runs.size(), 2u);  // L only: L0 has no stage 'rough'
  EXPECT_EQ(plan.selection_runs[1], "L: sim_val × icm [rough.window=6]");
  std::ostringstream log;
  const std::string out = dir.str() + "/out";
  const SweepResult r = runQuiet(sweep, out, log);
  ASSERT_EQ(r.exitCode(), 0) << log.str();
  ASSERT_EQ(r.selections.size(), 1u);
  const SelectionRecord& sr = r.selections[0];
  EXPECT_EQ(sr.feature_set, "L");
  ASSERT_EQ(sr.candidates, (std::vector<std::string>{"rough.window=1", "rough.window=6"}));
  // Another window is another feature, so another model.
  EXPECT_NE(sr.models[0], sr.models[1]);
  ASSERT_GE(sr.chosen, 0);
  const std::string window = sr.chosen == 0 ? "1" : "6";
  EXPECT_EQ(r.models[1].selected, sr.candidates[sr.chosen]);
  EXPECT_EQ(r.models[0].selected, "");  // L0: trained as usual
  // The validation runs and the test run computed roughness with the candidate's window.
  const std::string cand_cfg = readFile(out + "/select/L/runs/2__sim_val/resolved_config.yaml");
  EXPECT_NE(cand_cfg.find("window: 6"), std::string::npos) << cand_cfg;
  // … and each its own: no candidate's values leak into another's (YAML nodes are shared).
  const std::string first_cfg = readFile(out + "/select/L/runs/1__sim_val/resolved_config.yaml");
  EXPECT_NE(first_cfg.find("window: 1"), std::string::npos) << first_cfg;
  const std::string run_cfg = readFile(out + "/runs/sim_test__L__icm/resolved_config.yaml");
  EXPECT_NE(run_cfg.find("window: " + window), std::string::npos) << run_cfg;
  // With a training axis too: the product, training values first, for the sets each applies to.
  const std::string both = put(dir, "both.yaml", selectSweep(R"(select:
  training: {components: [1, 2]}
  stages: {rough: {window: [1, 6]}}
)"));
  const SweepPlan plan2 = planSweep(both, {test::pluginDir()});
  ASSERT_EQ(plan2.selection_runs.size(), 6u);
  EXPECT_EQ(plan2.selection_runs[0], "L0: sim_val × icm [components=1]");
  EXPECT_EQ(plan2.selection_runs[1], "L0: sim_val × icm [components=2]");
  EXPECT_EQ(plan2.selection_runs[3], "L: sim_val × icm [components=1, rough.window=6]");
  // The sweep's own feature set is left as written for the sets that extend it.
  const std::string l0_cfg = readFile(out + "/runs/sim_test__L0__icm/resolved_config.yaml");
  EXPECT_EQ(l0_cfg.find("type: roughness"), std::string::npos);
}

TEST(SweepSelect, BadStageSelectionsAreReportedWithTheirPlace) {
  test::TempDir dir;
  std::string text = selectSweep(R"(select:
  stages:
    rogh: {window: [1]}
    pre: {threshold_m2: [0.01]}
    rough: {windw: [1], window: [0, 2], residual: [range, height]}
)");
  const std::string sweep = put(dir, "bad_stages.yaml", text);
  const ConfigError e = expectConfigError(sweep);
  const std::string all = e.what();
  EXPECT_NE(all.find("select.stages.rogh: no feature set has a stage named 'rogh' (did you mean "
                     "'rough'?)"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("select.stages.pre: no feature set has a stage named 'pre' (it is a common "
                     "stage; move it into the feature sets to select its parameters)"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("unknown key 'windw' in select.stages.rough (did you mean 'window'?)"),
            std::string::npos)
      << all;
  const std::size_t at = text.find("    rough:");
  const std::string line = std::to_string(std::count(text.begin(), text.begin() + at, '\n') + 1);
  EXPECT_NE(all.find(sweep + ":" + line +
                     ":34: select.stages.rough.window: candidate 0: value 0 out of range"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("select.stages.rough.residual: candidate height:"), std::string::npos) << all;
  // A parameter the feature set sets itself.
  std::string twice = selectSweep("select: {stages: {rough: {window: [1, 2]}}}\n");
  twice.replace(twice.find("{name: rough, type: roughness}"),
                std::string("{name: rough, type: roughness}").size(),
                "{name: rough, type: roughness, params: {window: 3}}");
  const ConfigError e2 = expectConfigError(put(dir, "twice.yaml", twice));
  EXPECT_NE(std::string(e2.what()).find("select.stages.rough.window: also set in feature set 'L' "
                                        "(line "),
            std::string::npos)
      << e2.what();
}

TEST(SweepSelect, RefitLearnsTheChoiceAgainWithTheValidationData) {
  test::TempDir dir;
  const std::string sweep = put(dir, "refit.yaml", selectSweep(R"(select:
  training: {components: [1, 2]}
  refit: true
)"));
  std::ostringstream log;
  const std::string out = dir.str() + "/out";
  const SweepResult r = runQuiet(sweep, out, log);
  ASSERT_EQ(r.exitCode(), 0) << log.str();
  ASSERT_EQ(r.models.size(), 2u);
  for (const auto& m : r.models) {
    SCOPED_TRACE(m.feature_set);
    EXPECT_NE(m.selected.find("(refit on train + validation)"), std::string::npos) << m.selected;
    EXPECT_EQ(m.labelled_frames, 3u);  // two training frames and the validation frame
    EXPECT_EQ(m.train_items.back(), "sim_val (all frames, validation)");
  }
  // The model the test runs use names the validation world as training data, not as held out.
  const YAML::Node model = YAML::LoadFile(out + "/models/L.yaml");
  ASSERT_EQ(model["trained_from"]["data"].size(), 2u);
  EXPECT_EQ(model["trained_from"]["data"][1]["item"].as<std::string>(), "sim_val");
  ASSERT_EQ(model["trained_from"]["held_out"].size(), 1u);
  EXPECT_EQ(model["trained_from"]["held_out"][0].as<std::string>(), "sim_test (all frames)");
  EXPECT_TRUE(YAML::LoadFile(out + "/results.json")["selection"][0]["refit"].as<bool>());
}

TEST(SweepSelect, ValidationDataWithoutLabelsFailsTheFeatureSetsAndSaysWhy) {
  test::TempDir dir;
  // Validation scans read without their labels: nothing to score the candidates by.
  std::ostringstream log;
  const SweepResult r =
      runWithoutLabels(dir, selectSweep("select: {training: {components: [1, 2]}}\n"), "sim_val",
                       "semantickitti_mmdet3d_fixture/sequences/00", log);
  ASSERT_EQ(r.selections.size(), 2u);
  for (const auto& s : r.selections) {
    SCOPED_TRACE(s.feature_set);
    EXPECT_EQ(s.chosen, -1);
    EXPECT_TRUE(std::isnan(s.scores[0]));
    // L0 runs on the scans but has nothing to score; L's roughness cannot run without rings.
    EXPECT_EQ(s.notes[0].find(s.feature_set == "L0" ? "no validation frame with ground truth"
                                                    : "validation run on 'sim_val' failed: "),
              0u)
        << s.notes[0];
  }
  expectEveryRunFailedForWantOfACandidate(r);
}

// A validation frame that fails would leave the candidates scored on fewer frames than chosen:
// no candidate is scored, and the feature set's test runs fail saying which validation item lost
// how many frames (the failure is in the selection record and the run's reason, never silent).
TEST(SweepSelect, AValidationFrameThatFailsIsReportedAndScoresNoCandidate) {
  test::TempDir dir;
  goodAndTruncatedScan(dir, "semantickitti_seq00_000000-000005/sequences/00");  // with rings
  std::string text = selectSweep("select: {training: {components: [1, 2]}}\n");
  const std::size_t at = text.find("  sim_val:");
  text.replace(at, text.find('\n', at) - at,
               "  sim_val: {type: semantickitti, params: {path: seq}}");
  const std::string sweep = put(dir, "bad_validation.yaml", text);
  std::ostringstream log;
  const SweepResult r = runQuiet(sweep, dir.str() + "/out", log);
  EXPECT_EQ(r.exitCode(), 3) << log.str();
  ASSERT_EQ(r.selections.size(), 2u);
  for (const auto& sel : r.selections) {
    SCOPED_TRACE(sel.feature_set);
    EXPECT_EQ(sel.chosen, -1);
    for (std::size_t c = 0; c < sel.scores.size(); ++c) {
      EXPECT_TRUE(std::isnan(sel.scores[c]));
      EXPECT_EQ(sel.notes[c], "1 validation frame(s) of 'sim_val' failed");
    }
  }
  ASSERT_EQ(r.runs.size(), 2u);
  for (const auto& x : r.runs) {
    EXPECT_EQ(x.status, RunRecord::Status::kFailed);
    EXPECT_EQ(x.reason, "no model for feature set '" + x.feature_set +
                            "': select: no candidate could be scored on the validation split "
                            "(first: 1 validation frame(s) of 'sim_val' failed)");
  }
}

TEST(SweepSelect, BadSelectionsAreReportedWithTheirPlace) {
  test::TempDir dir;
  std::string text = selectSweep(R"(training: {components: 2}
select:
  training: {componets: [1, 2], components: [1, 0], min_purity: [0.9], min_sigma: [[0.3]]}
  energy: {beta: 0.8, model: [a.yaml]}
  refit: maybe
  optimiser: icn
  score: accuracy
)");
  const std::string sweep = put(dir, "bad_select.yaml", text);
  const ConfigError e = expectConfigError(sweep);
  const std::string all = e.what();
  auto line_of = [&](const std::string& needle) {
    const std::size_t at = text.find(needle);
    return std::to_string(std::count(text.begin(), text.begin() + at, '\n') + 1);
  };
  const std::string sel_line = line_of("  training: {componets");
  EXPECT_NE(
      all.find(sweep + ":" + sel_line +
               ":14: unknown key 'componets' in select.training (did you mean 'components'?)"),
      std::string::npos)
      << all;
  EXPECT_NE(all.find("select.training.components: also set in 'training'"), std::string::npos)
      << all;
  // The feature sets' own floors would have been replaced without a word.
  EXPECT_NE(all.find("select.training.min_sigma: also set in feature set 'L0' (min_sigma); give "
                     "it in one place"),
            std::string::npos)
      << all;
  // components 0 is out of feature_stats' range: reported at the value.
  EXPECT_NE(all.find(sweep + ":" + sel_line +
                     ":49: select.training.components: candidate 0: value 0 out of range"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("select.energy.beta: expected a non-empty list of candidate values"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("unknown key 'model' in select.energy"), std::string::npos) << all;
  EXPECT_NE(
      all.find(
          "select.optimiser: 'icn' is not one of the sweep's optimisers (did you mean 'icm'?)"),
      std::string::npos)
      << all;
  EXPECT_NE(all.find("select.score: 'accuracy'; expected macro_f1"), std::string::npos) << all;
  EXPECT_NE(all.find("select.refit: expected true or false, got 'maybe'"), std::string::npos)
      << all;
}

// Nothing trains a feature set's given model, so select's training values do not apply to it:
// it was "selected" over identical runs and reported as trained on the train split.
TEST(SweepSelect, AGivenModelIsNotSelectedOverTrainingCandidates) {
  test::TempDir dir;
  const std::string model = test::sourceDir() + "/configs/models/laser_simulator.yaml";
  std::string text = selectSweep("select: {training: {components: [1, 2]}}\n");
  text = test::edited(text, "    min_sigma: [0.02, 0.0001]\n",
                      "    min_sigma: [0.02, 0.0001]\n    model: " + model + "\n");
  const SweepPlan plan = planSweep(put(dir, "given.yaml", text), {test::pluginDir()});
  EXPECT_EQ(plan.selection_runs, (std::vector<std::string>{"L: sim_val × icm [components=1]",
                                                           "L: sim_val × icm [components=2]"}));
  // With energy values too, the given model's set is selected over those alone.
  text =
      test::edited(text, "select: {training: {components: [1, 2]}}",
                   "select: {training: {components: [1, 2]}, energy: {beta_diagonal: [0.8, 1.6]}}");
  const SweepPlan both = planSweep(put(dir, "given2.yaml", text), {test::pluginDir()});
  std::vector<std::string> l0;
  for (const auto& r : both.selection_runs)
    if (r.rfind("L0:", 0) == 0) l0.push_back(r);
  EXPECT_EQ(l0, (std::vector<std::string>{"L0: sim_val × icm [beta_diagonal=0.8]",
                                          "L0: sim_val × icm [beta_diagonal=1.6]"}));
}

TEST(SweepSelect, SelectNeedsAValidationSplitDisjointFromTrainAndTest) {
  test::TempDir dir;
  // No validation split at all.
  const std::string none =
      put(dir, "none.yaml",
          tinySweep("  icm: {type: icm}") + "select: {energy: {beta_diagonal: [0.4, 0.8]}}\n");
  EXPECT_NE(std::string(expectConfigError(none).what())
                .find("select needs split.validation or split.folds: the candidates are scored "
                      "there, never on the test split"),
            std::string::npos);
  // Validation = the test world, then = the training world.
  for (const char* world : {"seed: 1", "seed: 7"}) {
    std::string text = selectSweep("select: {energy: {beta_diagonal: [0.4, 0.8]}}\n");
    text.replace(text.find("seed: 3"), 7, world);
    const std::string sweep = put(dir, "overlap.yaml", text);
    const std::string all = expectConfigError(sweep).what();
    const bool test_world = std::string(world) == "seed: 1";
    EXPECT_NE(
        all.find(test_world ? "split: test item 'sim_test'" : "split: validation item 'sim_val'"),
        std::string::npos)
        << all;
    EXPECT_NE(all.find(test_world ? "overlaps validation item 'sim_val'"
                                  : "overlaps train item 'sim_train'"),
              std::string::npos)
        << all;
    EXPECT_NE(all.find(test_world ? "validation and test sets must be disjoint"
                                  : "train and validation sets must be disjoint"),
              std::string::npos)
        << all;
  }
}

// ---- select: by cross-validation on folds of the train split ----------------------------------

/// tinySweep whose train split (frames 0 and 1 of world 7) is cut into two folds, with
/// `select_yaml` appended.
std::string foldSweep(const std::string& select_yaml) {
  std::string s = tinySweep("  icm: {type: icm}");
  const std::string test_line = "  test: [sim_test]\n";
  s.replace(s.find(test_line), test_line.size(),
            "  folds: [[{dataset: sim_train, frames: [0, 0]}], {dataset: sim_train, frames: 1}]\n" +
                test_line);
  return s + select_yaml;
}

TEST(SweepSelectFolds, EachFoldIsScoredByModelsLearntOnTheOtherFolds) {
  test::TempDir dir;
  // The class_cost -1000 candidates make every cell an obstacle: they must lose.
  const std::string sweep = put(dir, "folds.yaml", foldSweep(R"(select:
  training: {components: [1, 2]}
  energy: {class_cost: [[0, 0, -1000], [0, 0, 0]]}
)"));
  const SweepPlan plan = planSweep(sweep, {test::pluginDir()});
  ASSERT_EQ(plan.selection_runs.size(), 16u);  // 2 feature sets × 4 candidates × 2 folds
  EXPECT_EQ(plan.selection_runs[0],
            "L0: fold 1 sim_train (frame 0) × icm [components=1, class_cost=[0, 0, -1000]] "
            "(trained on the other folds)");
  std::ostringstream log;
  const std::string out = dir.str() + "/out";
  const SweepResult r = runQuiet(sweep, out, log);
  ASSERT_EQ(r.exitCode(), 0) << log.str();
  EXPECT_EQ(r.folds, 2u);
  EXPECT_EQ(r.validation_items, (std::vector<std::string>{"fold 1: sim_train (frame 0)",
                                                          "fold 2: sim_train (frame 1)"}));
  ASSERT_EQ(r.selections.size(), 2u);
  for (const auto& s : r.selections) {
    SCOPED_TRACE(s.feature_set);
    EXPECT_EQ(s.folds, 2u);
    ASSERT_EQ(s.candidates.size(), 4u);
    ASSERT_GE(s.chosen, 0);
    EXPECT_EQ(s.candidates[s.chosen].find("class_cost=[0, 0, 0]"), 14u) << s.candidates[s.chosen];
    for (std::size_t c = 0; c < 4; ++c) {
      EXPECT_EQ(s.counts[c].scans, 2u);  // each fold's scan once, never the test scan
      // One model per fold, learnt without it.
      EXPECT_NE(s.models[c].find("_fold1.yaml; "), std::string::npos) << s.models[c];
      EXPECT_NE(s.models[c].find("_fold2.yaml"), std::string::npos) << s.models[c];
    }
    EXPECT_LT(s.scores[0], s.scores[1]);
  }
  // A fold's model learnt the other fold only, and names its own fold as held out.
  const YAML::Node fold1 = YAML::LoadFile(out + "/select/L/model_1_fold1.yaml")["trained_from"];
  ASSERT_EQ(fold1["data"].size(), 1u);
  EXPECT_EQ(fold1["data"][0]["frames"].as<std::string>(), "frame 1");
  EXPECT_EQ(fold1["held_out"][0].as<std::string>(), "sim_train (frame 0, validation fold 1)");
  // The choice is then learnt on the whole train split for the test runs.
  for (const auto& m : r.models) {
    SCOPED_TRACE(m.feature_set);
    EXPECT_EQ(m.labelled_frames, 2u);
    EXPECT_NE(m.selected.find("(2-fold cross-validation)"), std::string::npos) << m.selected;
  }
  const YAML::Node model = YAML::LoadFile(out + "/models/L.yaml")["trained_from"];
  EXPECT_EQ(model["data"][0]["frames"].as<std::string>(), "frames 0-1");
  const std::string summary = readFile(out + "/summary.md");
  EXPECT_NE(summary.find("2-fold cross-validation inside the train split"), std::string::npos)
      << summary;
  EXPECT_NE(summary.find("validation folds of the train split (select:): fold 1: sim_train"),
            std::string::npos);
  EXPECT_EQ(YAML::LoadFile(out + "/results.json")["selection"][0]["folds"].as<int>(), 2);
}

// A candidate whose training fails on a fold's complement is not scored, says which fold and
// why (in the selection record, the log and the test runs' reason), and costs no other result.
TEST(SweepSelectFolds, ACandidateWhoseTrainingFailsIsReportedWithItsFold) {
  test::TempDir dir;
  // The train split read without its labels: nothing to learn from on any fold.
  std::ostringstream log;
  const SweepResult r =
      runWithoutLabels(dir, foldSweep("select: {training: {components: [1, 2]}}\n"), "sim_train",
                       "semantickitti_seq00_000000-000005", log);
  ASSERT_EQ(r.selections.size(), 2u);
  for (const auto& s : r.selections) {
    SCOPED_TRACE(s.feature_set);
    EXPECT_EQ(s.chosen, -1);
    ASSERT_EQ(s.notes.size(), 2u);
    for (std::size_t c = 0; c < 2; ++c) {
      EXPECT_TRUE(std::isnan(s.scores[c]));
      EXPECT_EQ(s.notes[c].find("training without fold 1 failed: "), 0u) << s.notes[c];
      EXPECT_NE(s.notes[c].find("no labelled frame in the training data"), std::string::npos)
          << s.notes[c];
    }
    EXPECT_NE(log.str().find("feature set " + s.feature_set +
                             " [components=2]: training without "
                             "fold 1 failed: "),
              std::string::npos)
        << log.str();
  }
  expectEveryRunFailedForWantOfACandidate(r);
}

TEST(SweepSelectFolds, FoldsOutsideTheTrainSplitOrSharingDataAreRejectedAtTheirPlace) {
  test::TempDir dir;
  const std::string sel = "select: {training: {components: [1, 2]}}\n";
  auto errors = [&](const std::string& text) {
    return std::string(expectConfigError(put(dir, "bad_folds.yaml", text)).what());
  };
  auto with_folds = [&](const std::string& folds, const std::string& select) {
    std::string s = foldSweep(select);
    const std::size_t at = s.find("  folds:");
    s.replace(at, s.find('\n', at) - at, "  folds: " + folds);
    return s;
  };
  // One fold is no cross-validation.
  EXPECT_NE(errors(with_folds("[{dataset: sim_train, frames: 0}]", sel))
                .find("split.folds: expected a list of at least two folds"),
            std::string::npos);
  // A fold of the test world, and frames the train split does not have.
  const std::string outside =
      errors(with_folds("[{dataset: sim_train, frames: 0}, [sim_test]]", sel));
  EXPECT_NE(outside.find(":9:45: split.folds: fold 2 item 'sim_test'"), std::string::npos)
      << outside;
  EXPECT_NE(outside.find("is not part of split.train"), std::string::npos) << outside;
  // Two folds that share a frame.
  const std::string shared = errors(
      with_folds("[{dataset: sim_train, frames: [0, 1]}, {dataset: sim_train, frames: 1}]", sel));
  EXPECT_NE(shared.find("split: fold 2's item 'sim_train'"), std::string::npos) << shared;
  EXPECT_NE(shared.find("overlaps fold 1's item 'sim_train'"), std::string::npos) << shared;
  // Folds and a validation split; refit; a feature set that learns from other data.
  std::string both = foldSweep(sel);
  both.replace(both.find("  test: [sim_test]"), 0, "  validation: [sim_test]\n");
  EXPECT_NE(errors(both).find("split: give either validation"), std::string::npos);
  EXPECT_NE(errors(foldSweep("select: {training: {components: [1, 2]}, refit: true}\n"))
                .find("select.refit: with split.folds the chosen candidate is always learnt"),
            std::string::npos);
  std::string own = foldSweep(sel);
  own.replace(own.find("    extends: L0\n"), 0, "    train: [sim_test]\n");
  EXPECT_NE(errors(own).find("feature set 'L': trains on its own 'train:' items, but split.folds"),
            std::string::npos)
      << errors(own);
}

// ---- the frame cache ---------------------------------------------------------------------------

// The untimed warm-up before an item's first timed run covers its first five frames, not all of
// them (a long item's sweep ran it once more: +100 % with one optimiser). Counted by the frame
// cache: the training frames are read once and hit once; the six test frames are read by the
// warm-up (five), then by the two feature sets' runs.
TEST(SweepFrameCache, TheWarmUpReadsAnItemsFirstFiveFramesOnly) {
  test::TempDir dir;
  std::string text = tinySweep("  icm: {type: icm}");
  text.replace(text.find("seed: 1, frames: 1,"), 19, "seed: 1, frames: 6,");
  std::ostringstream log;
  const SweepResult r = runQuiet(put(dir, "sweep.yaml", text), dir.str() + "/out", log);
  ASSERT_EQ(r.exitCode(), 0) << log.str();
  EXPECT_EQ(r.cached_frames, 8u);
  EXPECT_EQ(r.cache_hits, 2u + 5u + 6u);  // (all six warmed: 2 + 6 + 6)
}

TEST(SweepFrameCache, KeptFramesGiveTheSameResultsAsReadingThemAgain) {
  test::TempDir dir;
  const std::string text = tinySweep("  icm: {type: icm}");
  const std::string cached = put(dir, "cached.yaml", text);
  const std::string uncached = put(dir, "uncached.yaml", text + "frame_cache_mb: 0\n");
  std::ostringstream log;
  const SweepResult a = runQuiet(cached, dir.str() + "/a", log);
  const SweepResult b = runQuiet(uncached, dir.str() + "/b", log);
  ASSERT_EQ(a.exitCode(), 0) << log.str();
  ASSERT_EQ(b.exitCode(), 0) << log.str();
  // Two feature sets: each reads the two training frames and the test frame, kept once; the
  // untimed warm-up before the first test run reads the test frame once more (once per item).
  EXPECT_EQ(a.cached_frames, 3u);
  EXPECT_EQ(a.cache_hits, 4u);
  EXPECT_GT(a.cached_mb, 0.1);
  EXPECT_EQ(b.cached_frames, 0u);
  EXPECT_EQ(b.cache_hits, 0u);
  ASSERT_EQ(a.runs.size(), b.runs.size());
  for (std::size_t i = 0; i < a.runs.size(); ++i) {
    SCOPED_TRACE(a.runs[i].key());
    EXPECT_TRUE(a.runs[i].counts.cell_wise == b.runs[i].counts.cell_wise);
    EXPECT_TRUE(a.runs[i].counts.point_wise == b.runs[i].counts.point_wise);
    EXPECT_EQ(a.runs[i].energies[0].recomputed, b.runs[i].energies[0].recomputed);
  }
  const std::string ma = readFile(dir.str() + "/a/models/L.yaml");
  const std::string mb = readFile(dir.str() + "/b/models/L.yaml");
  EXPECT_EQ(ma.substr(ma.find("\nclasses:")), mb.substr(mb.find("\nclasses:")));
  EXPECT_NE(readFile(dir.str() + "/a/summary.md").find("frame cache: 3 frame(s) kept"),
            std::string::npos);
}

TEST(SweepFrameCache, AFrameThatFailsToReadFailsInEveryRunAndIsReported) {
  test::TempDir dir;
  goodAndTruncatedScan(dir, "semantickitti_mmdet3d_fixture/sequences/00");
  const std::string sweep = put(dir, "bad_frame.yaml",
                                std::string(R"(version: 1
grid: {size_m: 30, cell_m: 0.5}
datasets:
  sim_train: {type: simulator, params: {seed: 7, frames: 1, )") +
                                    kSim + R"(}}
  scans: {type: semantickitti, params: {path: seq}}
split: {train: [sim_train], test: [scans]}
feature_sets:
  L0:
    stages: [{name: hdiff, type: height_difference}]
    features: [height_diff]
    min_sigma: [0.02]
optimisers: {icm: {type: icm}, icm_again: {type: icm}}
)");
  std::ostringstream log;
  const SweepResult r = runQuiet(sweep, dir.str() + "/out", log);
  EXPECT_EQ(r.exitCode(), 3) << log.str();  // frames were lost: said in the exit status
  ASSERT_EQ(r.runs.size(), 2u);
  for (const auto& x : r.runs) {
    SCOPED_TRACE(x.key());
    EXPECT_EQ(x.frames_ok, 1u);
    ASSERT_EQ(x.failed.size(), 1u);
    EXPECT_EQ(x.failed[0].first, "000001");
    EXPECT_NE(x.failed[0].second.find("000001.bin"), std::string::npos) << x.failed[0].second;
  }
  EXPECT_EQ(r.cached_frames, 2u);  // the training frame and the good scan, not the bad one
  EXPECT_EQ(r.cache_hits, 2u);     // both runs' good scan (the item's warm-up read it first)
  EXPECT_NE(log.str().find("1 frame(s) failed and were skipped"), std::string::npos) << log.str();
  // The tables say which columns were scored on fewer scans.
  for (const auto& x : r.runs) EXPECT_EQ(x.counts.frames_failed, 1u);
  const std::string acc = readFile(dir.str() + "/out/accuracy.md");
  EXPECT_NE(acc.find(" † |"), std::string::npos) << acc;
  EXPECT_NE(acc.find("† scored without the frames that failed in that run"), std::string::npos)
      << acc;
  EXPECT_NE(readFile(dir.str() + "/out/results.json").find("\"frames_failed\": 1"),
            std::string::npos);
  EXPECT_NE(readFile(dir.str() + "/out/evaluation.md")
                .find("- 1 frames failed in the pipeline (not evaluated)"),
            std::string::npos);
}

TEST(SweepTraining, ATrainingFrameThatFailsIsReportedAndSetsTheExitStatus) {
  test::TempDir dir;
  // Training on one good and one truncated scan: the model is learnt from the good one, and the
  // lost frame must show in the report and the exit status, not only inside the model file.
  goodAndTruncatedScan(dir, "semantickitti_seq00_000000-000005/sequences/00");
  const std::string sweep = put(dir, "bad_train_frame.yaml",
                                std::string(R"(version: 1
grid: {size_m: 30, cell_m: 0.5}
datasets:
  scans: {type: semantickitti, params: {path: seq}}
  sim_test: {type: simulator, params: {seed: 1, frames: 1, )") +
                                    kSim + R"(}}
split: {train: [scans], test: [sim_test]}
feature_sets:
  L0:
    stages: [{name: hdiff, type: height_difference}]
    features: [height_diff]
    min_sigma: [0.02]
optimisers: {icm: {type: icm}}
)");
  std::ostringstream log;
  const SweepResult r = runQuiet(sweep, dir.str() + "/out", log);
  EXPECT_EQ(r.exitCode(), 3) << log.str();
  ASSERT_EQ(r.models.size(), 1u);
  EXPECT_TRUE(r.models[0].trained);
  EXPECT_EQ(r.models[0].frames, 1u);
  ASSERT_EQ(r.models[0].failed.size(), 1u);
  EXPECT_EQ(r.models[0].failed[0].first, "000001");
  EXPECT_NE(r.models[0].failed[0].second.find("000001.bin"), std::string::npos);
  ASSERT_EQ(r.runs.size(), 1u);
  EXPECT_EQ(r.runs[0].status, RunRecord::Status::kOk) << r.runs[0].reason;  // still ran
  const std::string summary = readFile(dir.str() + "/out/summary.md");
  EXPECT_NE(summary.find("1 training frame(s) failed and were skipped:** 000001"),
            std::string::npos)
      << summary;
  const std::string json = readFile(dir.str() + "/out/results.json");
  EXPECT_NE(json.find("\"failed\": [{\"frame\": \"000001\""), std::string::npos) << json;
}

TEST(SweepTraining, AModelWithoutALearntClassFailsAtTrainingWithTheReason) {
  test::TempDir dir;
  // The mmdet3d fixture holds 50 points: no class gets two training cells.
  const std::string sweep = put(dir, "tiny_train.yaml",
                                std::string(R"(version: 1
grid: {size_m: 30, cell_m: 0.5}
datasets:
  scans: {type: semantickitti, params: {path: )") +
                                    test::dataPath("semantickitti_mmdet3d_fixture") + R"(}}
  sim_test: {type: simulator, params: {seed: 1, frames: 1, )" +
                                    kSim + R"(}}
split: {train: [scans], test: [sim_test]}
feature_sets:
  L0:
    stages: [{name: hdiff, type: height_difference}]
    features: [height_diff]
    min_sigma: [0.02]
optimisers: {icm: {type: icm}}
)");
  std::ostringstream log;
  const SweepResult r = runQuiet(sweep, dir.str() + "/out", log);
  EXPECT_EQ(r.exitCode(), 3);
  ASSERT_EQ(r.models.size(), 1u);
  EXPECT_NE(r.models[0].reason.find("no class has 2 or more training cells in 1 labelled frame(s) "
                                    "(cells need >= 3 labelled points and purity >= 0.9)"),
            std::string::npos)
      << r.models[0].reason;
  ASSERT_EQ(r.runs.size(), 1u);
  EXPECT_EQ(r.runs[0].status, RunRecord::Status::kFailed);
  EXPECT_NE(r.runs[0].reason.find("no class has 2 or more training cells"), std::string::npos)
      << r.runs[0].reason;
}

TEST(SweepFrameCache, BadBudgetIsReportedAtItsLine) {
  test::TempDir dir;
  const std::string sweep =
      put(dir, "budget.yaml", tinySweep("  icm: {type: icm}") + "frame_cache_mb: lots\n");
  const ConfigError e = expectConfigError(sweep);
  ASSERT_EQ(e.diagnostics().size(), 1u) << e.what();
  EXPECT_EQ(e.diagnostics()[0].line, 25);
  EXPECT_NE(e.diagnostics()[0].message.find("frame_cache_mb: expected megabytes"),
            std::string::npos);
}

// ---- train ----------------------------------------------------------------------------------

// Held-out frames of the world trained on: allowed (disjoint), and said.
TEST(Train, TestFramesOfTheTrainingWorldAreNoted) {
  test::TempDir dir;
  const std::string config = put(dir, "train.yaml",
                                 std::string(R"(version: 1
grid: {size_m: 30, cell_m: 0.5}
source: {type: simulator, params: {seed: 7, frames: 3, )") +
                                     kSim + R"(}}
stages:
  - {name: hdiff, type: height_difference}
split:
  train: [{frames: [0, 1]}]
  test: [{frames: [2, 2]}]
outputs:
  - {type: feature_stats, params: {features: [height_diff], min_sigma: [0.02]}}
)");
  TrainOptions o;
  o.config_path = config;
  o.model_out = dir.str() + "/sim.yaml";
  o.progress = false;
  o.plugin_dirs = {test::pluginDir()};
  std::ostringstream log;
  o.log = &log;
  trainModel(o);
  EXPECT_NE(log.str().find("note: test item"), std::string::npos) << log.str();
  EXPECT_NE(log.str().find("read the same recording (simulator seed 7) in other frames"),
            std::string::npos)
      << log.str();
}

TEST(Train, SimulatorModelLoadsInPottsGaussianAndNamesItsData) {
  test::TempDir dir;
  const std::string config = put(dir, "train.yaml",
                                 std::string(R"(version: 1
grid: {size_m: 30, cell_m: 0.5}
source: {type: simulator, params: {seed: 7, frames: 3, )") +
                                     kSim + R"(}}
stages:
  - {name: pre, type: eigen_preclass}
  - {name: hdiff, type: height_difference}
  - {name: mrf, type: potts_gaussian, params: {model: not_trained_yet.yaml, features: [height_diff, normal_eigenvalue]}}
  - {name: solve, type: icm}
split:
  train: [{frames: [0, 1]}]
  test: [{params: {seed: 1}}]
)");
  TrainOptions o;
  o.config_path = config;
  o.model_out = dir.str() + "/models/sim.yaml";
  o.progress = false;
  o.plugin_dirs = {test::pluginDir()};
  std::ostringstream log;
  o.log = &log;
  const TrainResult r = trainModel(o);
  EXPECT_EQ(log.str().find("read the same recording"), std::string::npos) << log.str();
  EXPECT_EQ(r.features, (std::vector<std::string>{"height_diff", "normal_eigenvalue"}));
  EXPECT_EQ(r.frames, 2u);
  EXPECT_EQ(r.labelled_frames, 2u);
  ASSERT_TRUE(fs::exists(o.model_out));
  EXPECT_TRUE(r.missing.empty());
  // Nothing left beside the model but the model.
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.str() + "/models"), fs::directory_iterator()),
            1);

  const YAML::Node m = YAML::LoadFile(o.model_out);
  const std::string prov = m["provenance"].as<std::string>();
  EXPECT_NE(prov.find(config), std::string::npos) << prov;
  EXPECT_NE(prov.find("simulator"), std::string::npos) << prov;
  const YAML::Node data = m["trained_from"]["data"];
  ASSERT_EQ(data.size(), 1u);
  EXPECT_EQ(data[0]["source"].as<std::string>(), "simulator");
  EXPECT_EQ(data[0]["frames"].as<std::string>(), "frames 0-1");
  EXPECT_EQ(data[0]["frame_ids"].size(), 2u);
  EXPECT_EQ(m["trained_from"]["held_out"][0].as<std::string>(), "simulator seed 1 (all frames)");
  // The road is flat, obstacles are tall: the learnt means say so.
  EXPECT_LT(m["classes"]["road"]["height_diff"]["mean"].as<double>(), 0.1);
  EXPECT_GT(m["classes"]["obstacle"]["height_diff"]["mean"].as<double>(), 0.5);

  PluginRegistry reg({test::pluginDir()});
  auto pg = reg.create("potts_gaussian");
  PluginContext ctx;
  const LabelSet ls = LabelSet::defaults();
  ctx.labels = &ls;
  EXPECT_NO_THROW(setParams(
      *pg, "{model: " + o.model_out + ", features: [height_diff, normal_eigenvalue]}", ctx));
}

TEST(Train, OverlappingSplitInATrainConfigIsRejected) {
  test::TempDir dir;
  const std::string config = put(dir, "train.yaml",
                                 std::string(R"(version: 1
source: {type: simulator, params: {seed: 7, frames: 3, )") +
                                     kSim + R"(}}
stages:
  - {name: hdiff, type: height_difference}
outputs:
  - {type: feature_stats, params: {features: [height_diff]}}
split:
  train: [{frames: [0, 2]}]
  test: [{frames: [2, 2]}]
)");
  TrainOptions o;
  o.config_path = config;
  o.model_out = dir.str() + "/m.yaml";
  o.progress = false;
  o.plugin_dirs = {test::pluginDir()};
  try {
    trainModel(o);
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    ASSERT_EQ(e.diagnostics().size(), 1u);
    EXPECT_EQ(e.diagnostics()[0].file, config);
    EXPECT_EQ(e.diagnostics()[0].line, 9);
    EXPECT_NE(e.diagnostics()[0].message.find("frame 2 in both"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(o.model_out));
}

// `terramrf train` assembles its pipeline as a sweep does: an egomotion stage after a feature
// stage ran after the grid was built, and the features were learnt on points it had not yet
// moved. Refused at the entry, as `terramrf run` refuses the same config.
TEST(Train, AnEgomotionStageAfterAFeatureStageIsRefused) {
  test::TempDir dir;
  const std::string text = "version: 1\nplugin_path: [" + std::string(TERRAMRF_TEST_PLUGIN_DIR) +
                           "/synthetic_egomotion]\n" +
                           R"(source: {type: simulator, params: {seed: 7, frames: 2, )" + kSim +
                           R"(}}
stages:
  - {name: hdiff, type: height_difference}
  - {name: ego, type: test_egomotion}
outputs:
  - {type: feature_stats, params: {features: [height_diff]}}
split:
  train: [{frames: [0, 1]}]
)";
  const std::string config = put(dir, "train.yaml", text);
  TrainOptions o;
  o.config_path = config;
  o.model_out = dir.str() + "/m.yaml";
  o.progress = false;
  o.plugin_dirs = {test::pluginDir()};
  std::ostringstream log;
  o.log = &log;
  try {
    trainModel(o);
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    ASSERT_EQ(e.diagnostics().size(), 1u) << e.what();
    EXPECT_EQ(e.diagnostics()[0].str().rfind(
                  config + ":" + test::positionOf(text, "{name: ego") +
                      ": stage 'ego' (test_egomotion): egomotion stages must come before",
                  0),
              0u)
        << e.what();
  }
  EXPECT_FALSE(fs::exists(o.model_out));
}

TEST(Train, DataFolderOfRealScansIsRecordedWithItsLabelMap) {
  test::TempDir dir;
  TrainOptions o;
  o.config_path = test::sourceDir() + "/configs/train/semantickitti_o3dml.yaml";
  o.data = {test::dataPath("semantickitti_o3dml_demo/converted_semantickitti")};
  o.model_out = dir.str() + "/skitti.yaml";
  o.limit = 1;
  o.progress = false;
  o.plugin_dirs = {test::pluginDir()};
  std::ostringstream log;
  o.log = &log;
  const TrainResult r = trainModel(o);
  ASSERT_EQ(r.items.size(), 1u);
  EXPECT_EQ(r.labelled_frames, 1u);
  const YAML::Node m = YAML::LoadFile(o.model_out);
  const YAML::Node item = m["trained_from"]["data"][0];
  // The model records the absolute path as given (symlinks kept, so a data folder linked into
  // place is named as the user named it); compare what both point to.
  EXPECT_EQ(fs::weakly_canonical(item["path"].as<std::string>()), fs::weakly_canonical(o.data[0]));
  EXPECT_TRUE(fs::path(item["path"].as<std::string>()).is_absolute());
  EXPECT_EQ(
      item["label_map"].as<std::string>(),
      fs::weakly_canonical(test::sourceDir() + "/configs/label_maps/semantickitti.yaml").string());
  EXPECT_EQ(m["trained_from"]["features"].size(), 6u);  // from the config's feature_stats output
  EXPECT_NE(m["provenance"].as<std::string>().find("converted_semantickitti"), std::string::npos);
  // The shipped config holds out the test scans of configs/semantickitti.yaml; the model names
  // them by their canonical folder, not by a path relative to the config.
  const YAML::Node held = m["trained_from"]["held_out"];
  ASSERT_EQ(held.size(), 1u);
  EXPECT_EQ(held[0].as<std::string>(),
            fs::canonical(test::dataPath("semantickitti_seq00_000000-000005")).string() +
                " (frames 0-2)");
}

/// A one-frame simulator train config learning height_diff, with `split` (YAML, "" = none)
/// before its stages; options that train it quietly into dir/m.yaml, logging to `log`.
std::string oneFeatureTrainConfig(test::TempDir& dir, const std::string& split) {
  return put(dir, "train.yaml",
             std::string(R"(version: 1
grid: {size_m: 30, cell_m: 0.5}
source: {type: simulator, params: {seed: 7, frames: 1, )") +
                 kSim + "}}\n" + split + R"(stages:
  - {name: hdiff, type: height_difference}
outputs:
  - {type: feature_stats, params: {features: [height_diff], min_sigma: [0.02]}}
)");
}
TrainOptions quietTraining(const std::string& config, test::TempDir& dir, std::ostream& log) {
  TrainOptions o;
  o.config_path = config;
  o.model_out = dir.str() + "/m.yaml";
  o.progress = false;
  o.plugin_dirs = {test::pluginDir()};
  o.log = &log;
  return o;
}

// Two ranges of the config's source were both named "simulator seed 7": in the model's data list
// and in their run folders (the second overwrote the first's). Now named as compare names them.
TEST(Train, ItemsOfOneSourceAreNamedApartInTheModel) {
  test::TempDir dir;
  std::ostringstream log;
  const std::string config = put(dir, "train2.yaml",
                                 std::string(R"(version: 1
grid: {size_m: 30, cell_m: 0.5}
source: {type: simulator, params: {seed: 7, frames: 2, )") +
                                     kSim + R"(}}
split:
  train: [{frames: 0}, {frames: 1}, {params: {range_noise_m: 0.0}}, {params: {range_noise_m: 0.0}}]
stages:
  - {name: hdiff, type: height_difference}
outputs:
  - {type: feature_stats, params: {features: [height_diff], min_sigma: [0.02]}}
)");
  const TrainOptions o = quietTraining(config, dir, log);
  trainModel(o);
  std::vector<std::string> items;
  for (const auto& d : YAML::LoadFile(o.model_out)["trained_from"]["data"])
    items.push_back(d["item"].as<std::string>());
  EXPECT_EQ(items, (std::vector<std::string>{"simulator seed 7[0-0]", "simulator seed 7[1-1]",
                                             "simulator seed 7 #3", "simulator seed 7 #4"}));
}

using test::ScopedEnv;  // restores the variable's earlier value

// The model's trained_from.date was the current time, so training twice on the same data gave
// two different files. With SOURCE_DATE_EPOCH (reproducible-builds.org) it is that time, and the
// two files are the same bytes; a value that is not a time is refused before training.
TEST(Train, SourceDateEpochMakesTheModelTheSameBytes) {
  test::TempDir dir;
  std::ostringstream log;
  TrainOptions o = quietTraining(oneFeatureTrainConfig(dir, ""), dir, log);
  std::string first;
  {
    ScopedEnv env("SOURCE_DATE_EPOCH", "1700000000");
    trainModel(o);
    first = readFile(o.model_out);
    EXPECT_EQ(YAML::Load(first)["trained_from"]["date"].as<std::string>(), "2023-11-14T22:13:20Z");
    std::this_thread::sleep_for(std::chrono::milliseconds(1100));  // another second
    trainModel(o);
    EXPECT_EQ(readFile(o.model_out), first);
  }
  for (const char* bad : {"tomorrow", "1700000000.5", "-1", " 17"}) {
    ScopedEnv env("SOURCE_DATE_EPOCH", bad);
    o.model_out = dir.str() + "/bad.yaml";
    try {
      trainModel(o);
      ADD_FAILURE() << "expected an error for SOURCE_DATE_EPOCH=" << bad;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("environment variable SOURCE_DATE_EPOCH: '" +
                                           std::string(bad) +
                                           "' is not a time; expected whole seconds since "
                                           "1970-01-01 00:00:00 UTC"),
                std::string::npos)
          << e.what();
    }
    EXPECT_FALSE(fs::exists(o.model_out));
  }
}

// The model records how each feature was computed, and a run whose stages compute it otherwise
// is refused before any frame is read, naming the difference (it had scored cells against
// Gaussians of another quantity without a word).
TEST(Train, TheModelRecordsHowItsFeaturesWereComputed) {
  test::TempDir dir;
  std::ostringstream log;
  const TrainOptions o = quietTraining(oneFeatureTrainConfig(dir, ""), dir, log);
  trainModel(o);
  const YAML::Node origin = YAML::LoadFile(o.model_out)["feature_origins"]["height_diff"];
  ASSERT_TRUE(origin) << readFile(o.model_out);
  EXPECT_EQ(origin["stage"].as<std::string>(), "height_difference");
  EXPECT_EQ(origin["params"]["min_points"].as<int>(), 1);
  auto runConfig = [&](const std::string& hdiff_params) {
    return put(dir, "run.yaml",
               std::string("version: 1\ngrid: {size_m: 30, cell_m: 0.5}\n"
                           "source: {type: simulator, params: {seed: 1, frames: 1, ") +
                   kSim + "}}\nstages:\n  - {name: hdiff, type: height_difference, params: " +
                   hdiff_params +
                   "}\n  - {name: mrf, type: potts_gaussian, params: {model: " + o.model_out +
                   ", features: [height_diff]}}\n  - {name: solve, type: icm}\n"
                   "outputs: []\n");
  };
  PluginRegistry reg({test::pluginDir()});
  EXPECT_NO_THROW(loadPipeline(runConfig("{}"), LoadOptions{}, reg));
  try {
    loadPipeline(runConfig("{min_points: 2}"), LoadOptions{}, reg);
    FAIL() << "a model of other features was used";
  } catch (const ConfigError& e) {
    EXPECT_NE(
        std::string(e.what()).find("feature 'height_diff': min_points: 2 here, 1 in the model"),
        std::string::npos)
        << e.what();
  }
  // The same stages on cells of another size compute another quantity too.
  const std::string finer = test::edited(readFile(runConfig("{}")), "cell_m: 0.5", "cell_m: 0.25");
  try {
    loadPipeline(put(dir, "finer.yaml", finer), LoadOptions{}, reg);
    FAIL() << "a model of 0.5 m cells was used on 0.25 m cells";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "feature 'height_diff': cells of 0.25 m here, 0.5 m in the model"),
              std::string::npos)
        << e.what();
  }
}

// --features comes from the command line: a feature no stage writes is named as such, not at a
// place in the config it never came from, and nothing is written.
TEST(Train, AFeatureOfTheCommandLineThatNoStageWritesIsAnError) {
  test::TempDir dir;
  std::ostringstream log;
  const std::string config = oneFeatureTrainConfig(dir, "");
  TrainOptions o = quietTraining(config, dir, log);
  o.features = {"height_diff", "nope"};
  try {
    trainModel(o);
    FAIL() << "trained with a feature no stage writes";
  } catch (const ConfigError& e) {
    EXPECT_EQ(std::string(e.what()).find(config + ": --features: feature 'nope' is not written by "
                                                  "any stage or the source (written: "
                                                  "height_diff)"),
              0u)
        << e.what();
  }
  EXPECT_FALSE(fs::exists(o.model_out));
  // The same features from the file keep their place there.
  o.features = {"height_diff"};
  trainModel(o);
  EXPECT_TRUE(fs::exists(o.model_out));
}

// The config's min_sigma list is one floor per feature of its own list: --features in another
// order takes each feature's floor by name (by position, roughness got normal_eigenvalue's
// 0.0001 and height_diff relative_height's 0.05); features the list does not name get the
// plugin default, with a note.
TEST(Train, MinSigmaFollowsTheFeaturesByNameUnderDashDashFeatures) {
  test::TempDir dir;
  std::ostringstream log;
  std::string text = readFile(test::sourceDir() + "/configs/train/simulator.yaml");
  text = test::edited(text, "frames: 10,", "frames: 1,");
  text = test::edited(text, "{frames: [0, 9]}", "{frames: [0, 0]}");
  TrainOptions o = quietTraining(put(dir, "t.yaml", text), dir, log);
  o.features = {"relative_height", "roughness", "normal_eigenvalue", "height_diff"};
  trainModel(o);
  EXPECT_NE(YAML::LoadFile(o.model_out)["provenance"].as<std::string>().find(
                "sigma floors relative_height 0.05, roughness 0.005, normal_eigenvalue 0.0001, "
                "height_diff 0.02"),
            std::string::npos)
      << readFile(o.model_out);
  o.features = {"roughness", "height_diff", "preclass"};
  trainModel(o);
  EXPECT_NE(YAML::LoadFile(o.model_out)["provenance"].as<std::string>().find(
                "sigma floors roughness 0.0001, height_diff 0.0001, preclass 0.0001"),
            std::string::npos)
      << readFile(o.model_out);
  EXPECT_NE(log.str().find("min_sigma list is for its own features, which do not include every "
                           "one of --features"),
            std::string::npos)
      << log.str();
}

TEST(Train, WithoutASplitTheModelSaysNothingIsHeldOut) {
  test::TempDir dir;
  std::ostringstream log;
  const TrainOptions o = quietTraining(oneFeatureTrainConfig(dir, ""), dir, log);
  trainModel(o);
  EXPECT_NE(log.str().find("has no split: training on every frame of its source; no test data is "
                           "held out"),
            std::string::npos)
      << log.str();
  const YAML::Node held = YAML::LoadFile(o.model_out)["trained_from"]["held_out"];
  ASSERT_TRUE(held.IsSequence());
  EXPECT_EQ(held.size(), 0u);
}

// A split without its train list is an error at the split; the "no split" note, which would
// contradict it, is not printed.
TEST(Train, ASplitWithoutTrainIsAnErrorNotANoSplitNote) {
  test::TempDir dir;
  std::ostringstream log;
  const TrainOptions o = quietTraining(
      oneFeatureTrainConfig(dir, "split:\n  test: [{params: {seed: 1}}]\n"), dir, log);
  try {
    trainModel(o);
    FAIL() << "trained without a train list";
  } catch (const ConfigError& e) {
    ASSERT_EQ(e.diagnostics().size(), 1u) << e.what();
    EXPECT_EQ(e.diagnostics()[0].line, 5);
    EXPECT_NE(e.diagnostics()[0].message.find("split: missing 'train: [...]'"), std::string::npos);
  }
  EXPECT_EQ(log.str().find("has no split"), std::string::npos) << log.str();
  EXPECT_FALSE(fs::exists(o.model_out));
}

/// A train config reading SemanticKITTI seq 00 `frames` ("[a, b]") through `label_map`.
std::string seq00TrainConfig(test::TempDir& dir, const std::string& label_map,
                             const std::string& frames) {
  return put(dir, "train.yaml", R"(version: 1
grid: {size_m: 40, cell_m: 0.5}
source:
  type: semantickitti
  params: {path: )" + test::dataPath("semantickitti_seq00_000000-000005") +
                                    R"(, label_map: )" + label_map + R"(}
split: {train: [{frames: )" + frames + R"(}]}
stages:
  - {name: hdiff, type: height_difference}
outputs:
  - {type: feature_stats, params: {features: [height_diff], min_sigma: [0.02]}}
)");
}

// The source's parameter errors are reported where the config writes them, whether the
// training frames are the source's own or --data folders (both read copies of the entry, whose
// positions had been lost: every error stood at 1:1).
TEST(Train, ASourceParameterErrorIsReportedAtItsLine) {
  test::TempDir dir;
  const std::string map = test::sourceDir() + "/configs/label_maps/semantickitti.yaml";
  std::string text = readFile(seq00TrainConfig(dir, map, "[0, 1]"));
  text = test::edited(text, "split: {train: [{frames: [0, 1]}]}\n", "");
  text = test::edited(text, ", label_map: ", ", use_poses: maybe, label_map: ");
  const std::string config = put(dir, "bad_source.yaml", text);
  for (const bool with_data : {false, true}) {
    SCOPED_TRACE(with_data ? "--data" : "the source's own frames");
    std::ostringstream log;
    TrainOptions o = quietTraining(config, dir, log);
    if (with_data) o.data = {test::dataPath("semantickitti_seq00_000000-000005")};
    try {
      trainModel(o);
      FAIL() << "trained with a bad source parameter";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(config + ":" + test::positionOf(text, "maybe") +
                                           ": stage 'semantickitti' (semantickitti): parameter "
                                           "'use_poses': expected bool"),
                std::string::npos)
          << e.what();
    }
  }
}

// A source entry of params alone (its type lost): the copy that keeps positions re-creates the
// `params` key, so the first key had none and the error stood without a line (found by fuzzing).
TEST(Train, ASourceWithoutATypeIsReportedAtItsLine) {
  test::TempDir dir;
  const std::string map = test::sourceDir() + "/configs/label_maps/semantickitti.yaml";
  std::string text = readFile(seq00TrainConfig(dir, map, "[0, 1]"));
  text = test::edited(text, "  type: semantickitti\n", "");
  const std::string config = put(dir, "no_type.yaml", text);
  std::ostringstream log;
  try {
    trainModel(quietTraining(config, dir, log));
    FAIL() << "trained without a source type";
  } catch (const ConfigError& e) {
    const std::string line = test::positionOf(text, "params: {path");
    EXPECT_NE(std::string(e.what()).find(config + ":" + line.substr(0, line.find(':')) + ":"),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("missing key 'type'"), std::string::npos) << e.what();
  }
}

TEST(Train, UnlabelledDataIsAnErrorNamingTheSourceItsFolderAndLabelMap) {
  // Frames 3–5 of the seq 00 folder have no .label files. `terramrf train` reads one unnamed
  // source, and the message said "no labelled frame in the training data ()" (found by fuzzing).
  test::TempDir dir;
  const std::string map = test::sourceDir() + "/configs/label_maps/semantickitti.yaml";
  std::ostringstream log;
  const TrainOptions o = quietTraining(seq00TrainConfig(dir, map, "[3, 4]"), dir, log);
  try {
    trainModel(o);
    FAIL() << "trained on unlabelled frames";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "no labelled frame in the training data (source semantickitti at " +
                  test::dataPath("semantickitti_seq00_000000-000005") + ", label map " + map +
                  "): a model needs per-point ground truth"),
              std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(fs::exists(o.model_out));
}

TEST(Train, ALabelMapMissingAnIdOfTheDataFailsEveryFrameAndSaysWhichFileAndId) {
  // The label map without road's id 40: every scan of seq 00 holds road points.
  test::TempDir dir;
  std::string map = readFile(test::sourceDir() + "/configs/label_maps/semantickitti.yaml");
  const std::size_t at = map.find("road: [40, ");
  ASSERT_NE(at, std::string::npos);
  map.replace(at, 11, "road: [");
  const std::string map_path = put(dir, "no_road_id.yaml", map);
  std::ostringstream log;
  const TrainOptions o = quietTraining(seq00TrainConfig(dir, map_path, "[0, 1]"), dir, log);
  try {
    trainModel(o);
    FAIL() << "expected the training to fail";
  } catch (const ConfigError& e) {
    FAIL() << e.what();
  } catch (const std::exception& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("every training frame failed (2)"), std::string::npos) << what;
    EXPECT_NE(what.find(map_path), std::string::npos) << what;
    EXPECT_NE(what.find("raw label id 40 (road)"), std::string::npos) << what;
    EXPECT_NE(what.find("is not listed in the label map"), std::string::npos) << what;
  }
  EXPECT_FALSE(fs::exists(o.model_out));  // no model from nothing
}

// ---- interruption (SIGINT/SIGTERM) ---------------------------------------------------------

/// Clears the process-wide stop request before and after a test.
struct StopRequestGuard {
  StopRequestGuard() { clearStopRequest(); }
  ~StopRequestGuard() { clearStopRequest(); }
};

// A stop asked for during a sweep's first test run (here by a test output, as the SIGINT handler
// would): that run stops after its frame in hand and is reported failed, the runs after it are
// not run, and the report is still written, saying so; status 130. Before, nothing stopped a
// sweep but the signal itself, which lost the report.
TEST(SweepRun, AStopDuringATestRunEndsTheSweepWithItsReport) {
  StopRequestGuard guard;
  test::TempDir dir;
  std::string text =
      test::edited(tinySweep("  icm: {type: icm}"), "seed: 1, frames: 1", "seed: 1, frames: 2");
  text += "outputs: [{type: test_requests_stop, params: {after: 1}}]\n";
  const std::string sweep = put(dir, "stop.yaml", text);
  CompareOptions o;
  o.sweep_path = sweep;
  o.output_dir = dir.str() + "/out";
  o.progress = false;
  o.plugin_dirs = {test::pluginDir(), std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/requests_stop"};
  std::ostringstream log;
  o.log = &log;
  const SweepResult r = runSweep(o);
  EXPECT_EQ(r.stop_signal, SIGINT);
  EXPECT_EQ(r.exitCode(), 130);
  for (const auto& m : r.models) EXPECT_TRUE(m.trained) << m.reason;  // before the stop
  ASSERT_EQ(r.runs.size(), 2u);
  EXPECT_EQ(r.runs[0].status, RunRecord::Status::kFailed);
  EXPECT_EQ(r.runs[0].reason,
            "run interrupted (SIGINT) after 1 of 2 frame(s); its files cover those only");
  EXPECT_EQ(r.runs[0].frames_ok, 1u);
  EXPECT_EQ(r.runs[1].status, RunRecord::Status::kSkipped);
  EXPECT_EQ(r.runs[1].reason, "not run: compare interrupted (SIGINT)");
  const std::string summary = readFile(o.output_dir + "/summary.md");
  EXPECT_NE(summary.find("- **interrupted** (SIGINT)"), std::string::npos) << summary;
  EXPECT_NE(readFile(o.output_dir + "/results.json").find("\"interrupted\": \"SIGINT\""),
            std::string::npos);
  // The interrupted run's own files: its timing says it, its evaluation too.
  const std::string run_dir = r.runs[0].output_dir;
  EXPECT_EQ(readFile(run_dir + "/timing.md").rfind("Run interrupted (SIGINT) after 1 of 2", 0), 0u);
}

/// Training options for `config` whose model goes to `<dir>/models/sim.yaml`, where a model from
/// an earlier training ("a good model") is already: a training that fails must leave it as it is.
TrainOptions overAGoodModel(const test::TempDir& dir, const std::string& config,
                            std::vector<std::string> plugin_dirs) {
  TrainOptions o;
  o.config_path = config;
  o.model_out = dir.str() + "/models/sim.yaml";
  fs::create_directories(dir.str() + "/models");
  std::ofstream(o.model_out) << "a good model\n";
  o.progress = false;
  o.plugin_dirs = std::move(plugin_dirs);
  return o;
}

// `train` asked to stop: no model is written (one learnt from part of the data would pass for
// one learnt from all of it), the one there is kept, the scratch runs are removed, and the error
// says all this.
TEST(Train, AStopWritesNoModelAndKeepsTheOneThere) {
  StopRequestGuard guard;
  test::TempDir dir;
  const std::string config = put(dir, "train.yaml",
                                 std::string(R"(version: 1
grid: {size_m: 30, cell_m: 0.5}
source: {type: simulator, params: {seed: 7, frames: 3, )") +
                                     kSim + R"(}}
stages:
  - {name: pre, type: eigen_preclass}
  - {name: hdiff, type: height_difference}
  - {name: mrf, type: potts_gaussian, params: {model: m.yaml, features: [height_diff]}}
  - {name: solve, type: icm}
)");
  TrainOptions o = overAGoodModel(dir, config, {test::pluginDir()});
  std::ostringstream log;
  o.log = &log;
  requestStop(SIGTERM);
  try {
    trainModel(o);
    ADD_FAILURE() << "expected the interrupted training to throw";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(
        std::string(e.what()).rfind("training interrupted (SIGTERM) after 0 of 3 frame(s)", 0), 0u)
        << e.what();
    EXPECT_NE(
        std::string(e.what()).find("no model written (" + o.model_out + " is left as it was)"),
        std::string::npos)
        << e.what();
  }
  EXPECT_EQ(readFile(o.model_out), "a good model\n");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.str() + "/models"), fs::directory_iterator()),
            1);
}

// ---- stage lifecycle -------------------------------------------------------------------------

// compare runs its stages through the same runner: a stage that cannot begin or end a test run
// fails that run, named, in the report and the exit status; the models, whose runs it began
// and ended, are trained. Test runs have one frame, training runs two (`fail_runs_of`).
TEST(SweepRun, AStageFailingToBeginOrEndFailsItsRunByName) {
  for (const std::string hook : {"begin", "end"}) {
    test::TempDir dir;
    std::string text = tinySweep("  icm: {type: icm}");
    text = test::edited(text, "  - {name: pre, type: eigen_preclass}\n",
                        "  - {name: pre, type: eigen_preclass}\n  - {name: map, type: "
                        "test_run_map, params: {fail_in: " +
                            hook + ", fail_runs_of: 1}}\n");
    CompareOptions o;
    o.sweep_path = put(dir, "lifecycle.yaml", text);
    o.output_dir = dir.str() + "/out";
    o.progress = false;
    o.plugin_dirs = {test::pluginDir(), std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/run_map"};
    std::ostringstream log;
    o.log = &log;
    const SweepResult r = runSweep(o);
    for (const auto& m : r.models) EXPECT_TRUE(m.trained) << hook << ": " << m.reason;
    ASSERT_EQ(r.runs.size(), 2u) << hook;
    for (const auto& run : r.runs) {
      EXPECT_EQ(run.status, RunRecord::Status::kFailed) << hook;
      EXPECT_NE(run.reason.find(hook == "begin"
                                    ? "stage 'map' (test_run_map): cannot open the map store"
                                    : "stage 'map' (test_run_map): disk full while saving the map"),
                std::string::npos)
          << hook << ": " << run.reason;
    }
    EXPECT_EQ(r.exitCode(), 3) << hook;
  }
}

// train likewise: a stage that fails at the end of a training run fails the training, named,
// and writes no model (before, train never looked at a run's errors at the end).
TEST(Train, AStageFailingAtTheEndWritesNoModel) {
  test::TempDir dir;
  const std::string config = put(dir, "train.yaml",
                                 std::string(R"(version: 1
grid: {size_m: 30, cell_m: 0.5}
source: {type: simulator, params: {seed: 7, frames: 2, )") +
                                     kSim + R"(}}
stages:
  - {name: pre, type: eigen_preclass}
  - {name: map, type: test_run_map, params: {fail_in: end}}
  - {name: hdiff, type: height_difference}
  - {name: mrf, type: potts_gaussian, params: {model: m.yaml, features: [height_diff]}}
  - {name: solve, type: icm}
)");
  TrainOptions o = overAGoodModel(
      dir, config, {test::pluginDir(), std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/run_map"});
  std::ostringstream log;
  o.log = &log;
  try {
    trainModel(o);
    ADD_FAILURE() << "expected the training to fail";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("stage 'map' (test_run_map): disk full while saving the map"),
              std::string::npos)
        << what;
    EXPECT_NE(what.find("no model written (" + o.model_out + " is left as it was)"),
              std::string::npos)
        << what;
  }
  EXPECT_EQ(readFile(o.model_out), "a good model\n");
}

}  // namespace
}  // namespace terramrf
