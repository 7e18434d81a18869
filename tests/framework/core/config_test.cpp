#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include "config_fixture.hpp"

namespace terramrf {

namespace {
std::vector<std::string> errorsOf(test::ConfigFixture& f, const std::string& text,
                                  LoadOptions lo = {}) {
  const std::string path = f.write("c.yaml", text);
  try {
    loadPipeline(path, lo, f.registry);
  } catch (const ConfigError& e) {
    std::vector<std::string> v;
    for (const auto& d : e.diagnostics()) v.push_back(d.str());
    return v;
  }
  return {};
}
bool contains(const std::vector<std::string>& v, const std::string& s) {
  for (const auto& x : v)
    if (x.find(s) != std::string::npos) return true;
  return false;
}
std::string joined(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += x + "\n";
  return s;
}
}  // namespace

TEST(Config, ValidPipelineLoadsWithDefaultsResolved) {
  test::ConfigFixture f;
  LoadOptions lo;
  lo.output_dir = f.dir.str() + "/out";
  Pipeline p = loadPipeline(f.write("ok.yaml", test::ConfigFixture::validPipeline()), lo, f.registry);
  EXPECT_EQ(p.stages.size(), 4u);
  EXPECT_EQ(p.source->size(), 3u);
  EXPECT_EQ(p.grid.cols(), 80);
  EXPECT_NE(p.resolved_yaml.find("threshold_m2"), std::string::npos) << p.resolved_yaml;
  EXPECT_NE(p.resolved_yaml.find("max_sweeps"), std::string::npos);
}

TEST(Config, ReportsAllErrorsWithPositions) {
  test::ConfigFixture f;
  const std::string text =
      "version: 1\n"
      "grid: {size_m: 400, cell_m: 0.5}\n"                                    // line 2
      "source: {type: test_synthetic, params: {frames: 3, framez: 2}}\n"      // line 3
      "stages:\n"
      "  - {name: pre, type: eigen_preclas}\n"                                // line 5
      "  - {name: hdiff, type: height_difference, params: {min_points: 0}}\n" // line 6
      "  - {name: mrf, type: potts_gaussian, params: {features: [height_diff]}}\n"  // line 7
      "  - {name: solve, type: icm, params: {max_sweeps: many}}\n"           // line 8
      "outputs: []\n"
      "extra: 1\n";                                                           // line 10
  const auto errs = errorsOf(f, text);
  const std::string all = joined(errs);
  EXPECT_TRUE(contains(errs, ":2:")) << all;
  EXPECT_TRUE(contains(errs, "grid.size_m = 400 out of range: expected [20, 100] m")) << all;
  EXPECT_TRUE(contains(errs, ":3:")) << all;
  EXPECT_TRUE(contains(errs, "stage 'test_synthetic' (test_synthetic): unknown parameter 'framez' (did you mean 'frames'?)")) << all;
  EXPECT_TRUE(contains(errs, ":5:")) << all;
  EXPECT_TRUE(contains(errs, "unknown plugin type 'eigen_preclas' (did you mean 'eigen_preclass'?)")) << all;
  EXPECT_TRUE(contains(errs, ":6:")) << all;
  EXPECT_TRUE(contains(errs, "stage 'hdiff' (height_difference): parameter 'min_points': value 0 out of range")) << all;
  EXPECT_TRUE(contains(errs, ":7:")) << all;
  EXPECT_TRUE(contains(errs, "missing required parameter 'model'")) << all;
  EXPECT_TRUE(contains(errs, ":8:")) << all;
  EXPECT_TRUE(contains(errs, "parameter 'max_sweeps': expected int, got 'many'")) << all;
  EXPECT_TRUE(contains(errs, ":10:")) << all;
  EXPECT_TRUE(contains(errs, "unknown key 'extra' in the config")) << all;
  EXPECT_GE(errs.size(), 7u) << all;
  // Every diagnostic starts with the file name.
  for (const auto& e : errs) EXPECT_EQ(e.rfind(f.dir.str() + "/c.yaml", 0), 0u) << e;
}

TEST(Config, LayerReadThatNoEarlierStageWrites) {
  test::ConfigFixture f;
  const std::string text =
      "version: 1\n"
      "source: {type: test_synthetic}\n"
      "stages:\n"
      "  - {name: mrf, type: potts_gaussian, params: {model: model.yaml, features: [height_diff]}}\n"
      "  - {name: hdiff, type: height_difference}\n"
      "  - {name: solve, type: icm}\n";
  const auto errs = errorsOf(f, text);
  EXPECT_TRUE(contains(errs, "c.yaml:4:5: stage 'mrf' (potts_gaussian): reads 'height_diff', which no earlier stage writes"))
      << joined(errs);
}

// A stage that cannot be made is reported once: what it would have written is unknown, so the
// stages after it are not also told that nobody writes their inputs.
TEST(Config, AStageThatCannotBeMadeIsNotReportedAgainByTheReadsAfterIt) {
  test::ConfigFixture f;
  const std::string text = test::edited(test::ConfigFixture::validPipeline(), "model: model.yaml",
                                        "model: nowhere.yaml");
  const auto errs = errorsOf(f, text);
  EXPECT_TRUE(contains(errs, "stage 'mrf' (potts_gaussian): parameter 'model'")) << joined(errs);
  EXPECT_FALSE(contains(errs, "which no earlier stage writes")) << joined(errs);
  EXPECT_EQ(errs.size(), 1u) << joined(errs);
}

// A source that cannot be made may be the one that brings layers computed elsewhere (an
// lcm_log with grid_layers whose log is missing): the reads after it are not reported as well.
TEST(Config, ASourceThatCannotBeMadeIsNotReportedAgainByTheReadsAfterIt) {
  test::ConfigFixture f;
  const std::string text = test::edited(
      test::ConfigFixture::validPipeline("{path: no/such/log, grid_layers: [height_diff]}"),
      "  - {name: hdiff, type: height_difference}\n", "");
  const auto errs = errorsOf(f, text);
  EXPECT_TRUE(contains(errs, "no/such/log' does not exist")) << joined(errs);
  EXPECT_EQ(errs.size(), 1u) << joined(errs);
  // What only stages make is still checked: an optimiser without an energy stage.
  std::string no_energy_text = text;
  const std::size_t mrf = no_energy_text.find("  - {name: mrf");
  no_energy_text.erase(mrf, no_energy_text.find('\n', mrf) + 1 - mrf);
  const auto no_energy = errorsOf(f, no_energy_text);
  EXPECT_TRUE(contains(no_energy, "reads '@energy'")) << joined(no_energy);
  // Made, the same source satisfies the read; without its grid_layers the read is refused.
  EXPECT_TRUE(errorsOf(f, test::edited(text, "path: no/such/log, ", "")).empty());
  const auto without = errorsOf(
      f, test::edited(text, "{path: no/such/log, grid_layers: [height_diff]}", "{frames: 3}"));
  EXPECT_TRUE(contains(without, "reads 'height_diff', which no earlier stage writes"))
      << joined(without);
}

// The runner times its own steps under these names; a stage of the same name would share their row
// in timing.md and be counted as reading in compare's runtime table.
TEST(Config, StageNamesOfTheRunnersOwnTimingAreRejected) {
  test::ConfigFixture f;
  for (const std::string name : {"read", "grid", "total"}) {
    std::string text = test::ConfigFixture::validPipeline();
    text.replace(text.find("name: hdiff"), 11, "name: '" + name + "'");
    const auto errs = errorsOf(f, text);
    EXPECT_TRUE(contains(errs, "c.yaml:6:12: stage '" + name +
                                   "' (height_difference): stage name '" + name +
                                   "' is the runner's own"))
        << joined(errs);
  }
  // "read wait" cannot be a stage name anyway: names are plain words.
  std::string wait = test::ConfigFixture::validPipeline();
  wait.replace(wait.find("name: hdiff"), 11, "name: 'read wait'");
  EXPECT_TRUE(contains(errorsOf(f, wait),
                       "c.yaml:6:12: stage of type 'height_difference': 'name' "
                       "must be a non-empty name"))
      << joined(errorsOf(f, wait));
  // Outputs are timed as "output:<name>", so the names stay free there.
  std::string text = test::ConfigFixture::validPipeline();
  text.replace(text.find("outputs: []"), 11, "outputs: [{name: grid, type: grid_png}]");
  EXPECT_TRUE(errorsOf(f, text).empty()) << joined(errorsOf(f, text));
}

// Values that yaml-cpp's Scalar() reads as "" (a list, a null) are errors at their own line,
// not an empty name, type or folder.
TEST(Config, NamesTypesAndFoldersMustBeWords) {
  test::ConfigFixture f;
  auto with = [](const std::string& from, const std::string& to) {
    std::string text = test::ConfigFixture::validPipeline();
    text.replace(text.find(from), from.size(), to);
    return text;
  };
  struct Case {
    std::string text, error;
  };
  const std::vector<Case> cases = {
      {with("name: hdiff", "name: [a, b]"),
       "c.yaml:6:12: stage of type 'height_difference': 'name' must be a non-empty name of "
       "letters, digits, '_', '-' and '.' (it heads the timing table's rows and the metric "
       "keys), got a list"},
      {with("name: hdiff", "name: ~"), "c.yaml:6:6: stage of type 'height_difference': 'name' "},
      {with("name: hdiff", "name: 'a|b'"), "got 'a|b'"},
      {with("type: icm", "type: [icm]"),
       "c.yaml:8:25: 'type' must be a plugin type name, got a list"},
      {with("outputs: []", "output_dir: [a, b]\noutputs: []"),
       "c.yaml:9:13: 'output_dir' must be a folder name (a non-empty string), got a list"},
      {with("outputs: []", "output_dir:\noutputs: []"),
       "c.yaml:9:1: 'output_dir' must be a folder name (a non-empty string), got nothing"},
      {with("outputs: []", "output_dir: ''\noutputs: []"),
       "c.yaml:9:13: 'output_dir' must be a folder name (a non-empty string), got ''"},
      {with("outputs: []", "outputs:\nlabels: ~"), "c.yaml:9:1: 'outputs' must be a list"},
      {with("type: height_difference}", "type: height_difference, params: {? [a, b] : 3}}"),
       "stage 'hdiff' (height_difference): parameter names must be plain words, got a list"},
      {with("type: height_difference}", "type: height_difference, params: {<<: {min_points: 2}}}"),
       "YAML merge keys ('<<: *anchor') are not supported"},
  };
  for (const Case& c : cases) {
    const auto errs = errorsOf(f, c.text);
    EXPECT_TRUE(contains(errs, c.error)) << c.text << "\n" << joined(errs);
  }
}

TEST(Config, OptimiserWithoutEnergyIsRejected) {
  test::ConfigFixture f;
  const auto errs = errorsOf(f, "version: 1\nsource: {type: test_synthetic}\nstages:\n  - {type: icm}\n");
  EXPECT_TRUE(contains(errs, "stage 'icm' (icm): reads '@energy'")) << joined(errs);
}

TEST(Config, MissingDataPathIsNamed) {
  test::ConfigFixture f;
  auto errs = errorsOf(f, test::ConfigFixture::validPipeline("{path: no/such/folder}"));
  EXPECT_TRUE(contains(errs, "data path '" + f.dir.str() + "/no/such/folder' does not exist"))
      << joined(errs);
  LoadOptions lo;
  lo.data_override = f.dir.str() + "/elsewhere";
  errs = errorsOf(f, test::ConfigFixture::validPipeline(), lo);
  EXPECT_TRUE(contains(errs, "elsewhere' does not exist")) << joined(errs);
}

// --data replaces the config's path: the config's own need not exist on this machine, and only
// the override is checked.
TEST(Config, DataOverrideReplacesAMissingConfigPath) {
  test::ConfigFixture f;
  LoadOptions lo;
  lo.data_override = f.dir.str();
  auto errs = errorsOf(f, test::ConfigFixture::validPipeline("{path: no/such/folder}"), lo);
  EXPECT_FALSE(contains(errs, "no/such/folder")) << joined(errs);
  lo.data_override = f.dir.str() + "/elsewhere";
  errs = errorsOf(f, test::ConfigFixture::validPipeline("{path: no/such/folder}"), lo);
  EXPECT_TRUE(contains(errs, "elsewhere' does not exist")) << joined(errs);
  EXPECT_FALSE(contains(errs, "no/such/folder")) << joined(errs);
  // A value of the wrong kind is still refused.
  lo.data_override = f.dir.str();
  errs = errorsOf(f, test::ConfigFixture::validPipeline("{path: [a, b]}"), lo);
  EXPECT_TRUE(contains(errs, "parameter 'path'")) << joined(errs);
}

TEST(Config, WrongKindAndWrongTypeAndChoices) {
  test::ConfigFixture f;
  const auto errs = errorsOf(
      f, "version: 1\nsource: {type: icm}\nstages:\n  - {type: test_synthetic, params: {mode: plain}}\n");
  EXPECT_TRUE(contains(errs, "'icm' is a optimiser plugin, but source takes source plugins")) << joined(errs);
  EXPECT_TRUE(contains(errs, "'test_synthetic' is a source plugin")) << joined(errs);
}

TEST(Config, ModelForOtherFeaturesIsRejected) {
  test::ConfigFixture f;
  std::string text = test::ConfigFixture::validPipeline();
  text.replace(text.find("features: [height_diff]"), 23, "features: [height_diff, roughness]");
  const auto errs = errorsOf(f, text);
  EXPECT_TRUE(contains(errs, "feature 'roughness' is not in model")) << joined(errs);
}

TEST(Config, SyntaxErrorAndMissingFile) {
  test::ConfigFixture f;
  auto errs = errorsOf(f, "version: 1\nsource: {type: [\n");
  EXPECT_TRUE(contains(errs, "YAML syntax error")) << joined(errs);
  try {
    loadPipeline(f.dir.str() + "/absent.yaml", {}, f.registry);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("absent.yaml: config file does not exist"), std::string::npos);
  }
}

TEST(Config, SectionsOfTheWrongShapeAreDiagnosticsNotYamlCppErrors) {
  // Found by fuzzing (docs/robustness.md): `grid: -1` ended the load with yaml-cpp's "operator[]
  // call on a scalar" and no file or line, and a nested plugin_path entry was read as "".
  test::ConfigFixture f;
  for (const char* grid : {"-1", "abc", "[40, 0.5]", "~"}) {
    std::string text = test::ConfigFixture::validPipeline();
    const std::size_t at = text.find("grid:");
    ASSERT_NE(at, std::string::npos);
    text.replace(at, text.find('\n', at) - at, std::string("grid: ") + grid);
    const int line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + at, '\n'));
    std::vector<std::string> errs;
    ASSERT_NO_THROW(errs = errorsOf(f, text)) << grid;
    EXPECT_TRUE(contains(
        errs, "c.yaml:" + std::to_string(line) + ":7: 'grid' must be a map {size_m, cell_m}"))
        << grid << "\n"
        << joined(errs);
  }
  // A file of comments only has no position to point at: it says what it holds instead.
  for (const char* text : {"", "# all commented out\n# version: 1\n"}) {
    const auto e = errorsOf(f, text);
    ASSERT_EQ(e.size(), 1u) << joined(e);
    EXPECT_EQ(e[0], f.dir.str() +
                        "/c.yaml: the file holds nothing (empty, or comments only); "
                        "expected a map with keys version, grid, source, stages, outputs");
  }
  EXPECT_TRUE(contains(errorsOf(f, "just words\n"),
                       "c.yaml:1:1: expected a map with keys version, grid, source, stages"));
  const auto errs = errorsOf(
      f, "plugin_path: [[a, b], " + f.dir.str() + "]\n" + test::ConfigFixture::validPipeline());
  EXPECT_TRUE(contains(errs, "c.yaml:1:15: plugin_path entries must be folder names"))
      << joined(errs);
  EXPECT_EQ(errs.size(), 1u) << joined(errs);
}

// A hand-written descriptor that declares an output a source: refused at the entry's type (before,
// static_cast to a Source and read as one: garbage or a crash at the first frame).
TEST(Config, APluginNotOfItsDeclaredKindIsRefusedAtItsType) {
  test::ConfigFixture f;
  const std::string text = "plugin_path: [" + std::string(TERRAMRF_TEST_PLUGIN_DIR) +
                           "/bad_descriptors]\n" +
                           test::edited(test::ConfigFixture::validPipeline(),
                                        "type: test_synthetic", "type: test_bad_wrong_kind");
  const auto errs = errorsOf(f, text);
  EXPECT_TRUE(contains(errs, "c.yaml:4:16: stage 'test_bad_wrong_kind' (test_bad_wrong_kind): " +
                                 std::string(TERRAMRF_TEST_PLUGIN_DIR) +
                                 "/bad_descriptors/wrong_kind.so: 'test_bad_wrong_kind' is "
                                 "declared a source plugin, but its class does not derive from "
                                 "terramrf::Source"))
      << joined(errs);
}

// A plugin_path folder that is not there is the config's error at its line, and not also a
// registry warning about the same folder.
TEST(Config, AMissingPluginPathFolderIsAnErrorAtItsLineOnly) {
  test::ConfigFixture f;
  const auto errs =
      errorsOf(f, "plugin_path: [no_such_folder]\n" + test::ConfigFixture::validPipeline());
  EXPECT_TRUE(contains(
      errs, "c.yaml:1:15: plugin_path entry '" + f.dir.str() + "/no_such_folder' is not a folder"))
      << joined(errs);
  for (const auto& p : f.registry.problems())
    EXPECT_EQ(p.find("no_such_folder"), std::string::npos) << p;
}

TEST(Config, RepeatedKeysAreRejectedAtTheRepeat) {
  // yaml-cpp keeps both entries and lookups return the first: the second would be ignored.
  test::ConfigFixture f;
  std::string text = test::ConfigFixture::validPipeline();
  const std::size_t at = text.find("grid:");
  ASSERT_NE(at, std::string::npos);
  const int line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + at, '\n'));
  text.insert(at, "grid: {size_m: 10, cell_m: 1.0}\n");
  const auto errs = errorsOf(f, text);
  EXPECT_TRUE(contains(errs, "c.yaml:" + std::to_string(line + 1) +
                                 ":1: duplicate key 'grid' (first at line " + std::to_string(line) +
                                 ")"))
      << joined(errs);
}

// Each malformed entry of the common keys and the stage list is reported at that entry, in the
// config's words: these paths had no test (coverage), and `labels:` reported yaml-cpp's own
// conversion message at the list's start, and took a colour of 300 as 44.
namespace {
// `n` label entries in flow style: unknown, then c1, c2, ...
std::string manyLabels(int n) {
  std::string s = "{name: unknown, color: [0, 0, 0]}";
  for (int i = 1; i < n; ++i) s += ", {name: c" + std::to_string(i) + ", color: [1, 1, 1]}";
  return s;
}
}  // namespace

TEST(Config, EachMalformedEntryIsNamedAtItsPlace) {
  test::ConfigFixture f;
  const std::string base = test::ConfigFixture::validPipeline();
  const std::string grid = "grid: {size_m: 40, cell_m: 0.5}\n";
  const std::string labels_ok =
      "labels:\n  - {name: unknown, color: [0, 0, 0]}\n  - {name: road, color: [128, 128, 128]}\n";
  struct Case {
    std::string text, token;
    int nth;
    std::string message;
  };
  const std::vector<Case> cases = {
      {test::edited(base, "cell_m: 0.5", "cell_m: half"), "half", 1,
       "grid.cell_m: expected a number in metres"},
      {test::edited(base, "cell_m: 0.5", "cell_m: .nan"), ".nan", 1,
       "grid.cell_m = nan out of range: expected [0.05, 5] m"},
      {test::edited(base, "cell_m: 0.5", "cell_m: 0.3"), "40", 1,
       "grid.size_m = 40 is not a whole number of 0.3 m cells (133.333); expected a multiple of "
       "cell_m, e.g. 39.9 or 40.2"},
      {"plugin_path: plugins\n" + base, "plugins", 1, "'plugin_path' must be a list of folders"},
      {"plugin_path: [no_such_folder]\n" + base, "no_such_folder", 1,
       "plugin_path entry '" + f.dir.str() + "/no_such_folder' is not a folder"},
      {test::edited(base, grid, grid + "labels: road\n"), "road", 1,
       "'labels' must be a non-empty list: expected a list of {name, color: [r, g, b]}, the first "
       "named 'unknown'"},
      {test::edited(base, grid, grid + "labels:\n  - {name: road, color: [1, 2, 3]}\n"), "road", 1,
       "labels[0]: the first class (id 0, no data) must be named 'unknown', got 'road'"},
      {test::edited(base, grid, grid + labels_ok + "  - {name: rough, color: [300, 0, 0]}\n"),
       "[300", 1, "labels[2].color: expected [r, g, b], three integers from 0 to 255"},
      {test::edited(base, grid, grid + labels_ok + "  - {name: rough, color: [9, 9]}\n"), "[9, 9]",
       1, "labels[2].color: expected [r, g, b], three integers from 0 to 255"},
      {test::edited(base, grid, grid + labels_ok + "  - {name: road, color: [9, 9, 9]}\n"), "road",
       2, "labels[2]: class 'road' is listed twice"},
      {test::edited(base, grid, grid + labels_ok + "  - {name: rough, colour: [9, 9, 9]}\n"),
       "colour", 1, "unknown key 'colour' in labels[2] (did you mean 'color'?)"},
      {test::edited(base, grid, grid + labels_ok + "  - {color: [9, 9, 9]}\n"), "{color", 1,
       "labels[2]: expected 'name: <class name>'"},
      {test::edited(base, grid, grid + labels_ok + "  - {name: '', color: [9, 9, 9]}\n"), "''", 1,
       "labels[2]: expected 'name: <class name>'"},
      {test::edited(base, grid, grid + labels_ok + "  - {name: 'road, wet', color: [9, 9, 9]}\n"),
       "'road, wet'", 1,
       "labels[2].name: 'road, wet' holds characters other than letters, digits, '_' and '-'; "
       "class names become layer names (score.<class>) and table columns, e.g. 'parking_lot'"},
      {test::edited(base, grid, grid + "labels: [" + manyLabels(256) + "]\n"), "[{name", 1,
       "labels: 256 classes; at most 255 (ids are bytes)"},
      {test::edited(base, grid, grid + labels_ok + "  - rough\n"), "rough", 1,
       "labels[2]: expected a list of {name, color: [r, g, b]}"},
      {test::edited(base, grid, grid + labels_ok + "  - {name: unknown, color: [9, 9, 9]}\n"),
       "unknown", 2, "labels[2]: 'unknown' must be the first class (id 0)"},
      {test::edited(base, "  - {name: solve, type: icm}\n", "  - icm\n"), "icm", 1,
       "stages entries must be maps {name, type, params}"},
      {test::edited(base, "name: pre, type: eigen_preclass", "name: hdiff, type: eigen_preclass"),
       "hdiff", 2,
       "stage 'hdiff' (height_difference): duplicate stage name 'hdiff' (give each a unique "
       "name:)"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.message);
    const auto errs = errorsOf(f, c.text);
    EXPECT_TRUE(
        contains(errs, "c.yaml:" + test::positionOf(c.text, c.token, c.nth) + ": " + c.message))
        << "expected at " << test::positionOf(c.text, c.token, c.nth) << ":\n"
        << joined(errs) << "in:\n"
        << c.text;
  }
}

// A config's own label set reaches every stage: the energy offers its classes, and the run
// scores them.
TEST(Config, OwnLabelSetIsUsedByTheEnergy) {
  test::ConfigFixture f;
  f.write("model5.yaml", R"(classes:
  road:     {height_diff: {mean: 0.02, sigma: 0.02}}
  kerb:     {height_diff: {mean: 0.12, sigma: 0.03}}
  rough:    {height_diff: {mean: 0.08, sigma: 0.05}}
  obstacle: {height_diff: {mean: 1.0, sigma: 0.8}}
)");
  std::string text =
      test::edited(test::ConfigFixture::validPipeline(), "model: model.yaml", "model: model5.yaml");
  text = test::edited(text, "grid: {size_m: 40, cell_m: 0.5}\n",
                      "grid: {size_m: 40, cell_m: 0.5}\n"
                      "labels:\n"
                      "  - {name: unknown, color: [0, 0, 0]}\n"
                      "  - {name: road, color: [128, 128, 128]}\n"
                      "  - {name: kerb, color: [255, 255, 0]}\n"
                      "  - {name: rough, color: [139, 90, 43]}\n"
                      "  - {name: obstacle, color: [220, 30, 30]}\n");
  LoadOptions lo;
  lo.output_dir = f.dir.str() + "/out";
  Pipeline p = loadPipeline(f.write("c.yaml", text), lo, f.registry);
  ASSERT_TRUE(p.labels);
  ASSERT_EQ(p.labels->size(), 5u);
  EXPECT_EQ(p.labels->name(2), "kerb");
  EXPECT_EQ((*p.labels)[2].rgb[0], 255);
  EXPECT_NE(p.resolved_yaml.find("kerb"), std::string::npos) << p.resolved_yaml;
  // The stages driven by hand on one frame: the energy's labels are the set's four classes.
  const test::StagesByHand run(p, 0);
  ASSERT_EQ(run.ctx.energy.numLabels(), 4);
  EXPECT_EQ(run.ctx.energy.active[1], 2);  // kerb
}

TEST(Config, ShippedConfigsValidate) {
  // Every pipeline config shipped in configs/ and configs/train/ must load (the data folders they
  // name are the shared ones). Model files, label maps and sweeps are not pipelines.
  PluginRegistry reg({test::pluginDir()});
  int n = 0;
  bool demo = false;
  for (const std::string sub : {"", "/train"}) {
    for (const auto& e : std::filesystem::directory_iterator(test::sourceDir() + "/configs" + sub)) {
      if (e.path().extension() != ".yaml") continue;
      // Read the log lcm_record.yaml writes: LcmConfigsE2E (tests/configs) records it first.
      if (e.path().filename() == "lcm_replay.yaml" || e.path().filename() == "lcm_classify.yaml")
        continue;
      SCOPED_TRACE(e.path().string());
      ++n;
      demo |= e.path().filename() == "demo.yaml";
      try {
        LoadOptions lo;
        lo.output_dir = test::TempDir().str();
        Pipeline p = loadPipeline(e.path().string(), lo, reg);
        EXPECT_GT(p.source->size(), 0u);
      } catch (const ConfigError& err) {
        ADD_FAILURE() << err.what();
      }
    }
  }
  EXPECT_TRUE(demo);
  EXPECT_GE(n, 4);
}

}  // namespace terramrf
