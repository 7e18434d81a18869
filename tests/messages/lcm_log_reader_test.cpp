// LcmLogReader, peekMessageStamp and indexLogFrames: reading LCM logs back by scan. Logs are
// written with LcmLogWriter (the writer lcm_publish uses), whose format LCM's own reader reads.
#include <gtest/gtest.h>
#include <lcm/eventlog.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "terramrf/atomic_file.hpp"
#include "terramrf/errors.hpp"
#include "terramrf/lcm/labels_codec.hpp"
#include "terramrf/lcm/log_frame_index.hpp"
#include "terramrf/lcm/log_reader.hpp"
#include "terramrf/lcm/log_writer.hpp"
#include "terramrf/lcm/message_peek.hpp"
#include "terramrf/lcm/pose_codec.hpp"
#include "terramrf/lcm/sensor_codec.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

MessageBytes cloud(const std::string& id, double t_s, int points = 3) {
  PointCloud c;
  for (int i = 0; i < points; ++i) c.push_back(1.0f + i, 0, 0, 0, 0);
  return encodePointCloud(c, {id, "lidar", t_s});
}

MessageBytes pose(const std::string& id, double t_s) {
  PoseMessage p;
  p.header = {id, "world", t_s};
  return encodePose(p);
}

MessageBytes imu(double t_s) {
  ImuSample s;
  s.t_s = t_s;
  return encodeImu(s);
}

void put(LcmLogWriter& w, const std::string& channel, const MessageBytes& b) {
  w.write(channel, b.data(), b.size(), 0);
}

TEST(MessagePeek, NamesTypeTimeAndScanOfEachMessageType) {
  const MessageBytes c = cloud("000042", 4.2);
  auto s = peekMessageStamp(c.data(), c.size());
  ASSERT_TRUE(s);
  EXPECT_EQ(s->type, "point_cloud_t");
  EXPECT_EQ(s->utime, 4200000);
  EXPECT_EQ(s->frame_id, "000042");

  const MessageBytes p = pose("7", 1.5);
  s = peekMessageStamp(p.data(), p.size());
  ASSERT_TRUE(s);
  EXPECT_EQ(s->type, "pose_t");
  EXPECT_EQ(s->frame_id, "7");

  const MessageBytes i = imu(2.0);
  s = peekMessageStamp(i.data(), i.size());
  ASSERT_TRUE(s);
  EXPECT_EQ(s->type, "imu_t");
  EXPECT_EQ(s->utime, 2000000);
  EXPECT_TRUE(s->frame_id.empty());

  PointLabels t;
  t.label = {1};
  const MessageBytes l = encodePointLabels(t, LabelSet::defaults(), {"9", "lidar", 0});
  s = peekMessageStamp(l.data(), l.size());
  ASSERT_TRUE(s);
  EXPECT_EQ(s->type, "point_labels_t");
  EXPECT_EQ(s->frame_id, "9");
}

TEST(MessagePeek, ForeignOrCutBytesAreNotPeeked) {
  const MessageBytes c = cloud("000042", 4.2);
  EXPECT_FALSE(peekMessageStamp(c.data(), 18));  // the id's length but not the id
  MessageBytes foreign = c;
  foreign[0] ^= 0xff;  // another fingerprint
  EXPECT_FALSE(peekMessageStamp(foreign.data(), foreign.size()));
  EXPECT_FALSE(peekMessageStamp(nullptr, 0));
}

TEST(LcmLogReader, ReadsEventsWithTheirPlaceAndReadsOneAgainByIt) {
  test::TempDir dir;
  const std::string path = dir.str() + "/a.lcm";
  {
    LcmLogWriter w(path, false);
    put(w, "P", cloud("1", 0.1));
    put(w, "Q", pose("1", 0.1));
    w.close();
  }
  LcmLogReader r(path);
  const auto a = r.next();
  const auto b = r.next();
  ASSERT_TRUE(a && b);
  EXPECT_FALSE(r.next());
  EXPECT_EQ(a->offset, 0);
  EXPECT_EQ(a->channel, "P");
  EXPECT_EQ(b->channel, "Q");
  EXPECT_EQ(b->eventnum, 1);
  EXPECT_EQ(r.skippedBytes(), 0);
  EXPECT_EQ(r.endOfLastEvent(), static_cast<std::int64_t>(std::filesystem::file_size(path)));

  const LcmLogEvent again = r.readAt(b->offset);
  EXPECT_EQ(again.data, b->data);
  try {
    r.readAt(b->offset + 1);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("byte " + std::to_string(b->offset + 1)),
              std::string::npos)
        << e.what();
  }
}

TEST(LcmLogReader, ReadsAPrefixOfEachMessageWhenAskedAndStillFindsTheNextEvent) {
  test::TempDir dir;
  const std::string path = dir.str() + "/a.lcm";
  const MessageBytes big = cloud("1", 0.1, 1000), small = pose("1", 0.1);
  {
    LcmLogWriter w(path, false);
    put(w, "P", big);
    put(w, "Q", small);
    w.close();
  }
  LcmLogReader r(path);
  const auto a = r.next(64);
  const auto b = r.next(4096);
  ASSERT_TRUE(a && b);
  EXPECT_FALSE(r.next(64));
  EXPECT_EQ(a->data.size(), 64u);
  EXPECT_EQ(a->data_size, static_cast<std::int64_t>(big.size()));
  EXPECT_TRUE(std::equal(a->data.begin(), a->data.end(), big.begin()));
  EXPECT_EQ(b->data, small);  // shorter than the limit: whole
  EXPECT_EQ(b->data_size, static_cast<std::int64_t>(small.size()));
  EXPECT_EQ(r.skippedBytes(), 0);
  EXPECT_EQ(r.endOfLastEvent(), static_cast<std::int64_t>(std::filesystem::file_size(path)));
  EXPECT_EQ(r.readAt(a->offset).data, big);
}

TEST(LcmLogReader, MissingLogOrAFolderIsAnErrorNamingIt) {
  test::TempDir dir;
  EXPECT_THROW(LcmLogReader(dir.str() + "/none.lcm"), InputError);
  try {
    LcmLogReader r(dir.str());
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("is a folder"), std::string::npos) << e.what();
  }
}

// Damage between events and a cut last event are counted, and the whole events around them are
// still read (LCM 1.3's own reader drops the event before the damage and everything after it).
TEST(LcmLogReader, CountsBytesOfNoWholeEvent) {
  test::TempDir dir;
  const std::string a = dir.str() + "/a.lcm", b = dir.str() + "/b.lcm";
  {
    LcmLogWriter w(a, false);
    put(w, "P", cloud("1", 0.1));
    w.close();
    LcmLogWriter v(b, false);
    put(v, "P", cloud("2", 0.2));
    v.close();
  }
  const std::string one = readFile(a), two = readFile(b);
  const std::string damaged = dir.str() + "/d.lcm";
  {
    std::ofstream o(damaged, std::ios::binary);
    o << one << "garbage" << two << two.substr(0, two.size() / 2);
  }
  LcmLogReader r(damaged);
  int events = 0;
  while (r.next()) ++events;
  EXPECT_EQ(events, 2);
  EXPECT_EQ(r.skippedBytes(), static_cast<std::int64_t>(7 + two.size() / 2));
}

// A writer killed mid-event leaves a cut event; appending to the log (mode=a) then puts whole
// events after it, which the cut event's length would swallow as its data. They are read, and
// the cut event's bytes are counted.
TEST(LcmLogReader, CutEventDoesNotSwallowEventsAppendedAfterIt) {
  test::TempDir dir;
  const std::string path = dir.str() + "/a.lcm";
  const MessageBytes big = cloud("1", 0.1, 400);
  std::int64_t cut_at = 0;
  {
    LcmLogWriter w(path, false);
    put(w, "P", cloud("0", 0.0));
    cut_at = static_cast<std::int64_t>(std::filesystem::file_size(path));
    put(w, "P", big);
    w.close();
  }
  const auto whole = static_cast<std::int64_t>(std::filesystem::file_size(path));
  std::filesystem::resize_file(path, cut_at + (whole - cut_at) / 2);
  {
    LcmLogWriter w(path, true);
    put(w, "P", cloud("2", 0.2));
    put(w, "P", cloud("3", 0.3));
    w.close();
  }
  LcmLogReader r(path);
  std::vector<std::string> ids;
  while (const auto e = r.next())
    ids.push_back(peekMessageStamp(e->data.data(), e->data.size())->frame_id);
  EXPECT_EQ(ids, (std::vector<std::string>{"0", "2", "3"}));
  EXPECT_EQ(r.skippedBytes(), (whole - cut_at) / 2);
}

// Logs of LCM's own writer (lcm-logger, LCM's file:// provider) read the same.
TEST(LcmLogReader, ReadsWhatLcmsOwnWriterWrote) {
  test::TempDir dir;
  const std::string path = dir.str() + "/lcm.lcm";
  const MessageBytes a = cloud("1", 0.1), b = pose("1", 0.1);
  {
    lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "w");
    ASSERT_NE(log, nullptr);
    std::string channels[] = {"PTS", "POSE"};
    const MessageBytes* data[] = {&a, &b};
    for (int i = 0; i < 2; ++i) {
      lcm_eventlog_event_t e{};
      e.timestamp = 1000 * (i + 1);
      e.channellen = static_cast<int32_t>(channels[i].size());
      e.datalen = static_cast<int32_t>(data[i]->size());
      e.channel = channels[i].data();
      e.data = const_cast<std::uint8_t*>(data[i]->data());
      ASSERT_EQ(lcm_eventlog_write_event(log, &e), 0);
    }
    lcm_eventlog_destroy(log);
  }
  LcmLogReader r(path);
  const auto x = r.next();
  const auto y = r.next();
  ASSERT_TRUE(x && y);
  EXPECT_FALSE(r.next());
  EXPECT_EQ(x->channel, "PTS");
  EXPECT_EQ(x->data, a);
  EXPECT_EQ(y->log_utime, 2000);
  EXPECT_EQ(y->eventnum, 1);
  EXPECT_EQ(y->data, b);
  EXPECT_EQ(r.skippedBytes(), 0);
}

class LogFrameIndexTest : public ::testing::Test {
 protected:
  std::string log() const { return dir.str() + "/run.lcm"; }
  test::TempDir dir;
};

TEST_F(LogFrameIndexTest, GroupsMessagesByScanAndSamplesByTime) {
  {
    LcmLogWriter w(log(), false);
    put(w, "IMU", imu(0.05));
    put(w, "POSE", pose("a", 0.1));  // before its cloud
    put(w, "PTS", cloud("a", 0.1));
    put(w, "IMU", imu(0.1));  // at the scan's time: that scan's
    put(w, "IMU", imu(0.15));
    put(w, "PTS", cloud("b", 0.2));
    put(w, "POSE", pose("b", 0.2));  // after its cloud
    put(w, "POSE", pose("zz", 0.3));  // no such scan
    put(w, "IMU", imu(0.25));         // after the last scan
    put(w, "OTHER", imu(0.3));
    w.close();
  }
  LogChannels ch;
  ch.points = "PTS";
  ch.pose = "POSE";
  ch.imu = "IMU";
  const LogFrameIndex idx = indexLogFrames(log(), ch);
  ASSERT_EQ(idx.frames.size(), 2u);
  EXPECT_EQ(idx.frames[0].id, "a");
  EXPECT_EQ(idx.frames[1].id, "b");
  EXPECT_EQ(idx.frames[0].utime, 100000);
  EXPECT_TRUE(idx.frames[0].pose && idx.frames[1].pose);
  EXPECT_FALSE(idx.frames[0].labels);
  EXPECT_EQ(idx.frames[0].imu.size(), 2u);
  EXPECT_EQ(idx.frames[1].imu.size(), 1u);
  EXPECT_EQ(idx.channel_events.at("OTHER"), 1u);
  EXPECT_EQ(idx.channel_events.at("IMU"), 4u);
  ASSERT_EQ(idx.notes.size(), 2u);
  EXPECT_NE(idx.notes[0].find("name a scan with no point cloud (e.g. 'zz')"), std::string::npos)
      << idx.notes[0];
  EXPECT_NE(idx.notes[1].find("1 imu_t sample(s) on IMU come after the last scan"),
            std::string::npos)
      << idx.notes[1];

  // The offsets read back the right events.
  LcmLogReader r(log());
  const LcmLogEvent p = r.readAt(*idx.frames[1].pose);
  EXPECT_EQ(decodePose(p.data.data(), p.data.size()).header.frame_id, "b");
}

// Bytes this process has read through read(2) and the like so far (/proc/self/io `rchar`),
// from the page cache included: what indexing costs in I/O on a cold disk.
std::int64_t bytesReadSoFar() {
  std::ifstream io("/proc/self/io");
  std::string key;
  std::int64_t value = 0;
  while (io >> key >> value)
    if (key == "rchar:") return value;
  ADD_FAILURE() << "/proc/self/io has no rchar";
  return 0;
}

TEST_F(LogFrameIndexTest, ReadsAFewKilobytesPerMessageNotTheLog) {
  const int kScans = 12;
  const std::string long_id(6000, 'x');  // a stamp beyond the index's prefix: read whole
  {
    LcmLogWriter w(log(), false);
    for (int i = 0; i < kScans; ++i) {
      const std::string id = i == kScans - 1 ? long_id : std::to_string(i);
      put(w, "PTS", cloud(id, 0.1 * (i + 1), 50000));
      put(w, "POSE", pose(id, 0.1 * (i + 1)));
    }
    w.close();
  }
  const auto log_bytes = static_cast<std::int64_t>(std::filesystem::file_size(log()));
  LogChannels ch;
  ch.points = "PTS";
  ch.pose = "POSE";
  const std::int64_t before = bytesReadSoFar();
  const LogFrameIndex idx = indexLogFrames(log(), ch);
  const std::int64_t read = bytesReadSoFar() - before;
  ASSERT_EQ(idx.frames.size(), static_cast<std::size_t>(kScans));
  EXPECT_EQ(idx.frames[3].id, "3");
  EXPECT_EQ(idx.frames.back().id, long_id);
  for (const LogFrame& f : idx.frames) EXPECT_TRUE(f.pose) << f.id;
  EXPECT_TRUE(idx.notes.empty());
  // The long-named cloud is read whole; of the others a prefix each (and the few KiB of stdio's
  // buffer around each event's start and end).
  const std::int64_t one_cloud = log_bytes / kScans;
  EXPECT_LT(read, one_cloud + 200 * 1024) << "log " << log_bytes << " bytes";
  std::printf("indexing a %lld-byte log of %d scans read %lld bytes\n",
              static_cast<long long>(log_bytes), kScans, static_cast<long long>(read));
}

TEST_F(LogFrameIndexTest, TwoCloudsOfOneScanAreAnErrorNamingBothEvents) {
  {
    LcmLogWriter w(log(), false);
    put(w, "PTS", cloud("a", 0.1));
    put(w, "X", imu(0.1));
    put(w, "PTS", cloud("a", 0.2));
    w.close();
  }
  try {
    indexLogFrames(log(), {"PTS"});
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find(log()), std::string::npos) << w;
    EXPECT_NE(w.find("event 0 (byte 0) and event 2 (byte "), std::string::npos) << w;
    EXPECT_NE(w.find("on channel PTS both carry the point cloud"), std::string::npos) << w;
    EXPECT_NE(w.find("'a'"), std::string::npos) << w;
  }
}

// Two poses for one scan: that scan cannot be read (which pose was meant?), the others can.
TEST_F(LogFrameIndexTest, TwoPosesOfOneScanFailThatScanOnly) {
  {
    LcmLogWriter w(log(), false);
    put(w, "PTS", cloud("a", 0.1));
    put(w, "POSE", pose("a", 0.1));
    put(w, "POSE", pose("a", 0.1));
    put(w, "PTS", cloud("b", 0.2));
    put(w, "POSE", pose("b", 0.2));
    w.close();
  }
  LogChannels ch{"PTS"};
  ch.pose = "POSE";
  const LogFrameIndex idx = indexLogFrames(log(), ch);
  ASSERT_EQ(idx.frames.size(), 2u);
  EXPECT_NE(idx.frames[0].error.find("event 1 (byte "), std::string::npos) << idx.frames[0].error;
  EXPECT_NE(idx.frames[0].error.find("on channel POSE both carry pose_t for scan 'a'"),
            std::string::npos)
      << idx.frames[0].error;
  EXPECT_TRUE(idx.frames[1].error.empty());
  EXPECT_TRUE(idx.frames[1].pose);
}

// Images name their scan too: one without a frame_id, or of a scan with no cloud, is noted as
// such, like a pose.
TEST_F(LogFrameIndexTest, ImagesThatNameNoScanAreNoted) {
  Image img;
  img.width = img.height = img.channels = 1;
  img.data = {0};
  {
    LcmLogWriter w(log(), false);
    put(w, "IMG", encodeImage(img, "cam", {"", "lidar", 0}));
    put(w, "IMG", encodeImage(img, "cam", {"zz", "lidar", 0}));
    put(w, "IMG", encodeImage(img, "cam", {"a", "lidar", 0}));
    put(w, "PTS", cloud("a", 0.1));
    w.close();
  }
  LogChannels ch{"PTS"};
  ch.images = "IMG";
  const LogFrameIndex idx = indexLogFrames(log(), ch);
  ASSERT_EQ(idx.frames.size(), 1u);
  EXPECT_EQ(idx.frames[0].images.size(), 1u);
  ASSERT_EQ(idx.notes.size(), 2u);
  EXPECT_NE(idx.notes[0].find("1 image_t message(s) on IMG name no scan"), std::string::npos)
      << idx.notes[0];
  EXPECT_NE(idx.notes[1].find("1 image_t message(s) on IMG name a scan with no point cloud "
                              "(e.g. 'zz')"),
            std::string::npos)
      << idx.notes[1];
}

// A cloud that is no point_cloud_t stays a scan of its own, so that reading it fails alone.
TEST_F(LogFrameIndexTest, UnreadableCloudIsAScanNamedByItsEvent) {
  {
    LcmLogWriter w(log(), false);
    put(w, "PTS", cloud("a", 0.1));
    put(w, "PTS", imu(0.2));
    put(w, "PTS", cloud("c", 0.3));
    w.close();
  }
  const LogFrameIndex idx = indexLogFrames(log(), {"PTS"});
  ASSERT_EQ(idx.frames.size(), 3u);
  EXPECT_EQ(idx.frames[1].id, "event1");
}

TEST_F(LogFrameIndexTest, SamplesNeedCloudsInTimeOrder) {
  {
    LcmLogWriter w(log(), false);
    put(w, "PTS", cloud("a", 0.2));
    put(w, "PTS", cloud("b", 0.1));
    put(w, "IMU", imu(0.15));
    w.close();
  }
  LogChannels ch{"PTS"};
  EXPECT_EQ(indexLogFrames(log(), ch).frames.size(), 2u);  // no samples read: order is free
  ch.imu = "IMU";
  try {
    indexLogFrames(log(), ch);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("not in time order (event 1, scan 'b'"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace terramrf
