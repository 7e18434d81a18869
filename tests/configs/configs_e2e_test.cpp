#include <gtest/gtest.h>
#include <sys/wait.h>
#include <yaml-cpp/yaml.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <regex>
#include <sstream>
#include <vector>

#include "terramrf/atomic_file.hpp"
#include "test_support.hpp"

namespace terramrf {

namespace {
struct Result {
  int status;
  std::string out;
};
Result sh(const std::string& cmd) {
  std::array<char, 4096> buf{};
  std::string out;
  FILE* p = ::popen((cmd + " 2>&1").c_str(), "r");
  while (p && std::fgets(buf.data(), buf.size(), p)) out += buf.data();
  const int st = p ? ::pclose(p) : -1;
  return {WIFEXITED(st) ? WEXITSTATUS(st) : -1, out};
}
double cellScore(const YAML::Node& s, const std::string& cls, const std::string& what) {
  for (const auto& c : s["cell_wise"]["classes"])
    if (c["name"].as<std::string>() == cls) return c[what].as<double>();
  ADD_FAILURE() << "class " << cls << " not in the summary";
  return 0;
}
double cellRecall(const YAML::Node& s, const std::string& cls) {
  return cellScore(s, cls, "recall");
}
/// A config reading the sequence `terramrf simulate` wrote to `seq` (beside it) with the
/// simulator's label map, classifying with height difference, and one output of type `output`.
std::string simulatedSeqConfig(const std::string& output) {
  return "version: 1\nsource: {type: semantickitti, params: {path: seq, label_map: " +
         test::sourceDir() +
         "/configs/label_maps/simulator.yaml}}\n"
         "stages:\n  - {name: hdiff, type: height_difference}\n"
         "  - {name: mrf, type: potts_gaussian, params: {model: " +
         test::sourceDir() +
         "/configs/models/laser_simulator.yaml, features: [height_diff]}}\n"
         "  - {name: solve, type: icm}\n"
         "outputs:\n  - {type: " + output + "}\n";
}
}  // namespace

TEST(ConfigsE2E, DemoOnTheSimulator) {
  test::TempDir out;
  const Result r = sh(test::cli() + " run " + test::sourceDir() +
                      "/configs/demo.yaml --no-progress --out " + out.str());
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("Per-stage timing"), std::string::npos) << r.out;
  EXPECT_TRUE(std::filesystem::exists(out.str() + "/grid/000000.png"));
  EXPECT_TRUE(std::filesystem::exists(out.str() + "/grid/000000_image_2.png"));
  EXPECT_TRUE(std::filesystem::exists(out.str() + "/grid_csv/000001.csv"));
  EXPECT_TRUE(std::filesystem::exists(out.str() + "/resolved_config.yaml"));
  const YAML::Node s = YAML::LoadFile(out.str() + "/evaluation/summary.json");
  // Measured on all 5 frames (docs/benchmarks.md; two Gaussians per class): obstacle 0.991 /
  // 0.967, road 0.962 / 0.971, rough 0.994 / 0.993. Guards: the targets for obstacle
  // (0.96 / 0.96), the measured figures less about 0.01 for road and rough (targets 0.90 / 0.90
  // and rough recall 0.60).
  EXPECT_GE(cellScore(s, "road", "precision"), 0.95);
  EXPECT_GE(cellRecall(s, "road"), 0.95);
  EXPECT_GE(cellScore(s, "obstacle", "precision"), 0.96);
  EXPECT_GE(cellRecall(s, "obstacle"), 0.96);
  EXPECT_GE(cellRecall(s, "rough"), 0.98);
  // The grid table carries each cell's true class for error analysis.
  EXPECT_NE(
      terramrf::readFile(out.str() + "/grid_csv/000001.csv").find(",truth,truth_name,truth_points"),
      std::string::npos);
}

// configs/lcm_record.yaml writes the demo's scans, ground truth, poses, samples and camera images
// with their calibrations to an LCM log as it classifies them; configs/lcm_replay.yaml
// classifies them again from the log. Evaluations and grid images are the same to the byte:
// nothing the stages use is lost on the way through LCM.
namespace {
/// configs/lcm_record.yaml run with its log written to `dir`/demo.lcm and its outputs to
/// `dir`/rec; the edited config is `dir`/lcm_record.yaml.
Result recordDemoLog(const test::TempDir& dir) {
  const std::string record = dir.str() + "/lcm_record.yaml";
  std::ofstream(record) << test::edited(
      test::edited(terramrf::readFile(test::sourceDir() + "/configs/lcm_record.yaml"),
                   "file://out/lcm_demo.lcm", "file://" + dir.str() + "/demo.lcm"),
      "models/laser_simulator.yaml", test::sourceDir() + "/configs/models/laser_simulator.yaml");
  return sh(test::cli() + " run " + record + " --no-progress --out " + dir.str() + "/rec");
}
}  // namespace

TEST(LcmConfigsE2E, RecordedLogReplaysToTheSameEvaluation) {
  test::TempDir dir;
  const std::string log = dir.str() + "/demo.lcm";
  const std::string record = dir.str() + "/lcm_record.yaml";
  const Result rec = recordDemoLog(dir);
  ASSERT_EQ(rec.status, 0) << rec.out;
  ASSERT_TRUE(std::filesystem::exists(log));
  const Result rep = sh(test::cli() + " run " + test::sourceDir() +
                        "/configs/lcm_replay.yaml --no-progress --data " + log + " --out " +
                        dir.str() + "/rep");
  ASSERT_EQ(rep.status, 0) << rep.out;
  EXPECT_NE(rep.out.find("5 of 5 frame(s) ok"), std::string::npos) << rep.out;
  const std::string a = terramrf::readFile(dir.str() + "/rec/evaluation/summary.json");
  EXPECT_EQ(a, terramrf::readFile(dir.str() + "/rep/evaluation/summary.json"));
  // Scored, not empty: the ground truth came through the log.
  const YAML::Node s = YAML::LoadFile(dir.str() + "/rep/evaluation/summary.json");
  EXPECT_GE(cellRecall(s, "obstacle"), 0.96);
  // The grid images, the camera's with the projected points included, to the byte: points,
  // image and calibration came through whole.
  int images = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir.str() + "/rec/grid")) {
    const std::string name = e.path().filename().string();
    images += name.find("image_2") != std::string::npos;
    EXPECT_EQ(terramrf::readFile(e.path().string()),
              terramrf::readFile(dir.str() + "/rep/grid/" + name))
        << name;
  }
  EXPECT_EQ(images, 5);
  EXPECT_EQ(rep.out.find("lcm: "), std::string::npos) << rep.out;  // no message went unused

  // configs/lcm_classify.yaml, the classifier node of a pipeline split across processes, takes
  // the feature layers from the grids the recording published and runs no feature stage: the
  // same evaluation to the byte, and the same grid images.
  const Result cls =
      sh(test::cli() + " run " + test::sourceDir() +
         "/configs/lcm_classify.yaml --no-progress --data " + log + " --out " + dir.str() + "/cls");
  ASSERT_EQ(cls.status, 0) << cls.out;
  EXPECT_NE(cls.out.find("5 of 5 frame(s) ok"), std::string::npos) << cls.out;
  EXPECT_EQ(a, terramrf::readFile(dir.str() + "/cls/evaluation/summary.json"));
  // `train` on that node's config learns from the received layers: the same class Gaussians as
  // learnt from the simulator with the feature stages themselves, and the same feature origins,
  // which came with the layers (layer_origins_t); only the provenance differs.
  const Result tl = sh(test::cli() + " train " + test::sourceDir() +
                       "/configs/lcm_classify.yaml --no-progress --data " + log + " --out " +
                       dir.str() + "/from_log.yaml");
  ASSERT_EQ(tl.status, 0) << tl.out;
  const Result ts =
      sh(test::cli() + " train " + record + " --no-progress --out " + dir.str() + "/from_sim.yaml");
  ASSERT_EQ(ts.status, 0) << ts.out;
  const YAML::Node from_log = YAML::LoadFile(dir.str() + "/from_log.yaml");
  const YAML::Node from_sim = YAML::LoadFile(dir.str() + "/from_sim.yaml");
  ASSERT_TRUE(from_log["classes"] && from_log["classes"].size() == 3u);
  EXPECT_EQ(YAML::Dump(from_log["classes"]), YAML::Dump(from_sim["classes"]));
  ASSERT_TRUE(from_log["feature_origins"]);
  EXPECT_EQ(YAML::Dump(from_log["feature_origins"]), YAML::Dump(from_sim["feature_origins"]));
  for (const auto& e : std::filesystem::directory_iterator(dir.str() + "/rec/grid")) {
    const std::string name = e.path().filename().string();
    if (name.find("image_2") != std::string::npos) continue;  // cameras not read here
    EXPECT_EQ(terramrf::readFile(e.path().string()),
              terramrf::readFile(dir.str() + "/cls/grid/" + name))
        << name;
  }
}

// A feature node whose roughness is computed otherwise than the classifier node's model was
// learnt with: the node refuses to run, naming the model and the difference, as it would for
// layers it computed itself (issue 3: a model file for other features than the config's).
TEST(LcmConfigsE2E, AClassifierNodeRefusesAModelLearntOnLayersComputedOtherwise) {
  test::TempDir dir;
  const std::string record = dir.str() + "/record.yaml";
  std::ofstream(record) << test::edited(
      test::edited(test::edited(terramrf::readFile(test::sourceDir() + "/configs/lcm_record.yaml"),
                                "file://out/lcm_demo.lcm", "file://" + dir.str() + "/demo.lcm"),
                   "models/laser_simulator.yaml",
                   test::sourceDir() + "/configs/models/laser_simulator.yaml"),
      "{name: rough, type: roughness}", "{name: rough, type: roughness, params: {window: 3}}");
  // The sender's own energy is told not to check, so the recording runs.
  std::string text = terramrf::readFile(record);
  text = test::edited(text, "      beta: 0.8\n",
                      "      beta: 0.8\n      check_feature_origins: false\n");
  std::ofstream(record) << text;
  const Result rec =
      sh(test::cli() + " run " + record + " --no-progress --limit 1 --out " + dir.str() + "/rec");
  ASSERT_EQ(rec.status, 0) << rec.out;
  const Result cls = sh(test::cli() + " run " + test::sourceDir() +
                        "/configs/lcm_classify.yaml --no-progress --data " + dir.str() +
                        "/demo.lcm --out " + dir.str() + "/cls");
  EXPECT_EQ(cls.status, 2) << cls.out;
  EXPECT_NE(cls.out.find("lcm_classify.yaml:"), std::string::npos) << cls.out;
  EXPECT_NE(cls.out.find("laser_simulator.yaml"), std::string::npos) << cls.out;
  EXPECT_NE(cls.out.find("window"), std::string::npos) << cls.out;
  EXPECT_FALSE(std::filesystem::exists(dir.str() + "/cls/evaluation")) << cls.out;
}

// configs/sweeps/lcm_layers.yaml compares feature sets and optimisers on the layers the recording
// brings, with no feature stage. The same sweep with the feature stages run on the simulator's
// scans learns the same models and scores every scan the same: the sweep over received layers is
// the sweep over computed ones.
TEST(LcmConfigsE2E, SweepOverRecordedLayersIsTheSweepOverComputedOnes) {
  test::TempDir dir;
  const Result rec = recordDemoLog(dir);
  ASSERT_EQ(rec.status, 0) << rec.out;
  const std::string sweep =
      test::edited(terramrf::readFile(test::sourceDir() + "/configs/sweeps/lcm_layers.yaml"),
                   "path: ../../out/lcm_demo.lcm", "path: " + dir.str() + "/demo.lcm");
  std::ofstream(dir.str() + "/lcm_layers.yaml") << sweep;
  const Result dry = sh(test::cli() + " compare " + dir.str() + "/lcm_layers.yaml --dry-run");
  ASSERT_EQ(dry.status, 0) << dry.out;
  const Result fromLog = sh(test::cli() + " compare " + dir.str() +
                            "/lcm_layers.yaml --no-progress --out " + dir.str() + "/log");
  ASSERT_EQ(fromLog.status, 0) << fromLog.out;

  // The recording's source and stages in place of the log; everything else as shipped.
  std::string computed = std::regex_replace(
      sweep, std::regex("  recorded:\n    type: lcm_log\n    params:\n(      [^\n]*\n)*"),
      "  recorded: {type: simulator, params: {seed: 1, frames: 5, rough_noise_m: 0.12, "
      "range_noise_m: 0.01, grass_depth_m: 0.05, gravel_depth_m: 0.02}}\n");
  computed = test::edited(computed, "feature_sets:\n",
                          "common_stages:\n  - {name: pre, type: eigen_preclass}\n"
                          "feature_sets:\n");
  computed = test::edited(
      computed, "    stages: []\n    features: [height_diff, roughness, relative_height]",
      "    stages: [{name: hdiff, type: height_difference}, {name: rough, type: roughness}, "
      "{name: relh, type: relative_height}]\n"
      "    features: [height_diff, roughness, relative_height]");
  computed = test::edited(computed, "    stages: []\n    features: [height_diff, roughness]",
                          "    stages: [{name: hdiff, type: height_difference}, {name: rough, "
                          "type: roughness}]\n    features: [height_diff, roughness]");
  ASSERT_EQ(computed.find("lcm_log"), std::string::npos) << computed;
  std::ofstream(dir.str() + "/computed.yaml") << computed;
  const Result fromSim = sh(test::cli() + " compare " + dir.str() +
                            "/computed.yaml --no-progress --out " + dir.str() + "/sim");
  ASSERT_EQ(fromSim.status, 0) << fromSim.out;

  for (const char* set : {"L", "L-rh"}) {
    const YAML::Node a = YAML::LoadFile(dir.str() + "/log/models/" + set + ".yaml");
    const YAML::Node b = YAML::LoadFile(dir.str() + "/sim/models/" + set + ".yaml");
    ASSERT_TRUE(a["classes"] && a["classes"].size() == 3u) << set;
    EXPECT_EQ(YAML::Dump(a["classes"]), YAML::Dump(b["classes"])) << set;
    ASSERT_TRUE(a["feature_origins"]) << set;  // came with the layers
    EXPECT_EQ(YAML::Dump(a["feature_origins"]), YAML::Dump(b["feature_origins"])) << set;
  }
  // Every run and scan scored, and the same, to the last digit; energies too.
  for (const char* table : {"per_scan.csv", "accuracy.csv", "energies.csv"}) {
    const std::string a = terramrf::readFile(dir.str() + "/log/" + table);
    EXPECT_EQ(a, terramrf::readFile(dir.str() + "/sim/" + table)) << table;
    EXPECT_NE(a.find("alpha_expansion"), std::string::npos) << table;
    EXPECT_NE(a.find("L-rh"), std::string::npos) << table;
  }
}

// A recorder (lcm_publish with publish_grid: false, no stage) and the textured mesh from the
// log it wrote: the same mesh files as from the simulator directly.
TEST(LcmConfigsE2E, TexturedMeshFromARecordedLogIsTheSame) {
  test::TempDir dir;
  const std::string log = dir.str() + "/mesh.lcm";
  std::string mesh = terramrf::readFile(test::sourceDir() + "/configs/mesh_demo.yaml");
  mesh = test::edited(mesh, "frames: 60", "frames: 4");
  const std::string record = test::edited(
      mesh, "outputs:\n",
      "outputs:\n  - {type: lcm_publish, params: {url: 'file://" + log +
          "?mode=w', publish_grid: false, publish_points: true, publish_pose: true, "
          "publish_images: true, publish_truth: true}}\n");
  std::ofstream(dir.str() + "/record.yaml") << record;
  const std::string replay = std::regex_replace(
      mesh, std::regex("source:\n  type: simulator\n  params: [^\n]*\n"),
      "source:\n  type: lcm_log\n  params: {path: " + log +
          ", pose_channel: TERRAMRF_GRID_POSE, images_channel: TERRAMRF_GRID_IMAGE, "
          "camera_info_channel: TERRAMRF_GRID_CAMERA_INFO, image_truth_channel: "
          "TERRAMRF_GRID_IMAGE_TRUTH, cameras: [image_2]}\n");
  ASSERT_NE(replay, mesh);
  std::ofstream(dir.str() + "/replay.yaml") << replay;
  const Result rec = sh(test::cli() + " mesh " + dir.str() + "/record.yaml --no-progress --out " +
                        dir.str() + "/rec");
  ASSERT_EQ(rec.status, 0) << rec.out;
  const Result rep = sh(test::cli() + " mesh " + dir.str() + "/replay.yaml --no-progress --out " +
                        dir.str() + "/rep");
  ASSERT_EQ(rep.status, 0) << rep.out;
  for (const char* f : {"terrain.obj", "terrain.ply", "terrain.glb"}) {
    EXPECT_EQ(terramrf::readFile(dir.str() + "/rec/mesh/" + f),
              terramrf::readFile(dir.str() + "/rep/mesh/" + f))
        << f;
  }
  // The image segmentation scored against the per-pixel truth the log carried, as directly.
  const auto scoreLine = [](const std::string& report) {
    const std::size_t at = report.find("Ground pixels found");
    return at == std::string::npos ? std::string("(none)")
                                   : report.substr(at, report.find('\n', at) - at);
  };
  const std::string direct = scoreLine(terramrf::readFile(dir.str() + "/rec/mesh/report.md"));
  EXPECT_NE(direct, "(none)");
  EXPECT_EQ(direct, scoreLine(terramrf::readFile(dir.str() + "/rep/mesh/report.md")));
}

TEST(ConfigsE2E, SemanticKittiPrintsTheEvaluation) {
  test::TempDir out;
  const std::string data = test::dataPath("semantickitti_seq00_000000-000005");
  const Result r =
      sh(test::cli() + " run " + test::sourceDir() + "/configs/semantickitti.yaml --data " + data +
         " --no-progress --out " + out.str());
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("Cell-wise"), std::string::npos) << r.out;
  const YAML::Node s = YAML::LoadFile(out.str() + "/evaluation/summary.json");
  EXPECT_EQ(s["counts"]["scans"].as<int>(), 3) << "frames 0-2 are the labelled ones";
  // Regression guards a little below the measured held-out figures (docs/benchmarks.md:
  // obstacle 0.976 / 0.945, road 0.983 / 0.930, rough recall 0.875, with roughness on a log
  // scale and two Gaussians per class; the road target 0.90 / 0.90 is met). The model is
  // learnt on the Open3D-ML scenes, whose rough ground is smoother than seq 00's.
  EXPECT_GE(cellScore(s, "obstacle", "precision"), 0.97);
  EXPECT_GE(cellScore(s, "obstacle", "recall"), 0.94);
  EXPECT_GE(cellScore(s, "road", "precision"), 0.975);
  EXPECT_GE(cellScore(s, "road", "recall"), 0.92);
  EXPECT_GE(cellScore(s, "rough", "recall"), 0.80);
}

TEST(ConfigsE2E, SimulateWritesAReadableSequence) {
  test::TempDir out;
  Result r = sh(test::cli() + " simulate --out " + out.str() + "/seq --frames 2");
  ASSERT_EQ(r.status, 0) << r.out;
  for (const char* f : {"velodyne/000000.bin", "labels/000001.label", "image_2/000000.png",
                        "calib.txt", "poses.txt", "imu.txt", "gps.txt", "odometry.txt"})
    EXPECT_TRUE(std::filesystem::exists(out.str() + "/seq/" + f)) << f;
  // The real-data reader reads it back and the pipeline scores it with the simulator label map.
  const std::string cfg = out.str() + "/c.yaml";
  std::ofstream(cfg) << simulatedSeqConfig("evaluation");
  r = sh(test::cli() + " run " + cfg + " --no-progress --out " + out.str() + "/o");
  EXPECT_EQ(r.status, 0) << r.out;
  const YAML::Node s = YAML::LoadFile(out.str() + "/o/evaluation/summary.json");
  EXPECT_EQ(s["counts"]["scans"].as<int>(), 2);
}

TEST(ConfigsE2E, BadScanInABatchIsSkippedAndReported) {
  test::TempDir out;
  Result r = sh(test::cli() + " simulate --out " + out.str() + "/seq --frames 3");
  ASSERT_EQ(r.status, 0) << r.out;
  std::ofstream(out.str() + "/seq/velodyne/000001.bin", std::ios::app) << "xyz";  // 3 stray bytes
  const std::string cfg = out.str() + "/c.yaml";
  std::ofstream(cfg) << simulatedSeqConfig("grid_csv");
  r = sh(test::cli() + " run " + cfg + " --no-progress --out " + out.str() + "/o");
  EXPECT_EQ(r.status, 3) << r.out;
  EXPECT_NE(r.out.find("000001"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("not a multiple of 16"), std::string::npos) << r.out;
  EXPECT_TRUE(std::filesystem::exists(out.str() + "/o/grid_csv/000000.csv"));
  EXPECT_FALSE(std::filesystem::exists(out.str() + "/o/grid_csv/000001.csv"));
  EXPECT_TRUE(std::filesystem::exists(out.str() + "/o/grid_csv/000002.csv"));
}

TEST(ConfigsE2E, ValidateReportsErrorsWithPositions) {
  test::TempDir d;
  const std::string cfg = d.str() + "/c.yaml";
  std::ofstream(cfg) << "version: 1\nsource: {type: simulatr}\nstages:\n  - {type: icm}\n";
  const Result r = sh(test::cli() + " validate " + cfg);
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find(cfg + ":2:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("did you mean 'simulator'"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("reads '@energy'"), std::string::npos) << r.out;
}

// ---- shipped sweeps -------------------------------------------------------------------------
namespace {
/// Rows of a CSV file as column-name → value maps (no quoting in the files read here).
std::vector<std::map<std::string, std::string>> readCsv(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::vector<std::string> head;
  std::vector<std::map<std::string, std::string>> rows;
  auto split = [](const std::string& s) {  // RFC 4180: a quoted field may hold commas and ""
    std::vector<std::string> v(1);
    bool quoted = false;
    for (std::size_t i = 0; i < s.size(); ++i) {
      const char c = s[i];
      if (quoted && c == '"' && i + 1 < s.size() && s[i + 1] == '"')
        v.back() += '"', ++i;
      else if (c == '"')
        quoted = !quoted;
      else if (c == ',' && !quoted)
        v.emplace_back();
      else
        v.back() += c;
    }
    return v;
  };
  if (std::getline(in, line)) head = split(line);
  while (std::getline(in, line)) {
    const auto v = split(line);
    std::map<std::string, std::string> r;
    for (std::size_t i = 0; i < head.size() && i < v.size(); ++i) r[head[i]] = v[i];
    rows.push_back(r);
  }
  return rows;
}

/// Cell-wise precision and recall of `cls` on one scan of one run, from per_scan.csv.
std::pair<double, double> scanScore(const std::string& dir, const std::string& feature_set,
                                    const std::string& optimiser, const std::string& frame,
                                    const std::string& cls) {
  for (const auto& r : readCsv(dir + "/per_scan.csv"))
    if (r.at("feature_set") == feature_set && r.at("optimiser") == optimiser &&
        r.at("frame") == frame && r.at("level") == "cell" && r.at("class") == cls)
      return {std::stod(r.at("precision")), std::stod(r.at("recall"))};
  ADD_FAILURE() << "no row " << feature_set << "/" << optimiser << "/" << frame << "/" << cls
                << " in " << dir << "/per_scan.csv";
  return {0, 0};
}

/// α-expansion's energy ≤ ICM's and ≤ Gibbs's on every scan (the target; 1e-9 relative
/// for rounding). Against ICM it holds by construction: α-expansion starts from the ICM result
/// and only accepts moves that lower the energy. Against Gibbs it is measured: annealed Gibbs can
/// end lower by moving a cluster of cells to two different labels at once, a move neither
/// expansions nor swaps contain (with one Gaussian per class it did on one of 44 sweep scans, by
/// 0.66 of 24 224; with two per class α-expansion is lowest on all 44).
void expectAlphaExpansionLowest(const std::string& dir) {
  std::map<std::string, std::map<std::string, double>> energy;  // set/frame → optimiser → E
  for (const auto& r : readCsv(dir + "/energies.csv"))
    energy[r.at("feature_set") + "/" + r.at("frame")][r.at("optimiser")] =
        std::stod(r.at("energy"));
  ASSERT_FALSE(energy.empty());
  for (const auto& [scan, by_opt] : energy) {
    // All three optimisers, or α-expansion would be compared with itself only.
    ASSERT_EQ(by_opt.size(), 3u) << scan;
    ASSERT_TRUE(by_opt.count("alpha_expansion")) << scan;
    for (const auto& [opt, e] : by_opt)
      EXPECT_LE(by_opt.at("alpha_expansion"), e + 1e-9 * std::fabs(e)) << scan << " vs " << opt;
  }
}

Result compare(const std::string& sweep, const std::string& out) {
  return sh(test::cli() + " compare " + test::sourceDir() + "/configs/sweeps/" + sweep +
            " --no-progress --out " + out);
}
}  // namespace

TEST(SweepsE2E, EveryShippedSweepValidates) {
  int n = 0;
  for (const auto& e : std::filesystem::directory_iterator(test::sourceDir() + "/configs/sweeps")) {
    if (e.path().extension() != ".yaml") continue;
    // Reads the log lcm_record.yaml writes: LcmConfigsE2E records it first and runs the sweep.
    if (e.path().filename() == "lcm_layers.yaml") continue;
    ++n;
    const Result r = sh(test::cli() + " compare " + e.path().string() + " --dry-run --no-progress");
    EXPECT_EQ(r.status, 0) << e.path() << "\n" << r.out;
  }
  EXPECT_GE(n, 5);
}

// The reference: Patchwork++ (default KITTI parameters, cell obstacle if any point is
// non-ground) scores obstacle P/R 0.979/0.921 on seq 00 frame 0, 0.972/0.973 on Open3D-ML 000750
// and 0.879/0.931 on the RELLIS-3D frame. These guard the figures of docs/benchmarks.md.
namespace {
/// A shipped sweep changed as `edit` says, written with absolute data and label-map paths (its
/// own are relative to configs/sweeps) to `dir`; returns the new file.
std::string editedSweep(const std::string& name, const test::TempDir& dir,
                        const std::vector<std::pair<std::string, std::string>>& edit) {
  std::string text = terramrf::readFile(test::sourceDir() + "/configs/sweeps/" + name);
  auto replaceAll = [&](const std::string& from, const std::string& to) {
    for (std::size_t at = 0; (at = text.find(from, at)) != std::string::npos; at += to.size())
      text.replace(at, from.size(), to);
  };
  replaceAll("../../../shared/data", test::dataDir());
  replaceAll("../label_maps", test::sourceDir() + "/configs/label_maps");
  for (const auto& [from, to] : edit) {
    EXPECT_NE(text.find(from), std::string::npos) << name << ": " << from;
    replaceAll(from, to);
  }
  const std::string path = dir.str() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

/// Runs a shipped sweep on its real data folder (the test fails loudly when it is missing) and
/// checks α-expansion's energies; returns the output folder's path. The sweep is read with its
/// data paths pointing where the check looked (TERRAMRF_DATA_DIR), not at its own relative ones.
std::string runSweep(const test::TempDir& out, const std::string& sweep, const std::string& data) {
  test::dataPath(data);
  const test::TempDir config;
  const Result r = sh(test::cli() + " compare " + editedSweep(sweep, config, {}) +
                      " --no-progress --out " + out.str());
  EXPECT_EQ(r.status, 0) << r.out;
  expectAlphaExpansionLowest(out.str());
  return out.str();
}
}  // namespace

// Patchwork++ scores obstacle 0.979 / 0.921 on this scan. L+G (roughness on a log scale, two
// Gaussians per class) beats it on both with every optimiser: 0.989 / 0.944 (docs/benchmarks.md).
// Guards: precision and recall above Patchwork++'s; road as measured (0.978–0.979 /
// 0.930–0.944) less about 0.01.
TEST(SweepsE2E, SemanticKittiAgainstPatchworkOnFrame0) {
  test::TempDir out;
  const std::string dir = runSweep(out, "semantickitti.yaml", "semantickitti_seq00_000000-000005");
  for (const char* opt : {"icm", "gibbs", "alpha_expansion"}) {
    const auto [p, rc] = scanScore(dir, "L+G", opt, "000000", "obstacle");
    EXPECT_GT(p, 0.979) << opt;
    EXPECT_GT(rc, 0.921) << opt;
    const auto [rp, rr] = scanScore(dir, "L+G", opt, "000000", "road");
    EXPECT_GE(rp, 0.97) << opt;
    EXPECT_GE(rr, 0.92) << opt;
  }
}

// Patchwork++ (the reference): 000750 0.972 / 0.973, RELLIS 0.879 / 0.931. L+G with ICM
// beats it on both on RELLIS (0.905 / 0.958). On 000750 its precision is higher (0.974) and its
// recall 0.971, two cells short (docs/benchmarks.md). Guards: precision above Patchwork++'s on
// both; recall above Patchwork++'s on RELLIS, as measured less 0.006 on 000750.
TEST(SweepsE2E, Open3dMl750AndRellisAgainstPatchwork) {
  struct Case {
    const char *sweep, *data, *feature_set, *frame;
    double min_precision, min_recall;
  };
  for (const Case& c :
       {Case{"semantickitti_o3dml.yaml", "semantickitti_o3dml_demo", "L+G", "000750", 0.9725,
             0.965},
        Case{"rellis3d.yaml", "rellis3d_example_000104", "L+G", "000104", 0.8795, 0.9315}}) {
    test::TempDir out;
    const auto [p, rc] =
        scanScore(runSweep(out, c.sweep, c.data), c.feature_set, "icm", c.frame, "obstacle");
    EXPECT_GE(p, c.min_precision) << c.sweep;
    EXPECT_GE(rc, c.min_recall) << c.sweep;
  }
}

// The return intensity on the one labelled data here that records it (seq 00, learnt on frames 1
// and 2, tested on frame 0; docs/plugins/features.md). Whether it helps depends on the Gaussians
// per class (rough precision, ICM: one 0.510 → 0.588, two 0.546 → 0.570, three 0.583 → 0.647),
// so the guards are the figures as measured with the shipped two, less about 0.01, for both sets
// and every optimiser (road 0.982–0.983 / 0.958–0.965, obstacle 0.984–0.993 / 0.912–0.920), the
// intensity learnt for every class, and α-expansion lowest in energy.
TEST(SweepsE2E, IntensitySweepOnSeq00) {
  test::TempDir out;
  const std::string dir =
      runSweep(out, "semantickitti_intensity.yaml", "semantickitti_seq00_000000-000005");
  for (const char* set : {"L+G", "L+G+I"})
    for (const char* opt : {"icm", "gibbs", "alpha_expansion"}) {
      const auto [rp, rr] = scanScore(dir, set, opt, "000000", "road");
      const auto [op, orc] = scanScore(dir, set, opt, "000000", "obstacle");
      EXPECT_GE(rp, 0.97) << set << " " << opt;
      EXPECT_GE(rr, 0.95) << set << " " << opt;
      EXPECT_GE(op, 0.975) << set << " " << opt;
      EXPECT_GE(orc, 0.90) << set << " " << opt;
    }
  const YAML::Node model = YAML::LoadFile(dir + "/models/L+G+I.yaml");
  for (const char* cls : {"road", "rough", "obstacle"}) {
    const YAML::Node c = model["classes"][cls];
    ASSERT_TRUE(c.IsDefined()) << cls;
    std::vector<YAML::Node> gaussians;  // a mixture's components, or the class's one Gaussian
    if (c["components"])
      for (const auto& comp : c["components"]) gaussians.push_back(comp["features"]);
    else
      gaussians.push_back(c);
    for (const YAML::Node& g : gaussians) {
      EXPECT_TRUE(g["intensity"]["mean"].IsDefined()) << cls;
      EXPECT_TRUE(g["intensity_std"]["mean"].IsDefined()) << cls;
    }
  }
}

// Off the shipped settings, with one Gaussian per class, annealed Gibbs ended below α-expansion
// with 2 × 2 block moves only (seq 00 frame 0: L+G learnt on frames 1–2 by 3.4, L-rh+G learnt on
// the Open3D-ML scans by 0.6; patches of 3 × 2 and 4 × 2 cells that two labels enter). With the
// strip moves α-expansion is lowest on every scan of both (docs/optimisers.md).
TEST(SweepsE2E, AlphaExpansionLowestWithOneGaussianPerClass) {
  test::dataPath("semantickitti_seq00_000000-000005");
  test::TempDir dir;
  const std::string intensity =
      editedSweep("semantickitti_intensity.yaml", dir, {{"components: 2}", "components: 1}"}});
  const std::string laser =
      editedSweep("semantickitti.yaml", dir,
                  {{"select: {training: {components: [1, 2, 3]}, optimiser: icm}\n", ""},
                   {"estimator: robust}", "estimator: robust, components: 1}"}});
  for (const std::string& sweep : {intensity, laser}) {
    const std::string out = dir.str() + "/out_" + std::filesystem::path(sweep).stem().string();
    const Result r = sh(test::cli() + " compare " + sweep + " --no-progress --out " + out);
    ASSERT_EQ(r.status, 0) << r.out;
    expectAlphaExpansionLowest(out);
  }
}

// The simulator sweep (paper 000 Tables 1–3 on our own data): with the Gaussians per class
// chosen on the validation world (select:; chosen L 2, L+H 4, L+FH 4 with Cheng & Sun's
// homogeneity, L+C 4) every feature set meets the obstacle target 0.96 / 0.96 with every
// optimiser (measured with α-expansion: L 0.991 / 0.967, L+H 0.976 / 0.964, L+FH 0.994 / 0.966,
// L+C 0.991 / 0.966), road ≥ 0.90 / 0.90 and rough recall
// ≥ 0.60; α-expansion has the lowest energy on all 20 (set, scan) pairs (docs/compare.md).
TEST(SweepsE2E, SimulatorSweepMeetsTheTargets) {
  test::TempDir out;
  const Result r = compare("simulator.yaml", out.str());
  ASSERT_EQ(r.status, 0) << r.out;
  expectAlphaExpansionLowest(out.str());
  std::map<std::string, std::map<std::string, std::pair<double, double>>> pr;  // run → class → P/R
  for (const auto& row : readCsv(out.str() + "/evaluation.csv"))
    if (row.at("level") == "cell")
      pr[row.at("feature_set") + "/" + row.at("optimiser")][row.at("class")] = {
          std::stod(row.at("precision")), std::stod(row.at("recall"))};
  ASSERT_EQ(pr.size(), 12u);
  for (const auto& [run, by_class] : pr) {
    EXPECT_GE(by_class.at("road").first, 0.90) << run;
    EXPECT_GE(by_class.at("road").second, 0.90) << run;
    EXPECT_GE(by_class.at("rough").second, 0.60) << run;
    EXPECT_GE(by_class.at("obstacle").first, 0.96) << run;
    EXPECT_GE(by_class.at("obstacle").second, 0.96) << run;
  }
  // One candidate chosen per feature set, on the validation world.
  std::map<std::string, int> chosen;
  for (const auto& row : readCsv(out.str() + "/selection.csv"))
    chosen[row.at("feature_set")] += std::stoi(row.at("chosen"));
  EXPECT_EQ(chosen, (std::map<std::string, int>{{"L", 1}, {"L+C", 1}, {"L+FH", 1}, {"L+H", 1}}));
  // L+FH's candidates include the homogeneity definition (a stage parameter).
  int fh_candidates = 0;
  for (const auto& row : readCsv(out.str() + "/selection.csv"))
    if (row.at("feature_set") == "L+FH") {
      ++fh_candidates;
      EXPECT_NE(row.at("candidate").find("homog.definition="), std::string::npos)
          << row.at("candidate");
    }
  EXPECT_EQ(fh_candidates, 12);  // 4 component counts × cheng_sun, local_std, local_mean
}

// docs/own_data.md's example, as shipped, on three simulated drives made as its header says.
TEST(DocsExamplesE2E, OwnDataSweepRunsOnThreeSimulatedDrives) {
  test::TempDir dir;
  const std::string example = test::sourceDir() + "/docs/examples/own_data";
  for (const char* f : {"sweep.yaml", "label_map.yaml"})
    std::filesystem::copy_file(example + "/" + f, dir.str() + "/" + f);
  for (const char* seed : {"7", "3", "1"}) {
    const Result r =
        sh(test::cli() + " simulate --config " + test::sourceDir() + "/configs/demo.yaml --out " +
           dir.str() + "/my_scans/drive_" + seed + " --seed " + seed + " --frames 3");
    ASSERT_EQ(r.status, 0) << r.out;
  }
  const Result r = sh(test::cli() + " compare " + dir.str() + "/sweep.yaml --no-progress --out " +
                      dir.str() + "/out");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("selected on validation for L: components="), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("selected on validation for L+C: components="), std::string::npos);
  for (const char* f :
       {"accuracy.md", "runtime.md", "evaluation.md", "per_scan.csv", "selection.md",
        "roc/drive_test__L+C__alpha_expansion.svg", "models/L+C.yaml"})
    EXPECT_TRUE(std::filesystem::exists(dir.str() + "/out/" + f)) << f;
  // Scored with the example's label map; the laser set finds the obstacles and the road.
  std::size_t checked = 0;
  for (const auto& row : readCsv(dir.str() + "/out/evaluation.csv"))
    if (row.at("level") == "cell" && row.at("feature_set") == "L" && row.at("class") != "rough") {
      EXPECT_GE(std::stod(row.at("recall")), 0.9) << row.at("optimiser") << " " << row.at("class");
      ++checked;
    }
  EXPECT_GE(checked, 2u) << "no cell-wise road/obstacle rows for L in evaluation.csv";
}

// ---- shipped mesh configs -------------------------------------------------------------------
namespace {
void expectMeshExport(const std::string& dir) {
  for (const char* f : {"terrain.obj", "terrain.mtl", "terrain.ply", "terrain.glb", "report.md"})
    EXPECT_TRUE(std::filesystem::exists(dir + "/mesh/" + f)) << f;
  EXPECT_FALSE(std::filesystem::is_empty(dir + "/mesh/textures"));
  // Files alone could be an empty mesh: the report's counts say there is a textured one.
  std::ifstream in(dir + "/mesh/report.md");
  const std::string report((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::smatch m;
  ASSERT_TRUE(
      std::regex_search(report, m, std::regex("vertices with data: (\\d+), textured: (\\d+)")))
      << report;
  const long with_data = std::stol(m[1]), textured = std::stol(m[2]);
  EXPECT_GT(with_data, 1000) << report;
  EXPECT_GT(textured, 0) << report;
  EXPECT_LE(textured, with_data) << report;
  ASSERT_TRUE(std::regex_search(
      report, m, std::regex("exported: (\\d+) tiles, (\\d+) vertices, (\\d+) triangles")))
      << report;
  EXPECT_GT(std::stol(m[1]), 0) << report;
  EXPECT_GT(std::stol(m[3]), 1000) << report;
}
}  // namespace

TEST(MeshConfigsE2E, KittiObjectAndRellisGiveTexturedMeshes) {
  const std::pair<const char*, const char*> runs[] = {
      {"mesh_kitti.yaml", "kitti_object_fusion/training"},
      {"mesh_rellis.yaml", "rellis3d_example_000104"}};
  for (const auto& [cfg, data] : runs) {
    test::TempDir out;
    const Result r = sh(test::cli() + " mesh " + test::sourceDir() + "/configs/" + cfg +
                        " --data " + test::dataPath(data) + " --no-progress --out " + out.str());
    ASSERT_EQ(r.status, 0) << cfg << "\n" << r.out;
    expectMeshExport(out.str());
  }
}

TEST(MeshConfigsE2E, DemoFirstFramesWithGroundTruthReport) {
  test::TempDir out;
  const Result r = sh(test::cli() + " mesh " + test::sourceDir() +
                      "/configs/mesh_demo.yaml --limit 3 --no-progress --out " + out.str());
  ASSERT_EQ(r.status, 0) << r.out;
  expectMeshExport(out.str());
  std::ifstream in(out.str() + "/mesh/report.md");
  const std::string report((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(report.find("Ground pixels found"), std::string::npos) << report;
}

}  // namespace terramrf
