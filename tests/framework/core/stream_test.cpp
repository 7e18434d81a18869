// Stream sources (Source::streaming()): frames through next() until the stream ends, of a number
// unknown to the run; ids checked as they come; --first / --limit; a stop request that ends a
// stream waiting for a message that never comes (Source::interrupt()). The stream is the
// test-only plugin test_synthetic_stream (tests/framework/test_plugins/synthetic_stream.cpp).
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "config_fixture.hpp"
#include "frame_reader.hpp"
#include "terramrf/atomic_file.hpp"
#include "terramrf/pipeline.hpp"
#include "terramrf/stop_request.hpp"

namespace terramrf {
namespace {
namespace fs = std::filesystem;

/// The core tests' pipeline (ConfigFixture::validPipeline) on test_synthetic_stream with
/// `params`, outputs in `<fixture>/out`.
Pipeline loadStream(test::ConfigFixture& f, const std::string& params) {
  std::string text = test::ConfigFixture::validPipeline(params);
  const std::string from = "type: test_synthetic,", to = "type: test_synthetic_stream,";
  text.replace(text.find(from), from.size(), to);
  LoadOptions lo;
  lo.output_dir = f.dir.str() + "/out";
  return loadPipeline(f.write("stream.yaml", text), lo, f.registry);
}

/// Records what the run told it and what it saw; writes `probe/<id>.txt` per frame, and names
/// that file as the frame's, so the runner removes it for a failed frame.
struct Probe : Output {
  RunInfo info;
  RunSummary summary;
  std::vector<std::string> ids;
  std::vector<std::size_t> indices;
  int begins = 0, ends = 0;
  Probe() { setIdentity("probe", "probe"); }
  void begin(const RunInfo& i) override {
    ++begins;
    info = i;
    fs::create_directories(i.output_dir + "/probe");
  }
  void write(const FrameContext& ctx) override {
    ids.push_back(ctx.frame->id);
    indices.push_back(ctx.index);
    std::ofstream(info.output_dir + "/probe/" + ctx.frame->id + ".txt") << ctx.frame->id;
  }
  void end(const RunSummary& s) override {
    ++ends;
    summary = s;
  }
  std::vector<std::string> frameFiles(const std::string& id, const Frame*) const override {
    return {"probe/" + id + ".txt"};
  }
};

struct Ran {
  RunResult result;
  Probe* probe = nullptr;
  std::string log;
  double seconds = 0;  ///< wall time of runPipeline [s]
  std::string output_dir;
};

Ran runStream(test::ConfigFixture& f, Pipeline& p, RunOptions ro) {
  Ran r;
  auto probe = std::make_unique<Probe>();
  r.probe = probe.get();
  p.outputs.push_back(std::move(probe));
  std::ostringstream log;
  ro.progress = false;
  ro.log = &log;
  const auto t0 = std::chrono::steady_clock::now();
  r.result = runPipeline(p, ro);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.log = log.str();
  r.output_dir = p.output_dir;
  (void)f;
  return r;
}

RunOptions readAhead(std::size_t n) {
  RunOptions ro;
  ro.read_ahead = n;
  return ro;
}

/// Clears the process-wide stop request before and after a test.
struct StopRequestGuard {
  StopRequestGuard() { clearStopRequest(); }
  ~StopRequestGuard() { clearStopRequest(); }
};

}  // namespace

// A stream runs through the stages and outputs frame after frame until it ends, read in place or
// ahead on one thread; the run knows no total: RunInfo::frames and frames_total are 0, and the
// reports say "k frame(s)". Before, the runner needed size() up front and could not run one.
TEST(Stream, RunsItsFramesThroughStagesAndOutputsUntilItEnds) {
  for (const std::size_t ahead : {std::size_t{0}, std::size_t{1}, std::size_t{3}}) {
    SCOPED_TRACE("read_ahead " + std::to_string(ahead));
    test::ConfigFixture f;
    Pipeline p = loadStream(f, "{frames: 4}");
    ASSERT_TRUE(p.source->streaming());
    const Ran r = runStream(f, p, readAhead(ahead));
    EXPECT_EQ(r.result.exitCode(), 0) << r.log;
    EXPECT_EQ(r.result.summary.frames_ok, 4u);
    EXPECT_EQ(r.result.frames_total, 0u);
    EXPECT_EQ(r.probe->info.frames, 0u);
    EXPECT_EQ(r.probe->begins, 1);
    EXPECT_EQ(r.probe->ends, 1);
    EXPECT_EQ(r.probe->summary.frames_ok, 4u);
    EXPECT_EQ(r.probe->summary.frames_total, 0u);
    EXPECT_EQ(r.probe->ids, (std::vector<std::string>{"s000000", "s000001", "s000002", "s000003"}));
    EXPECT_EQ(r.probe->indices, (std::vector<std::size_t>{0, 1, 2, 3}));
    EXPECT_EQ(r.result.read_threads, ahead ? 1u : 0u);  // one order: next() after next()
    ASSERT_EQ(r.result.metrics.size(), 4u);             // the stages measured every frame
    EXPECT_EQ(r.result.metrics[3].first, "s000003");
    EXPECT_EQ(r.result.metrics[3].second.count("pre.obstacle_cells"), 1u);
    EXPECT_GT(r.result.metrics[3].second.at("pre.obstacle_cells"), 0.0);  // the box
    EXPECT_EQ(r.result.timings.back().ms.size(), 4u);
    writeRunReports(r.output_dir, r.result);
    EXPECT_NE(readFile(r.output_dir + "/metrics.csv").find("s000003,pre.obstacle_cells,"),
              std::string::npos);
  }
}

// A stream's ids cannot be checked before the run: a frame whose id names an earlier frame's
// files fails as it comes, naming both, and the run goes on. The earlier frame's files stay (a
// failed frame's files are otherwise removed as an earlier run's). A frame next() cannot give
// fails as `#<position>`.
TEST(Stream, ARepeatedIdFailsThatFrameNamingBothAndTheRunGoesOn) {
  for (const std::size_t ahead : {std::size_t{0}, std::size_t{2}}) {
    SCOPED_TRACE("read_ahead " + std::to_string(ahead));
    test::ConfigFixture f;
    Pipeline p = loadStream(f, "{frames: 6, ids: [a, x y, a, x_y, c, d], bad_frames: [4]}");
    const Ran r = runStream(f, p, readAhead(ahead));
    EXPECT_EQ(r.probe->ids, (std::vector<std::string>{"a", "x y", "d"}));
    EXPECT_EQ(r.result.summary.frames_ok, 3u);
    ASSERT_EQ(r.result.summary.failed.size(), 3u);
    EXPECT_EQ(r.result.summary.failed[0].first, "a");
    EXPECT_EQ(r.result.summary.failed[0].second,
              "[read] frame 2 of the stream ('a') and frame 0 ('a') both write 'a': skipped, so "
              "that it cannot write over that frame's outputs; a stream must give every frame a "
              "distinct id");
    EXPECT_EQ(r.result.summary.failed[1].first, "x_y");
    EXPECT_NE(r.result.summary.failed[1].second.find(
                  "frame 3 of the stream ('x_y') and frame 1 ('x y') both write 'x_y'"),
              std::string::npos)
        << r.result.summary.failed[1].second;
    EXPECT_EQ(r.result.summary.failed[2].first, "#4");
    EXPECT_EQ(r.result.summary.failed[2].second,
              "[read] stream message 4: truncated: 12 of 40 bytes");
    EXPECT_EQ(r.result.exitCode(), 3);
    EXPECT_EQ(r.probe->ends, 1);
    // Frame 0's and 1's own files: not removed when their namesakes failed.
    EXPECT_EQ(readFile(r.output_dir + "/probe/a.txt"), "a");
    EXPECT_EQ(readFile(r.output_dir + "/probe/x y.txt"), "x y");
    EXPECT_EQ(r.log.find("removed"), std::string::npos) << r.log;
    EXPECT_NE(r.log.find("frame a failed and was skipped"), std::string::npos) << r.log;
  }
}

// Every frame of a stream failing is exit status 4, as for a batch; before, 4 needed a known
// total, and a stream's is 0.
TEST(Stream, EveryFrameFailingIsStatus4AndAnEmptyStreamIs0) {
  test::ConfigFixture f;
  {
    Pipeline p = loadStream(f, "{frames: 2, bad_frames: [0, 1]}");
    const Ran r = runStream(f, p, readAhead(1));
    EXPECT_EQ(r.result.summary.failed.size(), 2u);
    EXPECT_EQ(r.result.exitCode(), 4);
  }
  Pipeline p = loadStream(f, "{frames: 0}");
  const Ran r = runStream(f, p, readAhead(1));
  EXPECT_EQ(r.result.summary.frames_ok + r.result.summary.failed.size(), 0u);
  EXPECT_EQ(r.probe->ends, 1);
  EXPECT_EQ(r.result.exitCode(), 0);
}

// --limit stops after N frames, without asking a stream that would wait for the next one (it
// would wait its wait_limit_s, 30 s, were it asked and not interrupted); --first skips the
// stream's first N, which keep their positions (FrameContext::index); a stream that ends before
// --first runs nothing and says so.
TEST(Stream, LimitStopsAfterNFramesAndFirstSkipsTheFirstN) {
  for (const std::size_t ahead : {std::size_t{0}, std::size_t{1}, std::size_t{4}}) {
    SCOPED_TRACE("read_ahead " + std::to_string(ahead));
    test::ConfigFixture f;
    {
      Pipeline p = loadStream(f, "{frames: 3, after: wait, wait_limit_s: 30}");
      RunOptions ro = readAhead(ahead);
      ro.limit = 3;
      const Ran r = runStream(f, p, ro);
      EXPECT_EQ(r.result.summary.frames_ok, 3u);
      EXPECT_EQ(r.result.exitCode(), 0);
      EXPECT_LT(r.seconds, 20.0);
    }
    {
      Pipeline p = loadStream(f, "{frames: 10}");
      RunOptions ro = readAhead(ahead);
      ro.first = 2;
      ro.limit = 3;
      const Ran r = runStream(f, p, ro);
      EXPECT_EQ(r.probe->ids, (std::vector<std::string>{"s000002", "s000003", "s000004"}));
      EXPECT_EQ(r.probe->indices, (std::vector<std::size_t>{2, 3, 4}));
      EXPECT_EQ(r.result.frames_total, 0u);
    }
    Pipeline p = loadStream(f, "{frames: 4}");
    RunOptions ro = readAhead(ahead);
    ro.first = 6;
    const Ran r = runStream(f, p, ro);
    EXPECT_EQ(r.result.summary.frames_ok + r.result.summary.failed.size(), 0u);
    EXPECT_EQ(r.result.exitCode(), 0);
    EXPECT_NE(r.log.find("note: the stream of source 'test_synthetic_stream' ended before frame 6 "
                         "(--first 6 skips the frames before it): no frame was run"),
              std::string::npos)
        << r.log;
  }
}

// A stop requested while the stream waits for a message that never comes: the run interrupts
// the source (Source::interrupt()) at once, ends every output and returns with status 130, the
// summaries saying "after 2 frame(s)" with no total. Before, the read-ahead wait had no stop
// condition and the shutdown joined the blocked read: the first SIGINT was ignored, the second
// killed the process without the outputs' end(). The stream waits up to 30 s unless interrupted;
// the run must end well before.
TEST(Stream, AStopWhileTheStreamWaitsEndsTheRunAtOnceAndTheOutputsStillEnd) {
  // Read ahead by one at most: the stream then waits only once the run has taken both frames.
  for (const std::size_t ahead : {std::size_t{0}, std::size_t{1}}) {
    SCOPED_TRACE("read_ahead " + std::to_string(ahead));
    StopRequestGuard guard;
    test::ConfigFixture f;
    Pipeline p =
        loadStream(f, "{frames: 2, after: wait, stop_when_waiting: true, wait_limit_s: 30}");
    const Ran r = runStream(f, p, readAhead(ahead));
    EXPECT_LT(r.seconds, 20.0);
    EXPECT_EQ(r.result.summary.frames_ok, 2u);
    EXPECT_EQ(r.result.summary.stop_signal, SIGINT);
    EXPECT_EQ(r.result.exitCode(), 130);
    EXPECT_EQ(r.probe->ends, 1);
    EXPECT_EQ(r.probe->summary.stop_signal, SIGINT);
    EXPECT_EQ(interruptionText(r.result.summary), "interrupted (SIGINT) after 2 frame(s)");
    EXPECT_NE(r.log.find("run interrupted (SIGINT) after 2 frame(s); ending the outputs"),
              std::string::npos)
        << r.log;
    writeRunReports(r.output_dir, r.result);
    EXPECT_EQ(readFile(r.output_dir + "/timing.md")
                  .rfind("Run interrupted (SIGINT) after 2 frame(s): timings of those only.", 0),
              0u);
  }
}

TEST(Stream, InterruptionTextOfARunWithoutATotalCountsItsFramesOnly) {
  RunSummary s;
  s.frames_ok = 5;
  s.failed = {{"a", "why"}};
  s.stop_signal = SIGTERM;
  EXPECT_EQ(interruptionText(s), "interrupted (SIGTERM) after 6 frame(s)");
  s.frames_total = 9;
  EXPECT_EQ(interruptionText(s), "interrupted (SIGTERM) after 6 of 9 frame(s)");
}

// Reading a stream ahead: a reader destroyed while its thread waits in next() interrupts the
// source instead of waiting for a message (30 s here); take() past the end says so.
TEST(FrameReader, AStreamWaitingInNextIsInterruptedWhenTheReaderEnds) {
  test::ConfigFixture f;
  Pipeline p = loadStream(f, "{frames: 1, after: wait, wait_limit_s: 30}");
  const auto t0 = std::chrono::steady_clock::now();
  {
    FrameReader reader(*p.source, 0, static_cast<std::size_t>(-1), 1, 1);
    const FrameReader::Result r = reader.take(0);
    EXPECT_FALSE(r.end);
    EXPECT_EQ(r.frame.id, "s000000");
  }  // its thread now waits in next() for frame 1, or is about to
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 20.0);

  Pipeline q = loadStream(f, "{frames: 1}");
  FrameReader reader(*q.source, 0, static_cast<std::size_t>(-1), 2, 1);
  EXPECT_FALSE(reader.take(0).end);
  EXPECT_TRUE(reader.take(1).end);
}

// A stream's batch functions are not there to be called, and a batch's next() neither.
TEST(Stream, TheOtherKindsFunctionsSayWhatTheSourceIs) {
  test::ConfigFixture f;
  Pipeline s = loadStream(f, "{frames: 1}");
  EXPECT_EQ(s.source->size(), 0u);
  EXPECT_THROW(s.source->read(0), std::logic_error);
  EXPECT_THROW(s.source->frameId(0), std::logic_error);
  Pipeline b = f.loadSynthetic("{frames: 1}");
  EXPECT_FALSE(b.source->streaming());
  try {
    b.source->next();
    ADD_FAILURE() << "next() of a batch returned";
  } catch (const std::logic_error& e) {
    EXPECT_NE(std::string(e.what()).find("source 'test_synthetic' is a batch"), std::string::npos)
        << e.what();
  }
}

}  // namespace terramrf
