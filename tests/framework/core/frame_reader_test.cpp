// Reading ahead (FrameReader, RunOptions::read_ahead): frames reach the stages in order and once,
// results do not depend on it, a source that reads one frame at a time is never read twice at
// once, and a bad frame read ahead is reported as a bad frame read in place.
#include "frame_reader.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <numeric>
#include <set>
#include <sstream>
#include <thread>

#include "config_fixture.hpp"
#include "terramrf/pipeline.hpp"

namespace terramrf {
namespace {

/// Wraps a source and records how it is read: order, overlap, threads.
class ProbeSource final : public Source {
 public:
  /// With `await_overlap`, the first read waits (up to 10 s) for a second read to start, so a
  /// source read concurrently shows it whatever the scheduling.
  ProbeSource(std::unique_ptr<Source> inner, bool concurrent, bool await_overlap = false)
      : inner_(std::move(inner)), concurrent_(concurrent), await_overlap_(await_overlap) {}
  std::size_t size() const override { return inner_->size(); }
  std::string frameId(std::size_t i) const override { return inner_->frameId(i); }
  bool concurrentReads() const override { return concurrent_; }
  Frame read(std::size_t i) override {
    {
      std::unique_lock<std::mutex> lock(m_);
      order.push_back(i);
      threads.insert(std::this_thread::get_id());
      max_in_flight = std::max(max_in_flight, ++in_flight_);
      cv_.notify_all();
      if (await_overlap_ && !waited_) {
        waited_ = true;
        cv_.wait_for(lock, std::chrono::seconds(10), [&] { return in_flight_ >= 2; });
      }
    }
    struct Leave {
      ProbeSource& s;
      ~Leave() {
        std::lock_guard<std::mutex> lock(s.m_);
        --s.in_flight_;
      }
    } leave{*this};
    return inner_->read(i);
  }

  std::vector<std::size_t> order;
  std::set<std::thread::id> threads;
  int max_in_flight = 0;

 private:
  std::unique_ptr<Source> inner_;
  bool concurrent_, await_overlap_;
  std::mutex m_;
  std::condition_variable cv_;
  int in_flight_ = 0;
  bool waited_ = false;
};

/// What each frame looked like when it reached the outputs, in the order it did.
struct Seen {
  std::string id;
  std::size_t points = 0;
  double z_sum = 0;  // the synthetic frames differ by their noise: a fingerprint
  std::size_t obstacle_cells = 0;
  bool operator==(const Seen& o) const {
    return id == o.id && points == o.points && z_sum == o.z_sum &&
           obstacle_cells == o.obstacle_cells;
  }
};

class RecordOutput final : public Output {
 public:
  explicit RecordOutput(std::vector<Seen>& seen) : seen_(seen) { setIdentity("record", "record"); }
  void write(const FrameContext& ctx) override {
    Seen s;
    s.id = ctx.frame->id;
    s.points = ctx.frame->points.size();
    for (std::size_t k = 0; k < s.points; ++k) s.z_sum += ctx.frame->points.z[k];
    const auto& l = ctx.grid->labels();
    s.obstacle_cells = std::count(l.begin(), l.end(), labels::kObstacle);
    seen_.push_back(s);
  }

 private:
  std::vector<Seen>& seen_;
};

struct Observed {
  RunResult result;
  std::vector<Seen> seen;
  std::vector<std::size_t> order;
  std::set<std::thread::id> threads;
  int max_in_flight = 0;
  std::string log;
};

Observed runWith(test::ConfigFixture& f, const std::string& source_params, RunOptions ro,
                 bool concurrent, bool await_overlap = false) {
  Pipeline p = f.loadSynthetic(source_params);
  auto probe = std::make_unique<ProbeSource>(std::move(p.source), concurrent, await_overlap);
  ProbeSource& pr = *probe;
  p.source = std::move(probe);
  Observed r;
  p.outputs.push_back(std::make_unique<RecordOutput>(r.seen));
  std::ostringstream log;
  ro.progress = false;
  ro.log = &log;
  r.result = runPipeline(p, ro);
  r.order = pr.order;
  r.threads = pr.threads;
  r.max_in_flight = pr.max_in_flight;
  r.log = log.str();
  return r;
}

RunOptions readAhead(std::size_t n) {
  RunOptions ro;
  ro.read_ahead = n;
  return ro;
}

std::vector<std::size_t> range(std::size_t first, std::size_t n) {
  std::vector<std::size_t> v(n);
  std::iota(v.begin(), v.end(), first);
  return v;
}

}  // namespace

TEST(ReadAhead, SourceReadingOneFrameAtATimeIsReadInOrderOnOneThreadWithTheSameResults) {
  test::ConfigFixture f;
  const Observed in_place = runWith(f, "{frames: 6}", readAhead(0), false);
  ASSERT_EQ(in_place.seen.size(), 6u);
  EXPECT_EQ(in_place.result.read_threads, 0u);
  EXPECT_EQ(in_place.threads, std::set<std::thread::id>{std::this_thread::get_id()});

  const Observed ahead = runWith(f, "{frames: 6}", readAhead(3), false);
  EXPECT_EQ(ahead.result.exitCode(), 0);
  EXPECT_EQ(ahead.order, range(0, 6));
  EXPECT_EQ(ahead.max_in_flight, 1);
  ASSERT_EQ(ahead.threads.size(), 1u);  // one reader: thread-local scratch is kept between reads
  EXPECT_EQ(ahead.threads.count(std::this_thread::get_id()), 0u);
  EXPECT_EQ(ahead.result.read_ahead, 3u);
  EXPECT_EQ(ahead.result.read_threads, 1u);
  EXPECT_TRUE(ahead.seen == in_place.seen);
  ASSERT_GE(ahead.result.timings.size(), 2u);
  EXPECT_EQ(ahead.result.timings[0].name, "read");
  EXPECT_EQ(ahead.result.timings[1].name, "read wait");
  EXPECT_EQ(ahead.result.timings[1].ms.size(), 6u);
  EXPECT_NE(timingTable(ahead.result).find("read up to 3 ahead on 1 thread(s)"), std::string::npos);
}

TEST(ReadAhead, SourceAllowingConcurrentReadsIsReadInParallelAndFramesStayInOrder) {
  test::ConfigFixture f;
  const Observed in_place = runWith(f, "{frames: 8}", readAhead(0), true);
  const std::size_t hw = std::max(1u, std::thread::hardware_concurrency());
  const Observed ahead = runWith(f, "{frames: 8}", readAhead(4), true, /*await_overlap=*/hw > 1);
  EXPECT_EQ(ahead.result.exitCode(), 0);
  if (hw > 1) {
    EXPECT_GE(ahead.max_in_flight, 2);
    EXPECT_GE(ahead.threads.size(), 2u);
  }
  EXPECT_EQ(ahead.result.read_threads, std::min<std::size_t>(4, hw));
  std::vector<std::size_t> order = ahead.order;
  std::sort(order.begin(), order.end());
  EXPECT_EQ(order, range(0, 8));  // each frame read once
  ASSERT_EQ(ahead.seen.size(), 8u);
  EXPECT_TRUE(ahead.seen == in_place.seen);
}

// --read-ahead 64 holds 64 frames but reads them on no more threads than there are cores (before:
// 64 threads, on any machine).
TEST(ReadAhead, ThreadsAreCappedAtTheCoresWhileTheDepthStays) {
  test::ConfigFixture f;
  const std::size_t hw = std::max(1u, std::thread::hardware_concurrency());
  const Observed r = runWith(f, "{frames: 16, spacing_m: 0.5}", readAhead(64), true);
  EXPECT_EQ(r.result.exitCode(), 0);
  EXPECT_EQ(r.result.read_ahead, 64u);
  EXPECT_EQ(r.result.read_threads, std::min<std::size_t>(hw, 16));
  EXPECT_LE(r.threads.size(), hw);
  EXPECT_EQ(r.seen.size(), 16u);
}

TEST(ReadAhead, AutomaticDepthFollowsWhatTheSourceAllows) {
  test::ConfigFixture f;
  const Observed one = runWith(f, "{frames: 3}", RunOptions{}, false);
  EXPECT_EQ(one.result.read_ahead, 1u);
  EXPECT_EQ(one.result.read_threads, 1u);
  const Observed many = runWith(f, "{frames: 3}", RunOptions{}, true);
  const std::size_t hw = std::clamp<std::size_t>(std::thread::hardware_concurrency(), 1, 8);
  EXPECT_EQ(many.result.read_ahead, hw);
  EXPECT_EQ(many.result.read_threads, std::min<std::size_t>(hw, 3));
}

TEST(ReadAhead, BadFramesReadAheadAreReportedAndSkippedAsInPlace) {
  test::ConfigFixture f;
  for (bool concurrent : {false, true}) {
    const Observed r = runWith(f, "{frames: 5, bad_frames: [1, 3]}", readAhead(2), concurrent);
    EXPECT_EQ(r.result.exitCode(), 3);
    EXPECT_EQ(r.result.summary.frames_ok, 3u);
    ASSERT_EQ(r.result.summary.failed.size(), 2u);
    EXPECT_EQ(r.result.summary.failed[0].first, "000001");
    EXPECT_EQ(r.result.summary.failed[1].first, "000003");
    EXPECT_EQ(r.result.summary.failed[1].second,
              "[read] synthetic/000003.bin: size 13 bytes is not a multiple of 16");
    EXPECT_NE(r.log.find("frame 000003 failed and was skipped"), std::string::npos) << r.log;
    ASSERT_EQ(r.seen.size(), 3u);
    EXPECT_EQ(r.seen[0].id, "000000");
    EXPECT_EQ(r.seen[1].id, "000002");
    EXPECT_EQ(r.seen[2].id, "000004");
  }
}

TEST(ReadAhead, ReadsOnlyTheFramesOfTheRun) {
  test::ConfigFixture f;
  RunOptions ro = readAhead(4);
  ro.first = 2;
  ro.limit = 3;
  const Observed r = runWith(f, "{frames: 10}", ro, false);
  EXPECT_EQ(r.order, range(2, 3));
  ASSERT_EQ(r.seen.size(), 3u);
  EXPECT_EQ(r.seen.back().id, "000004");
}

TEST(FrameReader, ReadsNoFurtherThanItsDepthAndStopsWhenDestroyed) {
  test::ConfigFixture f;
  Pipeline p = f.loadSynthetic("{frames: 100}");
  ProbeSource probe(std::move(p.source), false);
  {
    FrameReader reader(probe, 0, 100, 3, 1);
    const FrameReader::Result r = reader.take(0);
    EXPECT_FALSE(r.error);
    EXPECT_EQ(r.frame.id, "000000");
    EXPECT_GE(r.read_ms, 0.0);
  }                                   // must not hang, nor read on
  EXPECT_LE(probe.order.size(), 4u);  // frame 0 and at most three beyond it
  EXPECT_EQ(probe.order, range(0, probe.order.size()));
}

}  // namespace terramrf
