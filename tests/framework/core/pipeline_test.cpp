#include "terramrf/pipeline.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <optional>
#include <sstream>
#include <tuple>

#include "config_fixture.hpp"
#include "terramrf/atomic_file.hpp"
#include "terramrf/stop_request.hpp"

namespace terramrf {

namespace {
/// Runs the synthetic test pipeline with `source_params` quietly (progress off, log to `log`);
/// outputs go to `<fixture>/out`.
RunResult runSynthetic(test::ConfigFixture& f, const std::string& source_params, std::ostream& log) {
  Pipeline p = f.loadSynthetic(source_params);
  RunOptions ro;
  ro.progress = false;
  ro.log = &log;
  return runPipeline(p, ro);
}
}  // namespace

TEST(StageTiming, StatisticsAreSampleStatisticsAndUndefinedStdFromOneScan) {
  StageTiming t;
  t.ms = {4.0};
  EXPECT_TRUE(std::isnan(t.stddev()));  // not 0: one scan says nothing about the spread
  EXPECT_DOUBLE_EQ(t.mean(), 4.0);
  t.ms = {1.0, 2.0, 6.0};
  EXPECT_DOUBLE_EQ(t.mean(), 3.0);
  EXPECT_DOUBLE_EQ(t.stddev(), std::sqrt(7.0));  // ((4 + 1 + 9) / (3 - 1))^0.5
  EXPECT_DOUBLE_EQ(t.median(), 2.0);
  RunResult r;
  r.timings.push_back({"solve", {4.0}});
  EXPECT_NE(timingTable(r).find("| solve | 4.000 | – | 4.000 | 4.000 | 4.000 |"), std::string::npos)
      << timingTable(r);
}

TEST(Pipeline, ClassifiesPlaneAndBox) {
  test::ConfigFixture f;
  LoadOptions lo;
  lo.output_dir = f.dir.str() + "/out";
  Pipeline p = loadPipeline(f.write("ok.yaml", test::ConfigFixture::validPipeline("{frames: 1}")),
                            lo, f.registry);
  RunOptions ro;
  ro.progress = false;
  RunResult r = runPipeline(p, ro);
  EXPECT_EQ(r.exitCode(), 0);
  EXPECT_EQ(r.summary.frames_ok, 1u);
  EXPECT_TRUE(std::filesystem::exists(lo.output_dir + "/resolved_config.yaml"));
  // Timing slots: read, read wait, grid, 4 stages, total.
  ASSERT_EQ(r.timings.size(), 8u);
  EXPECT_EQ(r.timings[2].name, "grid");
  EXPECT_EQ(r.timings[2].ms.size(), 1u);

  // The same stages driven by hand: the box's cells are obstacles, the plane is not.
  const test::StagesByHand run(p, 0);
  const FrameContext& ctx = run.ctx;
  const TerrainGrid& grid = run.grid;
  EXPECT_LE(ctx.optimiser.final_energy, ctx.optimiser.initial_energy);
  EXPECT_EQ(grid.labels()[p.grid.cellOf(3.05, 0.3)], labels::kObstacle);
  EXPECT_EQ(grid.labels()[p.grid.cellOf(-5.2, 5.2)], labels::kRoad);  // flat plane, tiny noise
  EXPECT_EQ(grid.labels()[p.grid.cellOf(15, 15)], labels::kUnknown);  // no points
}

TEST(Pipeline, BadFrameIsReportedAndSkipped) {
  test::ConfigFixture f;
  std::ostringstream log;
  const RunResult r = runSynthetic(f, "{frames: 4, bad_frames: [1, 2]}", log);
  EXPECT_EQ(r.summary.frames_ok, 2u);
  ASSERT_EQ(r.summary.failed.size(), 2u);
  EXPECT_EQ(r.summary.failed[0].first, "000001");
  EXPECT_NE(r.summary.failed[0].second.find("synthetic/000001.bin: size 13 bytes is not a multiple of 16"),
            std::string::npos);
  EXPECT_NE(log.str().find("frame 000002 failed and was skipped"), std::string::npos) << log.str();
  EXPECT_EQ(r.exitCode(), 3);
}

namespace {
/// An output whose end() fails, or that counts what it saw.
struct ProbeOutput : Output {
  bool fail_at_end = false;
  int* frames = nullptr;
  bool* ended = nullptr;
  void write(const FrameContext&) override { ++*frames; }
  void end(const RunSummary&) override {
    if (fail_at_end) throw std::runtime_error("disk full while writing summary.json");
    *ended = true;
  }
};
}  // namespace

// An output that fails at the end costs the run its exit status, not the other outputs' ends,
// and says which output failed and why.
TEST(Pipeline, AnOutputFailingAtTheEndIsReportedAndTheOthersStillEnd) {
  test::ConfigFixture f;
  Pipeline p = f.loadSynthetic("{frames: 2}");
  int frames_a = 0, frames_b = 0;
  bool ended_a = false, ended_b = false;
  auto probe = [&](const char* name, bool fail, int* frames, bool* ended) {
    auto o = std::make_unique<ProbeOutput>();
    o->setIdentity(name, "probe");
    o->fail_at_end = fail;
    o->frames = frames;
    o->ended = ended;
    p.outputs.emplace_back(std::move(o));
  };
  probe("first", true, &frames_a, &ended_a);
  probe("second", false, &frames_b, &ended_b);
  std::ostringstream log;
  RunOptions ro;
  ro.progress = false;
  ro.log = &log;
  const RunResult r = runPipeline(p, ro);
  EXPECT_EQ(r.summary.frames_ok, 2u);
  EXPECT_EQ(frames_a, 2);
  EXPECT_EQ(frames_b, 2);
  EXPECT_FALSE(ended_a);
  EXPECT_TRUE(ended_b);
  ASSERT_EQ(r.output_errors.size(), 1u);
  EXPECT_EQ(r.output_errors[0], "output 'first': disk full while writing summary.json");
  EXPECT_NE(log.str().find("output 'first' failed at the end: disk full"), std::string::npos)
      << log.str();
  EXPECT_EQ(r.exitCode(), 4);
}

TEST(Pipeline, EmptyScanGivesAllUnknownGrid) {
  test::ConfigFixture f;
  LoadOptions lo;
  lo.output_dir = f.dir.str() + "/out";
  Pipeline p = loadPipeline(
      f.write("e.yaml", test::ConfigFixture::validPipeline("{frames: 1, mode: empty}")), lo, f.registry);
  RunOptions ro;
  ro.progress = false;
  std::ostringstream log;
  ro.log = &log;
  RunResult r = runPipeline(p, ro);
  EXPECT_EQ(r.exitCode(), 0);
  // Not a failure, but not silent either: an all-unknown grid could pass for a scene seen clear.
  EXPECT_EQ(r.empty_frames, std::vector<std::string>{"000000"});
  EXPECT_NE(log.str().find("warning: frame 000000 has no usable point (0 dropped; "
                           "synthetic/000000.bin): every cell stays unknown"),
            std::string::npos)
      << log.str();
}

TEST(Pipeline, PointsDroppedWhileReadingAreCountedAndNonFiniteOnesWarned) {
  // The readers dropped NaN points and counted them in the frame, but nothing read the count:
  // 4000 NaN points in a damaged scan went by without a word (found by fuzzing).
  test::ConfigFixture f;
  std::ostringstream log;
  RunResult r = runSynthetic(f, "{frames: 2, nonfinite_points: 7, no_return_points: 5}", log);
  EXPECT_EQ(r.exitCode(), 0);
  EXPECT_EQ(r.points_dropped_nonfinite, 14u);
  EXPECT_EQ(r.points_dropped_no_return, 10u);
  EXPECT_TRUE(r.empty_frames.empty());
  for (const char* id : {"000000", "000001"})
    EXPECT_NE(log.str().find(std::string("warning: frame ") + id +
                             ": 7 point(s) with NaN/inf coordinates or intensity dropped "
                             "(synthetic/" +
                             id + ".bin)"),
              std::string::npos)
        << log.str();
  // No-returns are what organised scans store for "no echo": counted, not warned about.
  std::ostringstream quiet;
  r = runSynthetic(f, "{frames: 1, no_return_points: 5}", quiet);
  EXPECT_EQ(r.points_dropped_no_return, 5u);
  EXPECT_EQ(quiet.str(), "");
}

// A cloud far from the sensor-centred grid (a UTM PLY, a PCD without its VIEWPOINT) left every
// cell unknown with exit 0 and no word: now each such frame is named, with the counts inside and
// outside, where the cloud and the grid lie and what to do.
TEST(Pipeline, ACloudOutsideTheGridIsWarnedAboutWithBothExtents) {
  test::ConfigFixture f;
  std::ostringstream log;
  RunResult r = runSynthetic(f, "{frames: 2, offset_m: [512345, 5812345]}", log);
  EXPECT_EQ(r.exitCode(), 0);  // a frame in the wrong place is not a broken frame
  EXPECT_EQ(r.frames_outside_grid, (std::vector<std::string>{"000000", "000001"}));
  EXPECT_TRUE(r.empty_frames.empty());
  const std::string text = log.str();
  for (const char* want :
       {"warning: frame 000000: 0 of 40516 point(s) inside the grid, 40516 outside "
        "(synthetic/000000.bin): the cloud spans x [512335.0, 512355.0], y [5812335.0, "
        "5812355.0], z [-1.7, -0.3] m, the grid x [-20, 20], y [-20, 20] m around the sensor, so "
        "every cell stays unknown. Is the cloud in a map frame (e.g. UTM)?",
        "give a PCD the sensor's pose as its VIEWPOINT, use recentre: auto of semantickitti or "
        "pointcloud_file (a scan shifted by up to kilometres), or "
        "store the points relative to the sensor",
        "warning: frame 000001: 0 of "})
    EXPECT_NE(text.find(want), std::string::npos) << want << "\n" << text;
  // One row of points inside (0.1 m of a 20 m plane over the grid's edge): still under 1 %.
  std::ostringstream edge;
  r = runSynthetic(f, "{frames: 1, offset_m: [29.95, 0]}", edge);
  EXPECT_EQ(r.frames_outside_grid, (std::vector<std::string>{"000000"}));
  EXPECT_NE(edge.str().find("inside the grid"), std::string::npos) << edge.str();
  EXPECT_NE(edge.str().find("so nearly every cell stays unknown"), std::string::npos) << edge.str();
  // Half the cloud inside: nothing said.
  std::ostringstream quiet;
  r = runSynthetic(f, "{frames: 1, offset_m: [20, 0]}", quiet);
  EXPECT_TRUE(r.frames_outside_grid.empty());
  EXPECT_EQ(quiet.str(), "");
}

// What the stages measure is kept per completed frame and written next to timing.md.
TEST(Pipeline, StageMetricsOfCompletedFramesAreWrittenAsCsv) {
  test::ConfigFixture f;
  std::ostringstream log;
  const RunResult r = runSynthetic(f, "{frames: 3, bad_frames: [1]}", log);
  const std::string out = f.dir.str() + "/out";
  ASSERT_EQ(r.metrics.size(), 2u);  // the failed frame measured nothing that counts
  EXPECT_EQ(r.metrics[0].first, "000000");
  EXPECT_EQ(r.metrics[1].first, "000002");
  EXPECT_TRUE(r.metrics[1].second.count("solve.sweeps"));
  writeRunReports(out, r);
  EXPECT_TRUE(std::filesystem::exists(out + "/timing.md"));
  const std::string csv = readFile(out + "/metrics.csv");
  EXPECT_EQ(csv.rfind("frame,metric,value\n", 0), 0u) << csv;
  EXPECT_NE(csv.find("\n000002,solve.sweeps,"), std::string::npos) << csv;
  EXPECT_EQ(csv.find("000001,"), std::string::npos) << csv;
  // A later run into the same folder that measures nothing leaves its own, empty table, not the
  // earlier run's rows.
  writeRunReports(out, RunResult{});
  EXPECT_EQ(readFile(out + "/metrics.csv"), "frame,metric,value\n");
}

// RunOptions::metrics_csv (what `run` and `mesh` use): the rows go to the file as each frame
// completes, none stay in memory, and the file is the one the in-memory rows would have made.
// writeRunReports then leaves it alone.
TEST(Pipeline, StageMetricsStreamedToTheFileAsFramesComplete) {
  test::ConfigFixture f;
  std::ostringstream log;
  const RunResult kept = runSynthetic(f, "{frames: 3, bad_frames: [1]}", log);
  ASSERT_EQ(kept.metrics.size(), 2u);
  EXPECT_TRUE(kept.metrics_file.empty());

  Pipeline p = f.loadSynthetic("{frames: 3, bad_frames: [1]}");
  RunOptions ro;
  ro.progress = false;
  ro.log = &log;
  const std::string out = f.dir.str() + "/out";
  ro.metrics_csv = out + "/metrics.csv";
  const RunResult r = runPipeline(p, ro);
  EXPECT_TRUE(r.metrics.empty());
  EXPECT_EQ(r.metrics_file, out + "/metrics.csv");
  EXPECT_FALSE(std::filesystem::exists(out + "/metrics.csv.partial"));
  const std::string streamed = readFile(out + "/metrics.csv");
  EXPECT_EQ(streamed, metricsCsv(kept));
  writeRunReports(out, r);
  EXPECT_EQ(readFile(out + "/metrics.csv"), streamed);
  EXPECT_TRUE(std::filesystem::exists(out + "/timing.md"));
}

// A file that cannot be written (here: its folder is a file) falls back to memory, warned.
TEST(Pipeline, StageMetricsFallBackToMemoryWhenTheFileCannotBeWritten) {
  test::ConfigFixture f;
  std::ofstream(f.dir.str() + "/blocker") << "x";
  Pipeline p = f.loadSynthetic("{frames: 2}");
  RunOptions ro;
  ro.progress = false;
  std::ostringstream log;
  ro.log = &log;
  ro.metrics_csv = f.dir.str() + "/blocker/metrics.csv";
  const RunResult r = runPipeline(p, ro);
  EXPECT_EQ(r.summary.frames_ok, 2u);
  EXPECT_EQ(r.metrics.size(), 2u);
  EXPECT_TRUE(r.metrics_file.empty());
  EXPECT_NE(log.str().find("blocker/metrics.csv.partial cannot be written"), std::string::npos)
      << log.str();
}

// A partial file a killed run left is removed by the next run into the folder, even one that
// keeps its metrics in memory or fails before any frame.
TEST(Pipeline, AKilledRunsPartialMetricsAreRemovedByTheNext) {
  test::ConfigFixture f;
  const std::string out = f.dir.str() + "/out";
  std::filesystem::create_directories(out);
  std::ofstream(out + "/metrics.csv.partial") << "frame,metric,value\n000000,x,1\n";
  std::ostringstream log;
  runSynthetic(f, "{frames: 1}", log);
  EXPECT_FALSE(std::filesystem::exists(out + "/metrics.csv.partial"));
}

// The resolved config reproduces the run: numbers to the last bit, folders as this run found
// them, and the frames chosen on the command line said in its first line.
TEST(Pipeline, TheResolvedConfigReproducesTheRun) {
  test::ConfigFixture f;
  std::filesystem::create_directories(f.dir.str() + "/plugins");
  std::string text = "plugin_path: [plugins]\noutput_dir: somewhere\n" +
                     test::ConfigFixture::validPipeline("{frames: 3, spacing_m: 0.10000000000123}");
  LoadOptions lo;
  Pipeline p = loadPipeline(f.write("c.yaml", text), lo, f.registry);
  RunOptions ro;
  ro.progress = false;
  ro.first = 1;
  ro.limit = 1;
  runPipeline(p, ro);
  const std::string resolved = readFile(p.output_dir + "/resolved_config.yaml");
  EXPECT_EQ(resolved.rfind("# This run: --first 1 --limit 1 (give them again", 0), 0u) << resolved;
  const YAML::Node y = YAML::Load(resolved);
  EXPECT_EQ(y["source"]["params"]["spacing_m"].as<double>(), 0.10000000000123);
  EXPECT_EQ(y["plugin_path"][0].as<std::string>(), f.dir.str() + "/plugins");
  EXPECT_EQ(y["output_dir"].as<std::string>(), f.dir.str() + "/somewhere");
  EXPECT_EQ(p.output_dir, f.dir.str() + "/somewhere");
}

namespace {
/// An output that notes, when its first frame comes, whether a file exists.
/// Files an earlier run left in `out` ("earlier run\n"), dated `mtime` if given.
void putEarlierRunFiles(const std::string& out, std::initializer_list<const char*> files,
                        std::optional<std::filesystem::file_time_type> mtime = std::nullopt) {
  for (const char* file : files) {
    const std::string path = out + "/" + file;
    std::filesystem::create_directories(std::filesystem::path(path).parent_path());
    std::ofstream(path) << "earlier run\n";
    if (mtime) std::filesystem::last_write_time(path, *mtime);
  }
}

/// Fails the frames it is told to, after the outputs before it have written them.
struct FailingOutput : Output {
  std::string fail_id;
  void write(const FrameContext& ctx) override {
    if (ctx.frame->id == fail_id) throw std::runtime_error("cannot write " + fail_id);
  }
};
struct ExistsProbe : Output {
  std::string file;
  int seen = -1;
  void write(const FrameContext&) override {
    if (seen < 0) seen = std::filesystem::exists(file) ? 1 : 0;
  }
};
}  // namespace

// A run into a folder an earlier run wrote: a frame that fails leaves no earlier frame file that
// could pass for its result, and no earlier summary stays beside this run's resolved config
// while the run is under way (a run stopped then would leave them looking like its own).
TEST(Pipeline, EarlierRunsFilesCannotPassForThisRuns) {
  namespace fs = std::filesystem;
  test::ConfigFixture f;
  std::string text = test::ConfigFixture::validPipeline("{frames: 3, bad_frames: [1]}");
  text.replace(text.find("outputs: []"), 11, "outputs: [{type: grid_csv}, {type: evaluation}]");
  const std::string out = f.dir.str() + "/out";
  putEarlierRunFiles(out, {"grid_csv/000000.csv", "grid_csv/000001.csv", "evaluation/000001.json",
                           "evaluation/summary.md", "timing.md"});
  LoadOptions lo;
  lo.output_dir = out;
  Pipeline p = loadPipeline(f.write("c.yaml", text), lo, f.registry);
  auto probe = std::make_unique<ExistsProbe>();
  probe->file = out + "/evaluation/summary.md";
  ExistsProbe* seen = probe.get();
  p.outputs.push_back(std::move(probe));
  std::ostringstream log;
  RunOptions ro;
  ro.progress = false;
  ro.log = &log;
  const RunResult r = runPipeline(p, ro);
  ASSERT_EQ(r.summary.failed.size(), 1u);
  EXPECT_EQ(seen->seen, 0) << "the earlier summary was still there during the run";
  EXPECT_FALSE(fs::exists(out + "/grid_csv/000001.csv")) << log.str();
  EXPECT_FALSE(fs::exists(out + "/evaluation/000001.json")) << log.str();
  EXPECT_NE(log.str().find("removed " + out +
                           "/grid_csv/000001.csv: not this run's (frame 000001 failed before its "
                           "output wrote it)"),
            std::string::npos)
      << log.str();
  EXPECT_NE(readFile(out + "/grid_csv/000000.csv"), "earlier run\n");  // this run's
  EXPECT_NE(readFile(out + "/evaluation/summary.md"), "earlier run\n");
  EXPECT_FALSE(fs::exists(out + "/timing.md"));  // written by the command after the run
}

// Which of a failed frame's files go is decided by which outputs wrote the frame, not by file
// times: an earlier run's file dated after this run's start (a clock skew, a coarse filesystem,
// files copied from another machine) used to be kept as this run's; an output before the one
// that failed has written this run's result, which stays.
TEST(Pipeline, AFailedFramesFilesGoByWhoWroteThemNotByTheirTimes) {
  namespace fs = std::filesystem;
  test::ConfigFixture f;
  std::string text = test::ConfigFixture::validPipeline("{frames: 3}");
  text.replace(text.find("outputs: []"), 11, "outputs: [{type: grid_csv}]");
  const std::string out = f.dir.str() + "/out";
  putEarlierRunFiles(out, {"grid_csv/000001.csv", "evaluation/000001.json"},
                     fs::file_time_type::clock::now() + std::chrono::hours(1));
  LoadOptions lo;
  lo.output_dir = out;
  Pipeline p = loadPipeline(f.write("c.yaml", text), lo, f.registry);
  auto failing = std::make_unique<FailingOutput>();
  failing->fail_id = "000001";
  p.outputs.push_back(std::move(failing));
  // An evaluation output after the failing one: it never wrote frame 1.
  Pipeline with_eval = loadPipeline(
      f.write("e.yaml",
              test::edited(text, "outputs: [{type: grid_csv}]", "outputs: [{type: evaluation}]")),
      lo, f.registry);
  p.outputs.push_back(std::move(with_eval.outputs.front()));
  std::ostringstream log;
  RunOptions ro;
  ro.progress = false;
  ro.log = &log;
  const RunResult r = runPipeline(p, ro);
  ASSERT_EQ(r.summary.failed.size(), 1u);
  EXPECT_NE(readFile(out + "/grid_csv/000001.csv"), "earlier run\n");  // this run's, kept
  EXPECT_TRUE(fs::exists(out + "/grid_csv/000001.csv"));
  EXPECT_FALSE(fs::exists(out + "/evaluation/000001.json")) << log.str();
  EXPECT_TRUE(fs::exists(out + "/evaluation/000002.json"));
}

namespace {
struct BeginFails : Output {
  void begin(const RunInfo&) override { throw std::runtime_error("cannot open the database"); }
  void write(const FrameContext&) override {}
};
}  // namespace

// An output whose begin() throws ends the run before its first frame: the earlier run's summaries
// must be gone by then, not left beside the new resolved config (before, they were removed only
// after every begin()).
TEST(Pipeline, AnOutputFailingToBeginLeavesNoEarlierSummaryBesideTheNewConfig) {
  namespace fs = std::filesystem;
  test::ConfigFixture f;
  std::string text = test::ConfigFixture::validPipeline("{frames: 2}");
  text.replace(text.find("outputs: []"), 11, "outputs: [{type: evaluation}]");
  const std::string out = f.dir.str() + "/out";
  putEarlierRunFiles(
      out, {"evaluation/summary.md", "evaluation/summary.json", "timing.md", "metrics.csv"});
  LoadOptions lo;
  lo.output_dir = out;
  Pipeline p = loadPipeline(f.write("c.yaml", text), lo, f.registry);
  p.outputs.push_back(std::make_unique<BeginFails>());
  RunOptions ro;
  ro.progress = false;
  EXPECT_THROW(runPipeline(p, ro), std::runtime_error);
  EXPECT_TRUE(fs::exists(out + "/resolved_config.yaml"));
  for (const char* file :
       {"evaluation/summary.md", "evaluation/summary.json", "timing.md", "metrics.csv"})
    EXPECT_FALSE(fs::exists(out + "/" + file)) << file;
}

namespace {
/// Throws what is not a std::exception from write() for one frame, and a std::exception from
/// frameFiles(); notes the frame it is handed there.
struct ThrowsAnything : Output {
  std::string fail_id;
  mutable std::vector<std::string> frames_given;  ///< frameFiles()'s frame id, "null" if none
  void write(const FrameContext& ctx) override {
    if (ctx.frame->id == fail_id) throw 42;
  }
  std::vector<std::string> frameFiles(const std::string&, const Frame* frame) const override {
    frames_given.push_back(frame ? frame->id : "null");
    throw std::runtime_error("cannot list the folder");
  }
};
struct CountsEnds : Output {
  int ends = 0;
  void write(const FrameContext&) override {}
  void end(const RunSummary&) override { ++ends; }
};
/// The synthetic source, but frameId() throws for one frame.
struct IdFails : Source {
  std::unique_ptr<Source> inner;
  std::size_t bad = 0;
  std::size_t size() const override { return inner->size(); }
  std::string frameId(std::size_t i) const override {
    if (i == bad) throw std::runtime_error("no id for frame " + std::to_string(i));
    return inner->frameId(i);
  }
  Frame read(std::size_t i) override { return inner->read(i); }
};
}  // namespace

// A frame that fails with anything — no std::exception, an id that cannot be had, files that
// cannot be listed while it fails — is reported and skipped; the run goes on and every output
// ends. Before, each of these escaped the run and lost every output's end().
TEST(Pipeline, WhateverAFrameThrowsItIsReportedAndTheRunGoesOn) {
  test::ConfigFixture f;
  Pipeline p = f.loadSynthetic("{frames: 4}");
  auto src = std::make_unique<IdFails>();
  src->inner = std::move(p.source);
  src->bad = 2;
  p.source = std::move(src);
  auto thrower = std::make_unique<ThrowsAnything>();
  thrower->setIdentity("thrower", "thrower");
  thrower->fail_id = "000001";
  ThrowsAnything* t = thrower.get();
  p.outputs.push_back(std::move(thrower));
  auto counter = std::make_unique<CountsEnds>();
  CountsEnds* c = counter.get();
  p.outputs.push_back(std::move(counter));
  std::ostringstream log;
  RunOptions ro;
  ro.progress = false;
  ro.log = &log;
  RunResult r;
  ASSERT_NO_THROW(r = runPipeline(p, ro)) << log.str();
  EXPECT_EQ(r.summary.frames_ok, 2u);
  ASSERT_EQ(r.summary.failed.size(), 2u) << log.str();
  EXPECT_EQ(r.summary.failed[0].first, "000001");
  EXPECT_EQ(r.summary.failed[0].second,
            "[output thrower] unknown exception (not a std::exception)");
  EXPECT_EQ(r.summary.failed[1].first, "#2");
  EXPECT_EQ(r.summary.failed[1].second, "[read] no id for frame 2");
  EXPECT_EQ(c->ends, 1);
  EXPECT_EQ(t->frames_given, std::vector<std::string>{"000001"});  // read: handed the frame
  EXPECT_NE(log.str().find("warning: frame 000001: an earlier run's files of this frame may be "
                           "left, and pass for this run's: removing them failed: cannot list the "
                           "folder"),
            std::string::npos)
      << log.str();
  EXPECT_EQ(r.exitCode(), 3);
}

namespace {
/// The inner source's frames under ids of its own.
struct RenamedIds : Source {
  std::unique_ptr<Source> inner;
  std::vector<std::string> ids;
  std::atomic<int> reads{0};
  std::size_t size() const override { return inner->size(); }
  std::string frameId(std::size_t i) const override { return ids.at(i); }
  Frame read(std::size_t i) override {
    ++reads;
    Frame fr = inner->read(i);
    fr.id = ids.at(i);
    return fr;
  }
};
}  // namespace

// Frames whose ids name the same files ('scan' from scan.pcd and scan.ply; 'a b' and 'a_b') used
// to write over each other's outputs, and a failed one removed the other's as an earlier run's.
// Refused before any frame runs, naming the frames; distinct ids run as before.
TEST(Pipeline, FramesWhoseIdsNameTheSameFilesAreRefusedBeforeAnyRuns) {
  test::ConfigFixture f;
  for (const auto& [ids, clash] :
       {std::pair<std::vector<std::string>, std::string>{{"scan", "x", "scan"},
                                                         "frames 0 ('scan') and 2 ('scan') both "
                                                         "write 'scan'"},
        {{"a b", "a_b", "c"}, "frames 0 ('a b') and 1 ('a_b') both write 'a_b'"},
        {{"a", "b", "c"}, ""}}) {
    Pipeline p = f.loadSynthetic("{frames: 3}");
    auto src = std::make_unique<RenamedIds>();
    src->inner = std::move(p.source);
    src->ids = ids;
    const RenamedIds* renamed = src.get();
    p.source = std::move(src);
    std::ostringstream log;
    RunOptions ro;
    ro.progress = false;
    ro.log = &log;
    if (clash.empty()) {
      RunResult r;
      ASSERT_NO_THROW(r = runPipeline(p, ro)) << log.str();
      EXPECT_EQ(r.summary.frames_ok, 3u);
      continue;
    }
    try {
      runPipeline(p, ro);
      ADD_FAILURE() << "ran with clashing ids " << clash;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(clash), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("1 frame(s) share a file name"), std::string::npos)
          << e.what();
    }
    EXPECT_EQ(renamed->reads, 0);
  }
}

// Two stages sharing their params through a YAML alias: each keeps its own in the resolved
// config (assigning the first's resolved params through the shared node gave it the second's).
TEST(Pipeline, TheResolvedConfigKeepsAliasedParamsApart) {
  test::ConfigFixture f;
  std::string text = test::ConfigFixture::validPipeline();
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"type: eigen_preclass}", "type: eigen_preclass, params: &p {min_points: 4}}"},
           {"type: height_difference}", "type: height_difference, params: *p}"}})
    text.replace(text.find(from), from.size(), to);
  LoadOptions lo;
  lo.output_dir = f.dir.str() + "/out";
  Pipeline p = loadPipeline(f.write("alias.yaml", text), lo, f.registry);
  RunOptions ro;
  ro.progress = false;
  ro.limit = 1;
  runPipeline(p, ro);
  const std::string resolved = readFile(p.output_dir + "/resolved_config.yaml");
  const YAML::Node y = YAML::Load(resolved);
  EXPECT_EQ(y["stages"][0]["params"]["min_points"].as<int>(), 4);
  EXPECT_EQ(y["stages"][1]["params"]["min_points"].as<int>(), 4);
  EXPECT_TRUE(y["stages"][0]["params"]["threshold_m2"]) << resolved;  // eigen_preclass's own
  EXPECT_FALSE(y["stages"][0]["params"]["layer"]) << resolved;        // height_difference's
  EXPECT_EQ(resolved.find('*'), std::string::npos) << resolved;
  // And it loads again as the same pipeline.
  LoadOptions again;
  again.output_dir = f.dir.str() + "/out2";
  EXPECT_NO_THROW(loadPipeline(f.write("resolved.yaml", resolved), again, f.registry));
}

}  // namespace terramrf

namespace terramrf {
namespace {
/// An output that keeps, per frame, the labels of the cells at the given points.
struct CellLabelProbe : Output {
  std::vector<std::pair<double, double>> at_m;
  std::vector<std::vector<LabelId>> seen;
  void write(const FrameContext& ctx) override {
    std::vector<LabelId> l;
    for (const auto& [x, y] : at_m)
      l.push_back(ctx.grid->labels()[ctx.grid->geometry().cellOf(x, y)]);
    seen.push_back(l);
  }
};
}  // namespace

// Egomotion stages (the later EKF / ICP plugins) run before the grid is binned, in their own
// timing slot, set the frame's pose and see the previous frame's: the core's side of that
// contract, with a test plugin, before any real egomotion plugin exists.
TEST(Pipeline, EgomotionStagesRunBeforeBinningAndSeeThePreviousFrame) {
  test::ConfigFixture f;
  PluginRegistry reg({test::pluginDir(),
                      std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_source",
                      std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_egomotion"});
  const std::string base = test::ConfigFixture::validPipeline("{frames: 3}");
  const std::string ego =
      "  - {name: ego, type: test_egomotion, params: {step_m: 1.5, shift_x_m: 2}}\n";
  std::string text = base;
  text.insert(text.find("stages:\n") + 8, ego);
  LoadOptions lo;
  lo.output_dir = f.dir.str() + "/out";
  Pipeline p = loadPipeline(f.write("ego.yaml", text), lo, reg);
  auto probe = std::make_unique<CellLabelProbe>();
  // The box's wall stands at x = 3 m; shifted by 2 m it is binned at x = 1 m, and ground takes
  // its old place.
  probe->at_m = {{1.05, 0.3}, {3.05, 0.3}};
  CellLabelProbe* seen = probe.get();
  p.outputs.push_back(std::move(probe));
  RunOptions ro;
  ro.progress = false;
  const RunResult r = runPipeline(p, ro);
  ASSERT_EQ(r.summary.frames_ok, 3u);
  std::vector<std::string> slots;
  for (const auto& t : r.timings) slots.push_back(t.name);
  EXPECT_EQ(slots, (std::vector<std::string>{"read", "read wait", "ego", "grid", "pre", "hdiff",
                                             "mrf", "solve", "output:", "total"}));
  EXPECT_EQ(r.timings[2].ms.size(), 3u);
  ASSERT_EQ(seen->seen.size(), 3u);
  for (const auto& l : seen->seen) {
    EXPECT_EQ(l[0], labels::kObstacle);
    EXPECT_EQ(l[1], labels::kRoad);
  }
  ASSERT_EQ(r.metrics.size(), 3u);
  const double want[] = {-1.0, 0.0, 1.5};  // none, then frame 0's and frame 1's pose
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_DOUBLE_EQ(r.metrics[k].second.at("ego.previous_pose_x_m"), want[k]) << k;
    // An empty grid, not the one frame k - 2 left in the runner's slot (frame 2 saw frame 0's).
    EXPECT_DOUBLE_EQ(r.metrics[k].second.at("ego.grid_layers_and_points"), 0.0) << k;
  }

  // After a feature stage it would see a grid binned before it moved the points: refused.
  std::string late = base;
  late.insert(late.find("  - {name: mrf"), ego);
  try {
    loadPipeline(f.write("late.yaml", late), lo, reg);
    FAIL() << "expected a config error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "late.yaml:7:5: stage 'ego' (test_egomotion): egomotion stages must come before "
                  "feature/energy/optimiser stages"),
              std::string::npos)
        << e.what();
  }
}

TEST(PoseError, IsTheDistanceAndTheAngleBetweenTheTwoPosesWhateverTheAxis) {
  const Eigen::Isometry3d truth = Eigen::Translation3d(10, -4, 2) *
                                  Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized());
  // Turned 12° about an axis of the world that is no axis of either pose, and moved 3-4-0.
  Eigen::Isometry3d est = Eigen::Isometry3d::Identity();
  est.linear() =
      Eigen::AngleAxisd(12 * M_PI / 180, Eigen::Vector3d(-1, 0, 2).normalized()) * truth.linear();
  est.translation() = truth.translation() + Eigen::Vector3d(3, 4, 0);
  const PoseError e = poseError(est, truth);
  EXPECT_NEAR(e.translation_m, 5.0, 1e-12);
  EXPECT_NEAR(e.rotation_deg, 12.0, 1e-9);
  EXPECT_NEAR(poseError(truth, est).rotation_deg, 12.0, 1e-9);  // either way round
  const PoseError none = poseError(truth, truth);
  EXPECT_EQ(none.translation_m, 0.0);
  EXPECT_NEAR(none.rotation_deg, 0.0, 1e-6);
  // Half a turn is 180°, not 0° or NaN.
  EXPECT_NEAR(
      poseError(truth * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY()), truth).rotation_deg,
      180.0, 1e-6);
}

namespace {
/// Each frame's pose and truth pose as the outputs see them.
struct PosesSeen {
  std::vector<std::optional<Eigen::Isometry3d>> pose, truth;
};
/// An output that keeps them in a PosesSeen the test owns (the output goes with its pipeline).
struct PoseProbe : Output {
  explicit PoseProbe(PosesSeen& s) : seen(s) {}
  PosesSeen& seen;
  void write(const FrameContext& ctx) override {
    seen.pose.push_back(ctx.frame->pose);
    seen.truth.push_back(ctx.frame->truth_pose);
  }
};
}  // namespace

// An egomotion stage replaces Frame::pose with its estimate; the source's truth stays in
// Frame::truth_pose, and the runner scores the one against the other per frame (metrics.csv)
// and over the run (timing.md, egomotionErrorText).
TEST(Pipeline, EgomotionPosesAreScoredAgainstTheSourcesTruth) {
  test::ConfigFixture f;
  PluginRegistry reg({test::pluginDir(),
                      std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_source",
                      std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_egomotion"});
  auto config = [&](const std::string& name, const std::string& source_params,
                    const std::string& ego_params) {
    std::string text = test::ConfigFixture::validPipeline(source_params);
    if (!ego_params.empty())
      text.insert(text.find("stages:\n") + 8,
                  "  - {name: ego, type: test_egomotion, params: " + ego_params + "}\n");
    return f.write(name + ".yaml", text);
  };
  auto run = [&](const std::string& yaml, PosesSeen& seen) {
    LoadOptions lo;
    lo.output_dir = f.dir.str() + "/out";
    Pipeline p = loadPipeline(yaml, lo, reg);
    p.outputs.push_back(std::make_unique<PoseProbe>(seen));
    RunOptions ro;
    ro.progress = false;
    std::ostringstream log;
    ro.log = &log;
    RunResult r = runPipeline(p, ro);
    writeRunReports(lo.output_dir, r);
    return r;
  };

  // Truth: x = i m. Estimate: x = 1.5 i m, turned 2° per frame: off by 0.5 i m and 2 i °.
  PosesSeen seen;
  const RunResult r =
      run(config("scored", "{frames: 3, truth_pose: true}", "{step_m: 1.5, yaw_deg: 2}"), seen);
  ASSERT_EQ(r.summary.frames_ok, 3u);
  ASSERT_EQ(r.metrics.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_NEAR(r.metrics[k].second.at("egomotion.translation_error_m"), 0.5 * double(k), 1e-12);
    EXPECT_NEAR(r.metrics[k].second.at("egomotion.rotation_error_deg"), 2.0 * double(k), 1e-6);
    // The truth reaches the outputs as the source gave it; the pose is the stage's.
    ASSERT_TRUE(seen.truth[k] && seen.pose[k]) << k;
    EXPECT_TRUE(
        seen.truth[k]->isApprox(Eigen::Isometry3d(Eigen::Translation3d(double(k), 0, 0)), 1e-15))
        << seen.truth[k]->matrix();
    EXPECT_NEAR(seen.pose[k]->translation().x(), 1.5 * double(k), 1e-12);
  }
  const std::string out = f.dir.str() + "/out";
  const std::string csv = readFile(out + "/metrics.csv");
  EXPECT_NE(csv.find("\n000002,egomotion.translation_error_m,1\n"), std::string::npos) << csv;
  EXPECT_NE(csv.find("\n000002,egomotion.rotation_error_deg,4\n"), std::string::npos) << csv;
  EXPECT_NE(csv.find("\n000001,egomotion.translation_error_m,0.5\n"), std::string::npos) << csv;
  EXPECT_EQ(r.egomotion_error.frames, 3u);
  EXPECT_NEAR(r.egomotion_error.translationMean_m(), 0.5, 1e-12);
  EXPECT_NEAR(r.egomotion_error.translation_max_m, 1.0, 1e-12);
  EXPECT_NEAR(r.egomotion_error.rotationMean_deg(), 2.0, 1e-6);
  EXPECT_NEAR(r.egomotion_error.rotation_max_deg, 4.0, 1e-6);
  const std::string line =
      "egomotion against truth over 3 frame(s): translation mean 0.500 m, max 1.000 m; rotation "
      "mean 2.000°, max 4.000°";
  EXPECT_EQ(egomotionErrorText(r), line);
  EXPECT_NE(readFile(out + "/timing.md").find("\n" + line + ".\n"), std::string::npos)
      << readFile(out + "/timing.md");

  // Nothing is scored without an egomotion stage (pose is the source's own, the truth itself)
  // or without a truth, or when the egomotion stage writes no pose (one that only de-skews the
  // points leaves the source's, which equals the truth: it was scored 0 m, 0°); timing.md then
  // says nothing of it.
  for (const auto& [name, src, ego] : {std::tuple<std::string, std::string, std::string>{
                                           "no_ego", "{frames: 2, truth_pose: true}", ""},
                                       {"no_truth", "{frames: 2}", "{step_m: 1.5}"},
                                       {"ego_no_pose", "{frames: 2, truth_pose: true}",
                                        "{set_pose: false}"}}) {
    PosesSeen ignored;
    const RunResult q = run(config(name, src, ego), ignored);
    EXPECT_EQ(q.summary.frames_ok, 2u) << name;
    EXPECT_EQ(q.egomotion_error.frames, 0u) << name;
    EXPECT_EQ(egomotionErrorText(q), "") << name;
    for (const auto& [id, m] : q.metrics) EXPECT_FALSE(m.count("egomotion.translation_error_m"));
    EXPECT_EQ(readFile(out + "/timing.md").find("egomotion"), std::string::npos) << name;
  }

  // A stage that writes its estimate into truth_pose would be scored against itself (0 m, 0°):
  // the frame fails instead, naming the stage. Frame 0's estimate is its truth (x = 0 m), so
  // writing it there changes nothing and that frame is scored.
  std::ostringstream log;
  LoadOptions lo;
  lo.output_dir = f.dir.str() + "/out";
  Pipeline p = loadPipeline(
      config("cheat", "{frames: 2, truth_pose: true}", "{step_m: 1.5, overwrite_truth: true}"), lo,
      reg);
  RunOptions ro;
  ro.progress = false;
  ro.log = &log;
  const RunResult bad = runPipeline(p, ro);
  EXPECT_EQ(bad.summary.frames_ok, 1u);
  ASSERT_EQ(bad.summary.failed.size(), 1u);
  EXPECT_EQ(bad.summary.failed[0].first, "000001");
  EXPECT_EQ(bad.summary.failed[0].second,
            "[ego] egomotion stage changed Frame::truth_pose, the source's ground truth; an "
            "estimate belongs in Frame::pose");
  EXPECT_EQ(bad.egomotion_error.frames, 1u);
  // A source without truth gets none from such a stage either.
  Pipeline p2 = loadPipeline(config("cheat2", "{frames: 1}", "{overwrite_truth: true}"), lo, reg);
  EXPECT_EQ(runPipeline(p2, ro).summary.failed.size(), 1u);
}

// Temporal fusion (a later issue) slots in as a feature stage that reads the previous frame's
// labels and writes evidence layers for the energy: cells this scan has no points in are then
// classified from the earlier result instead of left unknown. The core's side of that, with a
// test plugin.
TEST(Pipeline, EvidenceFromThePreviousFrameFillsCellsWithoutPoints) {
  test::ConfigFixture f;
  PluginRegistry reg({test::pluginDir(),
                      std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_source",
                      std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_egomotion",
                      std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_carry_over"});
  // Frames 1 and 2 lose the ground points of 5 ≤ x < 7 m, 3 ≤ y < 5 m.
  // The carry-over reads the frames' poses: the source gives each the identity.
  std::string text =
      test::ConfigFixture::validPipeline("{frames: 4, hole_from_frame: 1, poses: true}");
  const std::string mrf = "preclass_layer: preclass}}";
  auto run = [&](const std::string& name, const std::string& config) {
    LoadOptions lo;
    lo.output_dir = f.dir.str() + "/out_" + name;
    Pipeline p = loadPipeline(f.write(name + ".yaml", config), lo, reg);
    auto probe = std::make_unique<CellLabelProbe>();
    probe->at_m = {{6.25, 4.25}, {5.75, 3.75}, {8.25, 4.25}};
    CellLabelProbe* seen = probe.get();
    p.outputs.push_back(std::move(probe));
    RunOptions ro;
    ro.progress = false;
    RunResult r = runPipeline(p, ro);
    EXPECT_EQ(r.summary.frames_ok, 4u) << name;
    return std::make_pair(seen->seen, r);
  };
  // Without evidence the occluded cells are unknown from frame 1 on.
  const auto [plain, plain_run] = run("plain", text);
  ASSERT_EQ(plain.size(), 4u);
  EXPECT_EQ(plain[0], (std::vector<LabelId>{labels::kRoad, labels::kRoad, labels::kRoad}));
  for (int k = 1; k < 4; ++k)
    EXPECT_EQ(plain[k], (std::vector<LabelId>{labels::kUnknown, labels::kUnknown, labels::kRoad}));

  std::string fused = text;
  fused.insert(fused.find("  - {name: mrf"), "  - {name: carry, type: test_carry_over}\n");
  fused.replace(fused.find(mrf), mrf.size(),
                "preclass_layer: preclass, evidence_layers: [evidence.road, evidence.rough, "
                "evidence.obstacle]}}");
  const auto [carried, carried_run] = run("fused", fused);
  ASSERT_EQ(carried.size(), 4u);
  // Carried over from frame to frame: road where frame 0 saw road, as long as the hole lasts.
  for (int k = 0; k < 4; ++k)
    EXPECT_EQ(carried[k], (std::vector<LabelId>{labels::kRoad, labels::kRoad, labels::kRoad})) << k;
  ASSERT_EQ(carried_run.metrics.size(), 4u);
  const double want_depth[] = {0, 1, 1, 1};  // one frame back, never a cycle
  for (int k = 0; k < 4; ++k)
    EXPECT_EQ(carried_run.metrics[k].second.at("carry.chain_depth"), want_depth[k]) << k;
  EXPECT_EQ(carried_run.metrics[0].second.count("carry.cells_carried"), 0u);
  // The occluded cells are classified from the evidence alone: 9 of the hole's 4 × 4 (the
  // lattice's float coordinates leave points in the cells along two of its edges).
  EXPECT_EQ(carried_run.metrics[0].second.at("mrf.cells_from_evidence"), 0.0);
  EXPECT_EQ(carried_run.metrics[1].second.at("mrf.cells_from_evidence"), 9.0);
  EXPECT_GT(carried_run.metrics[1].second.at("carry.cells_carried"), 1000);

  // With poses that move 2 m forward per frame the evidence is looked up 2 m further on, where
  // frame 0 saw the box (its wall at x = 3 m): the cell at x = 1.25 m inherits obstacle.
  std::string moving = fused;
  moving.insert(moving.find("stages:\n") + 8,
                "  - {name: ego, type: test_egomotion, params: {step_m: 2}}\n");
  LoadOptions lo;
  lo.output_dir = f.dir.str() + "/out_moving";
  Pipeline p = loadPipeline(f.write("moving.yaml", moving), lo, reg);
  TerrainGrid prev_grid(p.grid), grid(p.grid);
  Frame prev_frame = p.source->read(0), frame = p.source->read(1);
  FrameContext prev_ctx, ctx;
  prev_ctx.frame = &prev_frame;
  prev_ctx.grid = &prev_grid;
  prev_ctx.labels = p.labels.get();
  prev_ctx.index = 0;
  p.stages[0]->process(prev_ctx);
  prev_grid.binPoints(prev_frame.points);
  for (std::size_t s = 1; s < p.stages.size(); ++s) p.stages[s]->process(prev_ctx);
  ASSERT_EQ(prev_grid.labels()[p.grid.cellOf(3.25, 0.25)], labels::kObstacle);
  ctx.frame = &frame;
  ctx.grid = &grid;
  ctx.labels = p.labels.get();
  ctx.index = 1;
  ctx.previous = &prev_ctx;
  p.stages[0]->process(ctx);
  grid.binPoints(frame.points);
  for (std::size_t s = 1; s < p.stages.size(); ++s) {
    p.stages[s]->process(ctx);
    if (p.stages[s]->name() == "carry") break;
  }
  const int cell = p.grid.cellOf(1.25, 0.25);
  EXPECT_EQ(grid.layer("evidence.obstacle")[cell], 0.f);
  EXPECT_EQ(grid.layer("evidence.road")[cell], 20.f);
}

namespace {
/// Asks the run to stop (as the SIGINT handler does) while writing its `stop_at`-th frame; counts
/// the frames it wrote and its end()s, and keeps the summary end() was handed.
struct StopsTheRun : Output {
  int stop_at = 2, frames = 0, ends = 0;
  RunSummary seen;
  void write(const FrameContext&) override {
    if (++frames == stop_at) requestStop(SIGINT);
  }
  void end(const RunSummary& s) override {
    ++ends;
    seen = s;
  }
};
/// Clears the process-wide stop request before and after a test.
struct StopRequestGuard {
  StopRequestGuard() { clearStopRequest(); }
  ~StopRequestGuard() { clearStopRequest(); }
};
}  // namespace

// Ctrl-C (SIGINT) during a run: the frame in hand completes, no other is taken, every output
// still ends and the reports are written, saying the run was interrupted; exit status 130.
// Before, the run only stopped by dying: no end(), no timing.md or summaries. With frames read
// ahead on reader threads too: they are stopped and joined.
TEST(Pipeline, AStopRequestEndsTheRunAfterTheFrameInHandAndTheOutputsStillEnd) {
  for (const std::size_t read_ahead : {std::size_t{0}, std::size_t{4}}) {
    StopRequestGuard guard;
    test::ConfigFixture f;
    Pipeline p = f.loadSynthetic("{frames: 6}");
    auto stopper = std::make_unique<StopsTheRun>();
    stopper->setIdentity("stopper", "stopper");
    StopsTheRun* s = stopper.get();
    p.outputs.push_back(std::move(stopper));
    std::ostringstream log;
    RunOptions ro;
    ro.progress = false;
    ro.log = &log;
    ro.read_ahead = read_ahead;
    const RunResult r = runPipeline(p, ro);
    EXPECT_EQ(s->frames, 2) << "read_ahead " << read_ahead;
    EXPECT_EQ(s->ends, 1);
    EXPECT_EQ(s->seen.stop_signal, SIGINT);
    EXPECT_EQ(s->seen.frames_total, 6u);
    EXPECT_EQ(r.summary.frames_ok, 2u);
    EXPECT_EQ(r.frames_total, 6u);
    EXPECT_EQ(r.exitCode(), 130);
    EXPECT_EQ(interruptionText(r.summary), "interrupted (SIGINT) after 2 of 6 frame(s)");
    EXPECT_NE(log.str().find("run interrupted (SIGINT) after 2 of 6 frame(s); ending the outputs"),
              std::string::npos)
        << log.str();
    writeRunReports(p.output_dir, r);
    const std::string timing = readFile(p.output_dir + "/timing.md");
    EXPECT_EQ(
        timing.rfind("Run interrupted (SIGINT) after 2 of 6 frame(s): timings of those only.", 0),
        0u)
        << timing;
    EXPECT_TRUE(std::filesystem::exists(p.output_dir + "/metrics.csv"));
  }
}

// A stop requested before the run starts (a signal while the config loads) runs no frame but
// still ends the outputs; a run with no request is untouched.
TEST(Pipeline, AStopRequestedBeforeTheRunTakesNoFrameAndARunWithoutOneAllFrames) {
  StopRequestGuard guard;
  test::ConfigFixture f;
  {
    Pipeline p = f.loadSynthetic("{frames: 3}");
    auto counter = std::make_unique<CountsEnds>();
    CountsEnds* c = counter.get();
    p.outputs.push_back(std::move(counter));
    requestStop(SIGTERM);
    requestStop(SIGINT);  // the first request wins
    std::ostringstream log;
    RunOptions ro;
    ro.progress = false;
    ro.log = &log;
    const RunResult r = runPipeline(p, ro);
    EXPECT_EQ(r.summary.frames_ok + r.summary.failed.size(), 0u);
    EXPECT_EQ(c->ends, 1);
    EXPECT_EQ(r.exitCode(), 143);
  }
  clearStopRequest();
  std::ostringstream log;
  const RunResult r = runSynthetic(f, "{frames: 3}", log);
  EXPECT_EQ(r.summary.frames_ok, 3u);
  EXPECT_EQ(r.summary.stop_signal, 0);
  EXPECT_EQ(r.exitCode(), 0);
  EXPECT_EQ(interruptionText(r.summary), "");
}

// The SIGINT handler itself, raised in this process: it records the signal, and puts the
// default action back so that a second signal ends the process at once.
TEST(StopRequest, TheHandlerRecordsTheSignalAndASecondOneActsAsWithoutIt) {
  StopRequestGuard guard;
  struct sigaction saved_int {
  }, saved_term{};
  sigaction(SIGINT, nullptr, &saved_int);
  sigaction(SIGTERM, nullptr, &saved_term);
  struct sigaction dfl {};
  dfl.sa_handler = SIG_DFL;
  sigemptyset(&dfl.sa_mask);
  sigaction(SIGINT, &dfl, nullptr);
  sigaction(SIGTERM, &dfl, nullptr);
  installStopHandlers();
  ASSERT_EQ(::raise(SIGINT), 0);
  EXPECT_EQ(stopRequested(), SIGINT);
  struct sigaction now {};
  sigaction(SIGINT, nullptr, &now);
  EXPECT_EQ(now.sa_handler, SIG_DFL);
  sigaction(SIGTERM, nullptr, &now);
  EXPECT_EQ(now.sa_handler, SIG_DFL);
  // A signal ignored when the handlers are installed stays ignored (a background job's SIGINT).
  struct sigaction ign {};
  ign.sa_handler = SIG_IGN;
  sigemptyset(&ign.sa_mask);
  sigaction(SIGINT, &ign, nullptr);
  installStopHandlers();
  sigaction(SIGINT, nullptr, &now);
  EXPECT_EQ(now.sa_handler, SIG_IGN);
  sigaction(SIGTERM, nullptr, &now);
  EXPECT_NE(now.sa_handler, SIG_DFL);
  sigaction(SIGINT, &saved_int, nullptr);
  sigaction(SIGTERM, &saved_term, nullptr);
}

namespace {
using test::deadPid;
}  // namespace

// A run killed mid-write left `.<name>.tmp.<pid>.XXXXXX` in its output folder, which no later
// run removed; now a run removes those of writers that are gone before its first frame, and
// leaves a live writer's alone.
TEST(Pipeline, TemporariesOfKilledWritersAreRemovedWhenTheFolderIsUsedAgain) {
  test::ConfigFixture f;
  Pipeline p = f.loadSynthetic("{frames: 1}");
  namespace fs = std::filesystem;
  const std::string dead = std::to_string(deadPid()), live = std::to_string(::getpid());
  fs::create_directories(p.output_dir + "/grid");
  const std::string stale = p.output_dir + "/grid/.000041.png.tmp." + dead + ".hbVTdD";
  const std::string busy = p.output_dir + "/grid/.000042.png.tmp." + live + ".aB3dE9";
  std::ofstream(stale) << "x";
  std::ofstream(busy) << "x";
  std::ostringstream log;
  RunOptions ro;
  ro.progress = false;
  ro.log = &log;
  runPipeline(p, ro);
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::exists(busy));
  EXPECT_NE(log.str().find("note: removed " + stale + " (left by a process that no longer runs)"),
            std::string::npos)
      << log.str();
}

namespace {
/// The diagnostics of loading `text` (as `name`) with `reg`, each as file:line:col: … text.
std::vector<std::string> loadErrors(test::ConfigFixture& f, PluginRegistry& reg,
                                    const std::string& name, const std::string& text) {
  LoadOptions lo;
  lo.output_dir = f.dir.str() + "/out_" + name;
  try {
    loadPipeline(f.write(name, text), lo, reg);
  } catch (const ConfigError& e) {
    std::vector<std::string> v;
    for (const auto& d : e.diagnostics()) v.push_back(d.str());
    return v;
  }
  return {};
}
std::string joinedLines(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += x + "\n";
  return s;
}
}  // namespace

// An egomotion stage runs on the frame before the grid is built: no grid layer and none of the
// grid's point lists (`@points`) exist then, and the grid is built anew after it, so a layer it
// wrote would be gone. The check counted `@points` and such writes as available to it, and let a
// later egomotion stage read them; they are refused at the entry. The frame's pose, which lives
// on the frame, passes from one egomotion stage to the next.
TEST(Pipeline, AnEgomotionStageHasTheFrameNotTheGrid) {
  test::ConfigFixture f;
  PluginRegistry reg({test::pluginDir(),
                      std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_source",
                      std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_egomotion"});
  const std::string base = test::ConfigFixture::validPipeline("{frames: 1}");
  std::string text = base;
  text.insert(text.find("stages:\n") + 8,
              "  - {name: ego, type: test_egomotion, params: {declared_reads: ['@points'], "
              "declared_writes: [ego_layer]}}\n"
              "  - {name: ego2, type: test_egomotion, params: {declared_reads: [ego_layer, "
              "'@pose']}}\n");
  const std::string path = f.dir.str() + "/grid.yaml";
  const auto errs = loadErrors(f, reg, "grid.yaml", text);
  const std::string at_ego =
      path + ":" + test::positionOf(text, "{name: ego,") + ": stage 'ego' (test_egomotion): ";
  const std::string at_ego2 =
      path + ":" + test::positionOf(text, "{name: ego2") + ": stage 'ego2' (test_egomotion): ";
  EXPECT_EQ(errs,
            (std::vector<std::string>{
                at_ego + "reads '@points', which an egomotion stage cannot: it runs before the "
                         "grid is built, when no grid layer and none of the grid's point lists "
                         "('@points') exist; it has the frame (FrameContext::frame: its points, "
                         "pose, IMU, GPS, odometry)",
                at_ego + "writes 'ego_layer', which would be lost: the grid is built anew from "
                         "the frame's points after the egomotion stages; an egomotion stage "
                         "changes the frame (its points, its pose: '@pose')",
                at_ego2 + "reads 'ego_layer', which an egomotion stage cannot: it runs before "
                          "the grid is built, when no grid layer and none of the grid's point "
                          "lists ('@points') exist; it has the frame (FrameContext::frame: its "
                          "points, pose, IMU, GPS, odometry)"}))
      << joinedLines(errs);
  // The pose one writes the next one reads.
  std::string ok = base;
  ok.insert(ok.find("stages:\n") + 8,
            "  - {name: ego, type: test_egomotion}\n"
            "  - {name: ego2, type: test_egomotion, params: {declared_reads: ['@pose']}}\n");
  const auto ok_errs = loadErrors(f, reg, "ok.yaml", ok);
  EXPECT_TRUE(ok_errs.empty()) << joinedLines(ok_errs);
}


// A stage that reads the frame's pose (temporal fusion) was refused over any source, since the
// check never asked the source what it writes, and the test carry-over took a missing pose for
// the identity. The source's writes now count from the first stage on, a reader of `@pose` with
// neither the source nor an earlier stage writing it is refused at its entry, and a source can
// only declare what lives on the frame: a grid layer it "writes" is refused at the source.
TEST(Pipeline, AStageThatReadsThePoseNeedsASourceOrStageThatWritesIt) {
  test::ConfigFixture f;
  PluginRegistry reg({test::pluginDir(),
                      std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_source",
                      std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_egomotion",
                      std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_carry_over"});
  auto withCarry = [](const std::string& source_params) {
    std::string t = test::ConfigFixture::validPipeline(source_params);
    t.insert(t.find("  - {name: mrf"), "  - {name: carry, type: test_carry_over}\n");
    return t;
  };
  const std::string text = withCarry("{frames: 2}");
  const auto errs = loadErrors(f, reg, "nopose.yaml", text);
  ASSERT_EQ(errs.size(), 1u) << joinedLines(errs);
  EXPECT_EQ(errs[0].rfind(f.dir.str() + "/nopose.yaml:" + test::positionOf(text, "{name: carry") +
                              ": stage 'carry' (test_carry_over): reads '@pose', which neither "
                              "source 'test_synthetic' (test_synthetic) nor an earlier stage "
                              "writes (available here: @points, ",
                          0),
            0u)
      << errs[0];
  EXPECT_NE(errs[0].find("; a pose comes from a source that has one for every frame (simulator, "
                         "semantickitti with poses.txt, pointcloud_file PCDs with VIEWPOINTs) or "
                         "from an egomotion stage before it"),
            std::string::npos)
      << errs[0];
  // A source with poses, or an egomotion stage, provides it.
  const auto with_poses = loadErrors(f, reg, "poses.yaml", withCarry("{frames: 2, poses: true}"));
  EXPECT_TRUE(with_poses.empty()) << joinedLines(with_poses);
  std::string ego = text;
  ego.insert(ego.find("stages:\n") + 8, "  - {name: ego, type: test_egomotion}\n");
  const auto with_ego = loadErrors(f, reg, "ego.yaml", ego);
  EXPECT_TRUE(with_ego.empty()) << joinedLines(with_ego);
  // A source may declare grid layers it receives made (Frame::grid), but not what the runner
  // or stages make per frame.
  const auto layer_errs =
      loadErrors(f, reg, "layer.yaml",
                 test::ConfigFixture::validPipeline("{frames: 2, declared_writes: [height_diff]}"));
  EXPECT_TRUE(layer_errs.empty()) << joinedLines(layer_errs);
  const std::string energy =
      test::ConfigFixture::validPipeline("{frames: 2, declared_writes: ['@energy']}");
  const auto energy_errs = loadErrors(f, reg, "energy.yaml", energy);
  EXPECT_EQ(energy_errs,
            std::vector<std::string>{
                f.dir.str() + "/energy.yaml:" + test::positionOf(energy, "{type: test_synthetic") +
                ": stage 'test_synthetic' (test_synthetic): declares that it writes '@energy', "
                "which a source cannot: the runner bins each frame's points into the grid "
                "('@points') after it is read, and the energy model ('@energy') and the cameras' "
                "pixels per cell ('@cell_pixels') are made by stages; a source provides the frame "
                "(its points, frame artefacts such as '@pose', and grid layers received with it: "
                "Frame::grid)"})
      << joinedLines(energy_errs);
}

// A grid made elsewhere (another process's feature stages, received over LCM) comes with the
// frame: the stages after the source use its layers as if computed here, and with them the
// height-difference stage is not needed. A frame without it, without a declared layer, or with
// another geometry fails, naming the frame's file and the source; the other frames go on.
TEST(Pipeline, ASourcesGridLayersAreTheFramesAndAFrameWithoutThemFails) {
  test::ConfigFixture f;
  PluginRegistry reg(
      {test::pluginDir(), std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_source"});
  auto config = [](const std::string& source_params) {
    std::string t = test::ConfigFixture::validPipeline(source_params);
    t.erase(t.find("  - {name: hdiff"),
            std::string("  - {name: hdiff, type: height_difference}\n").size());
    t.replace(t.find("outputs: []"), 11, "outputs: [{type: grid_csv}]");  // every layer
    return t;
  };
  auto run = [&](const std::string& name, const std::string& source_params) {
    LoadOptions lo;
    lo.output_dir = f.dir.str() + "/out_" + name;
    Pipeline p = loadPipeline(f.write(name + ".yaml", config(source_params)), lo, reg);
    RunOptions ro;
    ro.progress = false;
    std::ostringstream log;
    ro.log = &log;
    return std::make_pair(runPipeline(p, ro), lo.output_dir);
  };
  {
    const auto [res, out] =
        run("received", "{frames: 3, grid_layers: [height_diff], gridless_frames: [1]}");
    EXPECT_EQ(res.summary.frames_ok, 2u);
    ASSERT_EQ(res.summary.failed.size(), 1u);
    EXPECT_EQ(res.summary.failed[0].first, "000001");
    EXPECT_NE(res.summary.failed[0].second.find(
                  "synthetic/000001.bin: has no grid, though source 'test_synthetic' "
                  "(test_synthetic) declares that it writes grid layers (height_diff) for every "
                  "frame"),
              std::string::npos)
        << res.summary.failed[0].second;
    // Frame 2's layer as the source made it (2 in every cell), not as height_difference would.
    const std::string csv = readFile(out + "/grid_csv/000002.csv");
    const std::string header = csv.substr(0, csv.find('\n'));
    ASSERT_NE(header.find("height_diff"), std::string::npos) << header;
    // Only what the source declares: its grid's other layer stays behind.
    EXPECT_EQ(header.find("undeclared"), std::string::npos) << header;
    std::istringstream rows(csv);
    std::string line;
    std::getline(rows, line);
    std::size_t cells = 0;
    const std::size_t column =
        std::count(header.begin(), header.begin() + header.find("height_diff"), ',');
    while (std::getline(rows, line)) {
      std::vector<std::string> fields;
      std::stringstream ls(line);
      for (std::string x; std::getline(ls, x, ',');) fields.push_back(x);
      ASSERT_GT(fields.size(), column) << line;
      EXPECT_EQ(std::stod(fields[column]), 2.0) << line;
      ++cells;
    }
    EXPECT_EQ(cells, 80u * 80u);
  }
  {
    const auto [res, out] =
        run("missing", "{frames: 2, grid_layers: [height_diff], declared_writes: [roughness]}");
    EXPECT_EQ(res.summary.frames_ok, 0u);
    ASSERT_EQ(res.summary.failed.size(), 2u);
    EXPECT_NE(res.summary.failed[0].second.find(
                  "synthetic/000000.bin: has no grid layer 'roughness', though source "
                  "'test_synthetic' (test_synthetic) declares that it writes it (layers "
                  "received: height_diff, undeclared)"),
              std::string::npos)
        << res.summary.failed[0].second;
  }
  {
    const auto [res, out] =
        run("geometry", "{frames: 1, grid_layers: [height_diff], grid_cell_m: 0.25}");
    ASSERT_EQ(res.summary.failed.size(), 1u);
    EXPECT_NE(res.summary.failed[0].second.find(
                  "synthetic/000000.bin: source 'test_synthetic' (test_synthetic): the grid "
                  "received is 160 x 160 cells of 0.250000 m centred at (0.000000, 0.000000) m; "
                  "the run's is 80 x 80 cells of 0.500000 m"),
              std::string::npos)
        << res.summary.failed[0].second;
  }
}

// A writer of `@pose` promises a pose for every frame: the stages that read it were let through
// on that promise. A frame that comes out of the source, or out of an egomotion stage, without
// one fails, naming the writer; it used to go on without a pose.
TEST(Pipeline, AFrameLeftWithoutThePoseItsWriterDeclaredFails) {
  test::ConfigFixture f;
  PluginRegistry reg({test::pluginDir(),
                      std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_source",
                      std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_egomotion"});
  auto run = [&](const std::string& name, const std::string& text) {
    LoadOptions lo;
    lo.output_dir = f.dir.str() + "/out_" + name;
    Pipeline p = loadPipeline(f.write(name + ".yaml", text), lo, reg);
    RunOptions ro;
    ro.progress = false;
    std::ostringstream log;
    ro.log = &log;
    return runPipeline(p, ro);
  };
  const RunResult src =
      run("src", test::ConfigFixture::validPipeline("{frames: 2, declared_writes: ['@pose']}"));
  EXPECT_EQ(src.summary.frames_ok, 0u);
  ASSERT_EQ(src.summary.failed.size(), 2u);
  EXPECT_EQ(src.summary.failed[0].second,
            "[read] synthetic/000000.bin: has no pose, though source 'test_synthetic' "
            "(test_synthetic) declares that it writes '@pose' (a pose for every frame, which "
            "stages rely on)");
  std::string text = test::ConfigFixture::validPipeline("{frames: 2}");
  text.insert(text.find("stages:\n") + 8,
              "  - {name: ego, type: test_egomotion, params: {set_pose: false, declared_writes: "
              "['@pose']}}\n");
  const RunResult ego = run("ego", text);
  EXPECT_EQ(ego.summary.frames_ok, 0u);
  ASSERT_EQ(ego.summary.failed.size(), 2u);
  EXPECT_EQ(ego.summary.failed[1].second,
            "[ego] left frame 000001 without a pose, though it declares that it writes '@pose' "
            "(a pose for every frame, which later stages rely on)");
}


}  // namespace terramrf
