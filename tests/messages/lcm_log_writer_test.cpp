// LcmLogWriter: LCM logs written by TerraMRF itself, every write checked. Read back with LCM's
// own reader (lcm/eventlog.h, LCM's C API: no clash with anything here).
#include <gtest/gtest.h>
#include <lcm/eventlog.h>
#include <sys/resource.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "terramrf/atomic_file.hpp"
#include "terramrf/lcm/grid_publisher.hpp"
#include "terramrf/lcm/log_writer.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

struct Event {
  std::int64_t eventnum = 0;
  std::int64_t timestamp = 0;
  std::string channel;
  std::vector<std::uint8_t> data;
};

// Every event LCM's reader finds, in order (it stops at the end or at the first it cannot read).
std::vector<Event> readWithLcm(const std::string& path) {
  std::vector<Event> out;
  lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "r");
  if (log == nullptr) return out;
  while (lcm_eventlog_event_t* e = lcm_eventlog_read_next_event(log)) {
    const auto* p = static_cast<const std::uint8_t*>(e->data);
    out.push_back({e->eventnum, e->timestamp, std::string(e->channel, e->channellen),
                   std::vector<std::uint8_t>(p, p + e->datalen)});
    lcm_eventlog_free_event(e);
  }
  lcm_eventlog_destroy(log);
  return out;
}

std::string fileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

std::vector<std::uint8_t> bytes(std::size_t n, std::uint8_t seed) {
  std::vector<std::uint8_t> v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = static_cast<std::uint8_t>(seed + 7 * i);
  return v;
}

std::int64_t nowMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

TEST(LcmLogWriter, WritesTheBytesLcmsOwnWriterWrites) {
  test::TempDir dir;
  const std::string ours = dir.str() + "/ours.lcmlog";
  const std::string theirs = dir.str() + "/theirs.lcmlog";
  const auto a = bytes(100, 1), b = bytes(0, 0), c = bytes(70000, 3);
  {
    LcmLogWriter w(ours, false);
    w.write("GRID", a.data(), a.size(), 1000);
    w.write("GRID_POINTS", b.data(), b.size(), 2000);
    w.write("GRID", c.data(), c.size(), -5);
    w.close();
    EXPECT_EQ(w.eventsWritten(), 3);
    EXPECT_EQ(w.bytesComplete(), static_cast<std::int64_t>(std::filesystem::file_size(ours)));
  }
  lcm_eventlog_t* log = lcm_eventlog_create(theirs.c_str(), "w");
  ASSERT_NE(log, nullptr);
  const std::pair<std::string, const std::vector<std::uint8_t>*> msgs[] = {
      {"GRID", &a}, {"GRID_POINTS", &b}, {"GRID", &c}};
  const std::int64_t stamps[] = {1000, 2000, -5};
  for (int i = 0; i < 3; ++i) {
    lcm_eventlog_event_t e{};
    e.timestamp = stamps[i];
    e.channellen = static_cast<std::int32_t>(msgs[i].first.size());
    e.datalen = static_cast<std::int32_t>(msgs[i].second->size());
    e.channel = const_cast<char*>(msgs[i].first.c_str());
    e.data = const_cast<std::uint8_t*>(msgs[i].second->data());
    ASSERT_EQ(lcm_eventlog_write_event(log, &e), 0);
  }
  lcm_eventlog_destroy(log);
  EXPECT_EQ(fileBytes(ours), fileBytes(theirs));
}

TEST(LcmLogWriter, ReadsBackWithLcmsReaderStampedNow) {
  test::TempDir dir;
  const std::string path = dir.str() + "/run.lcmlog";
  const auto a = bytes(300, 5), b = bytes(12, 9);
  const std::int64_t before = nowMicros();
  LcmLogWriter w(path, false);
  w.write("TERRAMRF_GRID", a.data(), a.size());
  w.write("TERRAMRF_GRID_POINTS", b.data(), b.size());
  w.close();
  const std::int64_t after = nowMicros();

  const auto events = readWithLcm(path);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].eventnum, 0);
  EXPECT_EQ(events[1].eventnum, 1);
  EXPECT_EQ(events[0].channel, "TERRAMRF_GRID");
  EXPECT_EQ(events[1].channel, "TERRAMRF_GRID_POINTS");
  EXPECT_EQ(events[0].data, a);
  EXPECT_EQ(events[1].data, b);
  // Wall-clock µs at the write, as LCM's file provider stamped them.
  for (const Event& e : events) {
    EXPECT_GE(e.timestamp, before);
    EXPECT_LE(e.timestamp, after);
  }
  EXPECT_LE(events[0].timestamp, events[1].timestamp);
}

TEST(LcmLogWriter, AppendModeKeepsWhatIsThere) {
  test::TempDir dir;
  const std::string path = dir.str() + "/run.lcmlog";
  const auto a = bytes(40, 1), b = bytes(50, 2);
  {
    LcmLogWriter w(path, false);
    w.write("A", a.data(), a.size(), 1);
    w.close();
  }
  const auto size1 = static_cast<std::int64_t>(std::filesystem::file_size(path));
  LcmLogWriter w(path, true);
  EXPECT_EQ(w.bytesComplete(), size1);
  w.write("B", b.data(), b.size(), 2);
  w.close();
  const auto events = readWithLcm(path);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].channel, "A");
  EXPECT_EQ(events[1].channel, "B");
  EXPECT_EQ(events[1].data, b);
  EXPECT_EQ(events[1].eventnum, 0);  // LCM numbers the events of each writer from 0 too

  // mode=w replaces the log.
  LcmLogWriter r(path, false);
  r.write("C", a.data(), a.size(), 3);
  r.close();
  ASSERT_EQ(readWithLcm(path).size(), 1u);
}

// /dev/full: every write fails with ENOSPC. LCM's provider reported success for each publish.
TEST(LcmLogWriter, FailedWriteIsReportedNamingTheFileAndTheError) {
  LcmLogWriter w("/dev/full", false);
  const auto a = bytes(1000, 1);
  for (int i = 0; i < 2; ++i) {  // nothing reached the device: the next write is tried again
    try {
      w.write("TERRAMRF_GRID", a.data(), a.size());
      FAIL() << "write to /dev/full reported no error";
    } catch (const std::runtime_error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("LCM log '/dev/full': cannot write event 0 (channel 'TERRAMRF_GRID', "
                          "1000 bytes of message): " +
                          std::string(std::strerror(ENOSPC))),
                std::string::npos)
          << what;
      EXPECT_NE(what.find("nothing of it reached the file"), std::string::npos) << what;
    }
  }
  EXPECT_EQ(w.eventsWritten(), 0);
  EXPECT_NO_THROW(w.close());
}

// A real file that fills up in the middle of an event (RLIMIT_FSIZE stands in for a full disk: the
// write stops at the limit, then fails with EFBIG). The cut event is removed, and writing goes on
// once there is room again.
TEST(LcmLogWriter, EventCutByAFullFileIsRemovedAndLaterEventsStayReadable) {
  test::TempDir dir;
  const std::string path = dir.str() + "/run.lcmlog";
  const auto a = bytes(100, 1), big = bytes(5000, 2), c = bytes(30, 3);
  LcmLogWriter w(path, false);
  w.write("A", a.data(), a.size(), 10);
  const std::int64_t one = w.bytesComplete();

  struct rlimit old {};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old), 0);
  auto* old_handler = std::signal(SIGXFSZ, SIG_IGN);  // else the process is killed at the limit
  struct rlimit lim = old;
  lim.rlim_cur = static_cast<rlim_t>(one + 1000);
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &lim), 0);
  std::string what;
  try {
    w.write("BIG", big.data(), big.size(), 20);
  } catch (const std::runtime_error& e) {
    what = e.what();
  }
  const auto size_after = std::filesystem::file_size(path);
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &old), 0);
  std::signal(SIGXFSZ, old_handler);

  EXPECT_NE(what.find("LCM log '" + path +
                      "': cannot write event 1 (channel 'BIG', 5000 bytes "
                      "of message): " +
                      std::string(std::strerror(EFBIG)) +
                      "; the 1000 bytes written of it were removed, the file keeps its 1 whole "
                      "event(s), " +
                      std::to_string(one) + " bytes"),
            std::string::npos)
      << what;
  EXPECT_EQ(size_after, static_cast<std::uintmax_t>(one));
  EXPECT_EQ(w.eventsWritten(), 1);

  w.write("C", c.data(), c.size(), 30);
  w.close();
  const auto events = readWithLcm(path);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].channel, "A");
  EXPECT_EQ(events[1].channel, "C");
  EXPECT_EQ(events[1].eventnum, 1);
  EXPECT_EQ(events[1].data, c);
}

// A log that cannot be cut back (a device, a pipe, or ftruncate failing) with part of an event in
// it: readers would take the next event for the rest of this one, so nothing more is written.
class HalfWriteThenFail : public LcmLogWriter {
 public:
  using LcmLogWriter::LcmLogWriter;
  int fail_after_calls = -1;  // writes that succeed before one is cut
  int truncate_errno = 0;     // 0: truncation works

 protected:
  ssize_t writeSome(int fd, const void* buf, std::size_t n) override {
    if (fail_after_calls < 0 || calls_++ < fail_after_calls)
      return LcmLogWriter::writeSome(fd, buf, n);
    if (!cut_) {
      cut_ = true;
      return LcmLogWriter::writeSome(fd, buf, n / 2);
    }
    errno = ENOSPC;
    return -1;
  }
  int truncateTo(int fd, off_t length) override {
    if (truncate_errno == 0) return LcmLogWriter::truncateTo(fd, length);
    errno = truncate_errno;
    return -1;
  }

 private:
  int calls_ = 0;
  bool cut_ = false;
};

TEST(LcmLogWriter, CutEventThatCannotBeRemovedStopsTheLog) {
  test::TempDir dir;
  const std::string path = dir.str() + "/run.lcmlog";
  const auto a = bytes(100, 1), b = bytes(400, 2);
  HalfWriteThenFail w(path, false);
  w.write("A", a.data(), a.size(), 1);
  w.fail_after_calls = 0;
  w.truncate_errno = EIO;
  try {
    w.write("B", b.data(), b.size(), 2);
    FAIL() << "cut event not reported";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot write event 1 (channel 'B', 400 bytes of "
                                         "message): " +
                                         std::string(std::strerror(ENOSPC)) +
                                         "; 14 bytes of it are in the file and cutting it back "
                                         "failed: " +
                                         std::strerror(EIO) + ", so nothing more is written"),
              std::string::npos)
        << e.what();
  }
  w.fail_after_calls = -1;  // the file would take more now, but it must not get it
  try {
    w.write("C", a.data(), a.size(), 3);
    FAIL() << "event written after a cut one";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("LCM log '" + path +
                                         "': event 1 (channel 'C', 100 "
                                         "bytes of message) not written: the log ends in event 1, "
                                         "cut after 14 of its bytes"),
              std::string::npos)
        << e.what();
  }
  try {
    w.close();
    FAIL() << "close() of a log ending in a cut event reported nothing";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("LCM log '" + path + "': the log ends in event 1"),
              std::string::npos)
        << e.what();
  }
  const auto events = readWithLcm(path);  // the whole events before the cut one still read
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].channel, "A");
}

// A missing folder is made, as for every output (`out/x.lcm` on a fresh clone); a folder that
// cannot be made, or a path that cannot be opened, is an error naming it.
TEST(LcmLogWriter, MakesItsFolderAndOpenFailureNamesTheFile) {
  test::TempDir dir;
  const std::string path = dir.str() + "/no/such/folder/run.lcmlog";
  {
    LcmLogWriter w(path, false);
    w.close();
  }
  EXPECT_TRUE(std::filesystem::is_regular_file(path));
  writeFileAtomic(dir.str() + "/file", "x");
  const std::string under_file = dir.str() + "/file/run.lcmlog";
  try {
    LcmLogWriter w(under_file, false);
    FAIL() << "opened a log under a file";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(
        std::string(e.what()).rfind(
            "cannot create folder '" + dir.str() + "/file' for LCM log '" + under_file + "': ", 0),
        0u)
        << e.what();
  }
  try {
    LcmLogWriter w(dir.str() + "/no", false);  // a folder
    FAIL() << "opened a folder as a log";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              "cannot open LCM log '" + dir.str() + "/no' for writing: " + std::strerror(EISDIR));
  }
}

TEST(LcmLogWriter, ChannelsAndSizesNoReaderTakesAreRefused) {
  LcmLogWriter w("/dev/null", false);
  const auto a = bytes(4, 1);
  EXPECT_THROW(w.write("", a.data(), a.size()), std::invalid_argument);
  EXPECT_THROW(w.write(std::string(1000, 'C'), a.data(), a.size()), std::invalid_argument);
  EXPECT_NO_THROW(w.write(std::string(999, 'C'), a.data(), a.size()));
  EXPECT_THROW(w.write("A", a.data(), std::size_t{1} << 31), std::invalid_argument);
  w.close();
  EXPECT_THROW(w.write("A", a.data(), a.size()), std::runtime_error);  // closed
}

TEST(LcmLogUrl, ParsedAsLcmSplitsIt) {
  EXPECT_FALSE(parseLcmLogUrl("udpm://239.255.76.67:7667?ttl=0"));
  EXPECT_FALSE(parseLcmLogUrl("memq://"));
  EXPECT_FALSE(parseLcmLogUrl(""));
  auto u = parseLcmLogUrl("file:///tmp/run.lcmlog?mode=w");
  ASSERT_TRUE(u);
  EXPECT_EQ(u->path, "/tmp/run.lcmlog");
  EXPECT_FALSE(u->append);
  u = parseLcmLogUrl("file://rel/run.lcmlog?mode=a");
  ASSERT_TRUE(u);
  EXPECT_EQ(u->path, "rel/run.lcmlog");  // relative to the working folder, as LCM takes it
  EXPECT_TRUE(u->append);

  const auto error = [](const std::string& url) {
    try {
      parseLcmLogUrl(url);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  EXPECT_EQ(error("file:///tmp/x.lcmlog"),
            "'file:///tmp/x.lcmlog' opens the log for reading; to write one give ?mode=w (or "
            "?mode=a to append), e.g. file:///tmp/run.lcmlog?mode=w");
  EXPECT_NE(error("file:///tmp/x.lcmlog?mode=r").find("mode 'r' is not a write mode"),
            std::string::npos);
  EXPECT_NE(error("file:///tmp/x.lcmlog?mode=w&speed=2").find("option 'speed' has no meaning"),
            std::string::npos);
  EXPECT_NE(error("file:///tmp/x.lcmlog?mode=w&mode=a").find("gives both mode=w and mode=a"),
            std::string::npos);
  EXPECT_NE(error("file://?mode=w").find("names no log file"), std::string::npos);
}

TEST(LcmLogWriter, GridPublisherWritesFileUrlsItself) {
  GridPublisher full("file:///dev/full?mode=w", "G");
  try {
    full.publishBytes("G", bytes(64, 1));
    FAIL() << "publishing into /dev/full reported no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("LCM log '/dev/full': cannot write event 0"),
              std::string::npos)
        << e.what();
  }
  EXPECT_NO_THROW(full.close());
  EXPECT_THROW(GridPublisher("file:///tmp/x.lcmlog", "G"), std::invalid_argument);

  // An empty URL is $LCM_DEFAULT_URL, which may name a log.
  test::TempDir dir;
  const std::string path = dir.str() + "/env.lcmlog";
  const char* old = std::getenv("LCM_DEFAULT_URL");
  const std::string saved = old != nullptr ? old : "";
  ::setenv("LCM_DEFAULT_URL", ("file://" + path + "?mode=w").c_str(), 1);
  {
    GridPublisher pub("", "G");
    pub.publishBytes("G_POINTS", bytes(10, 4));
    pub.close();
  }
  if (old != nullptr) {
    ::setenv("LCM_DEFAULT_URL", saved.c_str(), 1);
  } else {
    ::unsetenv("LCM_DEFAULT_URL");
  }
  const auto events = readWithLcm(path);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].channel, "G_POINTS");
  EXPECT_EQ(events[0].data, bytes(10, 4));
}

}  // namespace
}  // namespace terramrf
