// The run-long lifecycle of stages (Stage::begin, frameFailed, end) and the run's state
// (RunState) as runPipeline drives them: order relative to the outputs, interrupted runs, frames
// that fail after a stage processed them, hooks that throw, and a map built over a run that an
// output reads at its end.
#include <gtest/gtest.h>
#include <signal.h>

#include <algorithm>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "config_fixture.hpp"
#include "terramrf/pipeline.hpp"
#include "terramrf/run_state.hpp"
#include "terramrf/stop_request.hpp"

namespace terramrf {
namespace {

using Journal = std::vector<std::string>;

/// A stage that writes each call it gets into a journal ("begin a", "process a 1", …) and throws
/// from the hook named in `throw_in` ("begin", "process" at frame `throw_at`, "frame_failed",
/// "end"; "begin int" throws what is not a std::exception).
struct Recorder : Stage {
  Journal* journal = nullptr;
  std::string throw_in;
  std::size_t throw_at = 0;
  RunInfo info;
  RunSummary summary;
  std::vector<const RunState*> frame_runs;  ///< FrameContext::run of each frame processed
  void begin(const RunInfo& i) override {
    journal->push_back("begin " + name());
    info = i;
    if (throw_in == "begin") throw std::runtime_error("cannot open the map store");
    if (throw_in == "begin int") throw 42;
  }
  void process(FrameContext& ctx) override {
    journal->push_back("process " + name() + " " + std::to_string(ctx.index) +
                       (ctx.previous ? " after " + std::to_string(ctx.previous->index) : ""));
    frame_runs.push_back(ctx.run);
    if (throw_in == "process" && ctx.index == throw_at) throw std::runtime_error("singular matrix");
  }
  void frameFailed(const FrameContext& ctx) override {
    journal->push_back("frameFailed " + name() + " " + std::to_string(ctx.index));
    if (throw_in == "frame_failed") throw std::runtime_error("cannot undo the update");
  }
  void end(const RunSummary& s) override {
    journal->push_back("end " + name());
    summary = s;
    if (throw_in == "end") throw std::runtime_error("disk full while saving the map");
  }
};

/// An output that journals its calls and throws from write() at frame `throw_at` if `throws`.
struct OutputRecorder : Output {
  Journal* journal = nullptr;
  bool throws = false;
  bool throws_in_begin = false;
  std::size_t throw_at = 0;
  RunSummary summary;
  void begin(const RunInfo&) override {
    journal->push_back("begin " + name());
    if (throws_in_begin) throw std::runtime_error("cannot open the output");
  }
  void write(const FrameContext& ctx) override {
    if (throws && ctx.index == throw_at) throw std::runtime_error("cannot write the frame");
    journal->push_back("write " + name() + " " + std::to_string(ctx.index));
  }
  void end(const RunSummary& s) override {
    journal->push_back("end " + name());
    summary = s;
  }
};

/// Adds a journalling stage after the synthetic pipeline's own.
Recorder* addRecorder(Pipeline& p, Journal& j, const std::string& name,
                      const std::string& throw_in = "", std::size_t throw_at = 0) {
  auto s = std::make_unique<Recorder>();
  s->setIdentity(name, "recorder");
  s->journal = &j;
  s->throw_in = throw_in;
  s->throw_at = throw_at;
  Recorder* raw = s.get();
  p.stages.push_back(std::move(s));
  p.stage_kinds.push_back(PluginKind::kFeature);
  return raw;
}

OutputRecorder* addOutput(Pipeline& p, Journal& j, const std::string& name) {
  auto o = std::make_unique<OutputRecorder>();
  o->setIdentity(name, "output_recorder");
  o->journal = &j;
  OutputRecorder* raw = o.get();
  p.outputs.push_back(std::move(o));
  return raw;
}

RunOptions quiet(std::ostream& log) {
  RunOptions ro;
  ro.progress = false;
  ro.log = &log;
  return ro;
}

/// Clears the process-wide stop request before and after a test.
struct StopRequestGuard {
  StopRequestGuard() { clearStopRequest(); }
  ~StopRequestGuard() { clearStopRequest(); }
};

/// Asks the run to stop while writing its `stop_at`-th frame, as the SIGINT handler would.
struct StopsTheRun : Output {
  int stop_at = 1, frames = 0;
  void write(const FrameContext&) override {
    if (++frames == stop_at) requestStop(SIGINT);
  }
};

}  // namespace

// begin() once before the first frame, stages before outputs; end() once after the last frame,
// stages (in config order) before outputs, so that an output can export what a stage finished.
// Every frame and both ends see the one state of the run, which begin() was handed.
TEST(StageLifecycle, BeginAndEndComeOnceEachAroundTheFramesAndBeforeTheOutputs) {
  test::ConfigFixture f;
  Pipeline p = f.loadSynthetic("{frames: 2}");
  Journal j;
  Recorder* a = addRecorder(p, j, "a");
  Recorder* b = addRecorder(p, j, "b");
  OutputRecorder* out = addOutput(p, j, "out");
  std::ostringstream log;
  const RunResult r = runPipeline(p, quiet(log));
  EXPECT_EQ(r.exitCode(), 0) << log.str();
  EXPECT_EQ(j, (Journal{"begin a", "begin b", "begin out", "process a 0", "process b 0",
                        "write out 0", "process a 1 after 0", "process b 1 after 0", "write out 1",
                        "end a", "end b", "end out"}));
  EXPECT_EQ(a->info.frames, 2u);
  ASSERT_NE(a->info.run, nullptr);
  EXPECT_EQ(b->info.run, a->info.run);
  EXPECT_EQ(a->frame_runs, (std::vector<const RunState*>{a->info.run, a->info.run}));
  EXPECT_EQ(a->summary.frames_ok, 2u);
  EXPECT_EQ(a->summary.run, a->info.run);
  EXPECT_EQ(out->summary.run, a->info.run);
  EXPECT_EQ(r.summary.run, nullptr);  // the state is gone once the run returns
}

// An interrupted run still ends its stages (a map stage saves what it has), once each; a stop
// asked for before the run takes no frame but begins and ends all the same.
TEST(StageLifecycle, AnInterruptedRunStillEndsItsStages) {
  StopRequestGuard guard;
  test::ConfigFixture f;
  {
    Pipeline p = f.loadSynthetic("{frames: 4}");
    Journal j;
    Recorder* a = addRecorder(p, j, "a");
    auto stopper = std::make_unique<StopsTheRun>();
    stopper->stop_at = 2;
    p.outputs.push_back(std::move(stopper));
    std::ostringstream log;
    const RunResult r = runPipeline(p, quiet(log));
    EXPECT_EQ(r.exitCode(), 130);
    EXPECT_EQ(j, (Journal{"begin a", "process a 0", "process a 1 after 0", "end a"}));
    EXPECT_EQ(a->summary.stop_signal, SIGINT);
    EXPECT_EQ(a->summary.frames_ok, 2u);
  }
  clearStopRequest();
  Pipeline p = f.loadSynthetic("{frames: 3}");
  Journal j;
  addRecorder(p, j, "a");
  requestStop(SIGTERM);
  std::ostringstream log;
  EXPECT_EQ(runPipeline(p, quiet(log)).exitCode(), 143);
  EXPECT_EQ(j, (Journal{"begin a", "end a"}));
}

// A frame that fails in an output after every stage processed it: each stage is told, so that a
// filter or a map can take the frame back; the next frame's previous is the last good one, two
// indices back.
TEST(StageLifecycle, StagesAreToldOfAFrameTheyProcessedThatAnOutputFailed) {
  test::ConfigFixture f;
  Pipeline p = f.loadSynthetic("{frames: 3}");
  Journal j;
  addRecorder(p, j, "a");
  addRecorder(p, j, "b");
  OutputRecorder* out = addOutput(p, j, "out");
  out->throws = true;
  out->throw_at = 1;
  std::ostringstream log;
  const RunResult r = runPipeline(p, quiet(log));
  EXPECT_EQ(r.summary.frames_ok, 2u);
  ASSERT_EQ(r.summary.failed.size(), 1u);
  EXPECT_EQ(j, (Journal{"begin a", "begin b", "begin out", "process a 0", "process b 0",
                        "write out 0", "process a 1 after 0", "process b 1 after 0",
                        "frameFailed a 1", "frameFailed b 1", "process a 2 after 0",
                        "process b 2 after 0", "write out 2", "end a", "end b", "end out"}));
}

// A frame that fails in a stage: the stages before it are told, the failing one is not (its own
// process() threw) and those after it never processed the frame.
TEST(StageLifecycle, OnlyTheStagesBeforeTheFailingOneAreToldOfTheFailedFrame) {
  test::ConfigFixture f;
  Pipeline p = f.loadSynthetic("{frames: 2}");
  Journal j;
  addRecorder(p, j, "a");
  addRecorder(p, j, "b", "process", 0);
  addRecorder(p, j, "c");
  std::ostringstream log;
  const RunResult r = runPipeline(p, quiet(log));
  ASSERT_EQ(r.summary.failed.size(), 1u);
  EXPECT_EQ(r.summary.failed[0].second, "[b] singular matrix");
  EXPECT_EQ(
      j, (Journal{"begin a", "begin b", "begin c", "process a 0", "process b 0", "frameFailed a 0",
                  "process a 1", "process b 1", "process c 1", "end a", "end b", "end c"}));
}

// A stage that cannot take a failed frame back is logged by name; the other stages are still
// told and the run goes on.
TEST(StageLifecycle, AStageFailingToTakeAFrameBackIsLoggedAndTheRunGoesOn) {
  test::ConfigFixture f;
  Pipeline p = f.loadSynthetic("{frames: 2}");
  Journal j;
  addRecorder(p, j, "a", "frame_failed");
  addRecorder(p, j, "b");
  OutputRecorder* out = addOutput(p, j, "out");
  out->throws = true;
  out->throw_at = 0;
  std::ostringstream log;
  const RunResult r = runPipeline(p, quiet(log));
  EXPECT_EQ(r.summary.frames_ok, 1u);
  EXPECT_EQ(r.exitCode(), 3);
  EXPECT_NE(std::find(j.begin(), j.end(), "frameFailed b 0"), j.end());
  EXPECT_NE(std::find(j.begin(), j.end(), "write out 1"), j.end());
  EXPECT_NE(log.str().find("warning: frame 000000: stage 'a' (recorder): could not take the "
                           "failed frame back: cannot undo the update"),
            std::string::npos)
      << log.str();
}

// A stage whose begin() throws fails the run before any frame, naming the stage, whatever it
// threw; no output has begun and nothing ends (end() of a run that never ran would write
// summaries of no frame).
TEST(StageLifecycle, AStageFailingToBeginFailsTheRunNamingTheStage) {
  for (const std::string what : {"begin", "begin int"}) {
    test::ConfigFixture f;
    Pipeline p = f.loadSynthetic("{frames: 2}");
    Journal j;
    addRecorder(p, j, "a");
    addRecorder(p, j, "b", what);
    addRecorder(p, j, "c");
    addOutput(p, j, "out");
    std::ostringstream log;
    try {
      runPipeline(p, quiet(log));
      ADD_FAILURE() << "expected the run to fail";
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()),
                what == "begin" ? "stage 'b' (recorder): cannot open the map store"
                                : "stage 'b' (recorder): unknown exception (not a std::exception)");
    }
    EXPECT_EQ(j, (Journal{"begin a", "begin b"})) << what;
  }
}

// An output whose begin() throws fails the run; nothing ends, as for a stage.
TEST(StageLifecycle, AnOutputFailingToBeginEndsNothing) {
  test::ConfigFixture f;
  Pipeline p = f.loadSynthetic("{frames: 2}");
  Journal j;
  addRecorder(p, j, "a");
  addOutput(p, j, "out1");
  addOutput(p, j, "out2")->throws_in_begin = true;
  std::ostringstream log;
  EXPECT_THROW(runPipeline(p, quiet(log)), std::exception);
  EXPECT_EQ(j, (Journal{"begin a", "begin out1", "begin out2"}));
}

// A stage failing at the end costs the run its exit status (4) as an output would, named in the
// errors and the log; the stages after it and the outputs still end.
TEST(StageLifecycle, AStageFailingAtTheEndIsReportedAndTheOthersStillEnd) {
  test::ConfigFixture f;
  Pipeline p = f.loadSynthetic("{frames: 2}");
  Journal j;
  addRecorder(p, j, "a", "end");
  addRecorder(p, j, "b");
  addOutput(p, j, "out");
  std::ostringstream log;
  const RunResult r = runPipeline(p, quiet(log));
  EXPECT_EQ(r.summary.frames_ok, 2u);
  EXPECT_EQ(r.output_errors,
            (std::vector<std::string>{"stage 'a' (recorder): disk full while saving the map"}));
  EXPECT_EQ(r.exitCode(), 4);
  EXPECT_NE(log.str().find("stage 'a' (recorder): failed at the end: disk full"), std::string::npos)
      << log.str();
  EXPECT_EQ(std::vector<std::string>(j.end() - 3, j.end()),
            (std::vector<std::string>{"end a", "end b", "end out"}));
}

namespace {
/// Reads map `map.test`'s `hits` (frames that had points in a cell) from the run's state: its
/// highest count at each write() and at end(). Keeps the map itself past the run.
struct MapReader : Output {
  std::vector<float> at_write;
  float at_end = -1;
  std::shared_ptr<const TerrainGrid> kept;
  static float most(const TerrainGrid& m) {
    const Layer& h = m.layer("hits");
    return *std::max_element(h.begin(), h.end());
  }
  void write(const FrameContext& ctx) override {
    at_write.push_back(most(*ctx.run->findMap("map.test")));
  }
  void end(const RunSummary& s) override {
    at_end = most(*s.run->findMap("map.test"));
    kept = s.run->maps.at("map.test");
  }
};
}  // namespace

// A map stage, loaded from a library of its own as a real one would be, builds a map over the
// run in the run's state; an output reads it through core types only, and at its end sees
// every frame, the last included (a stage that could only add frame k − 1 at frame k lost it).
// A frame that fails after the stage added it is taken back out (frameFailed). Each run starts
// from an empty state: the plugin's begin() refuses one that holds its map already.
TEST(StageLifecycle, AMapBuiltOverTheRunIsReadWholeByAnOutputAtItsEnd) {
  test::ConfigFixture f;
  PluginRegistry reg({test::pluginDir(),
                      std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/synthetic_source",
                      std::string(TERRAMRF_TEST_PLUGIN_DIR) + "/run_map"});
  std::string text = test::ConfigFixture::validPipeline("{frames: 3}");
  text.insert(text.find("  - {name: mrf"), "  - {name: map, type: test_run_map}\n");
  LoadOptions lo;
  lo.output_dir = f.dir.str() + "/out";
  Pipeline p = loadPipeline(f.write("map.yaml", text), lo, reg);
  auto reader = std::make_unique<MapReader>();
  MapReader* seen = reader.get();
  p.outputs.push_back(std::move(reader));
  std::ostringstream log;
  for (int run = 0; run < 2; ++run) {
    seen->at_write.clear();
    const RunResult r = runPipeline(p, quiet(log));
    ASSERT_EQ(r.summary.frames_ok, 3u) << log.str();
    EXPECT_EQ(seen->at_write, (std::vector<float>{1, 2, 3})) << run;
    EXPECT_EQ(seen->at_end, 3.f) << run;
    ASSERT_EQ(r.metrics.size(), 3u);
    EXPECT_EQ(r.metrics[2].second.at("map.frames_in_map"), 3.0);
  }
  EXPECT_EQ(MapReader::most(*seen->kept), 3.f);  // shared: the output may keep it

  // An output after the reader fails frame 1: the map stage takes it back.
  Journal j;
  OutputRecorder* failing = addOutput(p, j, "failing");
  failing->throws = true;
  failing->throw_at = 1;
  seen->at_write.clear();
  const RunResult r = runPipeline(p, quiet(log));
  ASSERT_EQ(r.summary.frames_ok, 2u);
  EXPECT_EQ(seen->at_write, (std::vector<float>{1, 2, 2}));  // frame 1's writes, then frame 2's
  EXPECT_EQ(seen->at_end, 2.f);
  ASSERT_EQ(r.metrics.size(), 2u);
  EXPECT_EQ(r.metrics[1].second.at("map.frames_in_map"), 2.0);
}

}  // namespace terramrf
