// ScanAssembler: live messages put together into scans, with the clock given by the test.
#include "terramrf/lcm/scan_assembler.hpp"

#include <gtest/gtest.h>

#include "terramrf/lcm/camera_codec.hpp"
#include "terramrf/lcm/grid_codec.hpp"
#include "terramrf/lcm/labels_codec.hpp"
#include "terramrf/lcm/pose_codec.hpp"
#include "terramrf/lcm/sensor_codec.hpp"

namespace terramrf {
namespace {

MessageBytes cloud(const std::string& id, double t_s) {
  PointCloud c;
  c.push_back(1, 0, 0, 0, 0);
  return encodePointCloud(c, {id, "lidar", t_s});
}
MessageBytes pose(const std::string& id) {
  PoseMessage p;
  p.header = {id, "world", 0};
  return encodePose(p);
}
MessageBytes labels(const std::string& id) {
  PointLabels t;
  t.label = {labels::kRoad};
  return encodePointLabels(t, LabelSet::defaults(), {id, "lidar", 0});
}
MessageBytes imu(double t_s) {
  ImuSample s;
  s.t_s = t_s;
  return encodeImu(s);
}

class ScanAssemblerTest : public ::testing::Test {
 protected:
  ScanAssembler make(double wait_s = 0.5) {
    ScanAssembler::Options o;
    o.channels.points = "P";
    o.channels.pose = "POSE";
    o.channels.labels = "L";
    o.channels.imu = "IMU";
    o.wait_s = wait_s;
    o.max_held = 2;
    return ScanAssembler(o);
  }
  static void add(ScanAssembler& a, const std::string& ch, const MessageBytes& b, double t) {
    a.add(ch, b.data(), b.size(), t);
  }
};

TEST_F(ScanAssemblerTest, ScanIsReadyOnceItHasWhatItsChannelsPromise) {
  ScanAssembler a = make();
  add(a, "POSE", pose("a"), 0.0);  // before its cloud: held
  add(a, "P", cloud("a", 1.0), 0.1);
  EXPECT_FALSE(a.pop(0.1));  // labels still missing
  ASSERT_TRUE(a.nextDeadline());
  EXPECT_DOUBLE_EQ(*a.nextDeadline(), 0.6);
  add(a, "L", labels("a"), 0.2);  // after it, within the wait
  const auto r = a.pop(0.2);
  ASSERT_TRUE(r && r->scan);
  EXPECT_EQ(r->scan->id, "a");
  EXPECT_TRUE(r->scan->pose && r->scan->labels);
  EXPECT_EQ(r->scan->points.source, "channel P (scan 'a')");
  EXPECT_TRUE(a.empty());
}

// A grid made by another process (a feature node) is one more message a scan waits for: before
// its cloud (as lcm_publish sends it: the points last) or after it; two for one scan are an error
// of that scan.
TEST_F(ScanAssemblerTest, ScanWaitsForItsGridWhenAGridChannelIsRead) {
  ScanAssembler::Options o;
  o.channels.points = "P";
  o.channels.grid = "G";
  o.wait_s = 0.5;
  ScanAssembler a(o);
  GridGeometry geom;
  geom.size_m = 2;
  const MessageBytes ga = encodeGrid(TerrainGrid(geom), LabelSet::defaults(), {"a", "lidar", 0});
  const MessageBytes gb = encodeGrid(TerrainGrid(geom), LabelSet::defaults(), {"b", "lidar", 0});
  add(a, "G", ga, 0.0);  // held
  add(a, "P", cloud("a", 1.0), 0.1);
  auto r = a.pop(0.1);
  ASSERT_TRUE(r && r->scan);
  ASSERT_TRUE(r->scan->grid);
  EXPECT_EQ(r->scan->grid->bytes, std::vector<std::uint8_t>(ga.begin(), ga.end()));
  add(a, "P", cloud("b", 2.0), 0.2);
  EXPECT_FALSE(a.pop(0.2));  // its grid still missing
  add(a, "G", gb, 0.3);
  add(a, "G", gb, 0.3);
  r = a.pop(0.3);
  ASSERT_TRUE(r);
  EXPECT_FALSE(r->scan);
  EXPECT_NE(r->error.find("two terrain_grid_t messages for scan 'b'"), std::string::npos)
      << r->error;
}

TEST_F(ScanAssemblerTest, WaitRunsOutAndLateMessagesAreCounted) {
  ScanAssembler a = make(0.5);
  add(a, "P", cloud("a", 1.0), 0.0);
  EXPECT_FALSE(a.pop(0.49));
  const auto r = a.pop(0.5);
  ASSERT_TRUE(r && r->scan);
  EXPECT_FALSE(r->scan->pose);
  add(a, "POSE", pose("a"), 0.7);
  EXPECT_EQ(a.counts().late, 1u);
  EXPECT_TRUE(a.empty());
}

TEST_F(ScanAssemblerTest, ScansLeaveInTheOrderTheirCloudsCame) {
  ScanAssembler a = make(0.5);
  add(a, "P", cloud("a", 1.0), 0.0);
  add(a, "P", cloud("b", 1.1), 0.1);
  add(a, "POSE", pose("b"), 0.1);
  add(a, "L", labels("b"), 0.1);
  EXPECT_FALSE(a.pop(0.2));  // b is complete, a is not: b waits behind a
  add(a, "POSE", pose("a"), 0.2);
  add(a, "L", labels("a"), 0.2);
  EXPECT_EQ(a.pop(0.2)->scan->id, "a");
  EXPECT_EQ(a.pop(0.2)->scan->id, "b");
}

TEST_F(ScanAssemblerTest, SamplesGoToTheFirstScanAtOrAfterTheirTime) {
  ScanAssembler a = make(0);
  add(a, "IMU", imu(0.9), 0.0);
  add(a, "IMU", imu(1.0), 0.0);
  add(a, "IMU", imu(1.05), 0.0);  // after scan a's time: the next scan's
  add(a, "P", cloud("a", 1.0), 0.0);
  add(a, "P", cloud("b", 1.1), 0.0);
  a.flush();
  const auto ra = a.pop(0.0), rb = a.pop(0.0);
  ASSERT_TRUE(ra && ra->scan && rb && rb->scan);
  EXPECT_EQ(ra->scan->imu.size(), 2u);
  EXPECT_EQ(rb->scan->imu.size(), 1u);
}

TEST_F(ScanAssemblerTest, TwoPosesForAScanOrADamagedCloudAreErrorsOfTheirOwn) {
  ScanAssembler a = make(0);
  add(a, "POSE", pose("a"), 0.0);
  add(a, "POSE", pose("a"), 0.0);
  add(a, "P", cloud("a", 1.0), 0.0);
  const auto r = a.pop(0.0);
  ASSERT_TRUE(r);
  EXPECT_FALSE(r->scan);
  EXPECT_NE(r->error.find("two pose_t messages for scan 'a' (channel POSE, then channel POSE)"),
            std::string::npos)
      << r->error;
  EXPECT_EQ(r->error_source, "channel P (scan 'a')");

  add(a, "P", imu(1.0), 0.0);  // not a cloud, on the points channel
  const auto d = a.pop(0.0);
  ASSERT_TRUE(d);
  EXPECT_FALSE(d->scan);
  EXPECT_NE(d->error.find("not a terramrf_msgs point_cloud_t"), std::string::npos) << d->error;
  EXPECT_NE(d->error.find("a imu_t"), std::string::npos) << d->error;
}

// Labels and poses for scans whose clouds never come are held for a bounded number of scans.
TEST_F(ScanAssemblerTest, HeldMessagesAreBoundedAndForeignOnesCounted) {
  ScanAssembler a = make(0);
  for (const char* id : {"x", "y", "z"}) add(a, "POSE", pose(id), 0.0);
  EXPECT_EQ(a.counts().unclaimed, 1u);  // x, the oldest
  add(a, "L", pose("q"), 0.0);  // a pose on the labels channel
  EXPECT_EQ(a.counts().foreign, 1u);
  add(a, "OTHER", cloud("o", 0), 0.0);  // a channel not read: ignored
  EXPECT_TRUE(a.empty());
  a.flush();
  EXPECT_EQ(a.counts().unclaimed, 3u);
}

// A held message whose cloud came is no longer held: one orphan (a cloud lost over UDP) must not
// keep the claimed ids' bookkeeping growing, nor evict the newest.
TEST_F(ScanAssemblerTest, ClaimedIdsLeaveTheHeldListAndOrphansAreEvictedOldestFirst) {
  ScanAssembler a = make(0);  // max_held 2
  add(a, "POSE", pose("orphan"), 0.0);
  for (int k = 0; k < 50; ++k) {
    const std::string id = "s" + std::to_string(k);
    add(a, "POSE", pose(id), 0.0);
    add(a, "L", labels(id), 0.0);
    add(a, "P", cloud(id, k), 0.0);
    const auto r = a.pop(0.0);
    ASSERT_TRUE(r && r->scan) << id;
    EXPECT_TRUE(r->scan->pose && r->scan->labels) << id;
  }
  EXPECT_EQ(a.counts().unclaimed, 0u);  // the orphan is the only one held, under the bound
  add(a, "POSE", pose("t1"), 0.0);
  add(a, "POSE", pose("t2"), 0.0);  // three held: the orphan, the oldest, goes
  EXPECT_EQ(a.counts().unclaimed, 1u);
  add(a, "L", labels("t2"), 0.0);
  add(a, "P", cloud("t2", 60), 0.0);
  EXPECT_TRUE(a.pop(0.0)->scan->pose);  // t2's pose was kept
}

// A consumer slower than the sender: the oldest waiting scans are dropped, counted.
TEST_F(ScanAssemblerTest, WaitingScansAreBoundedKeepingTheNewest) {
  ScanAssembler::Options o;
  o.channels.points = "P";
  o.max_waiting = 3;
  ScanAssembler a(o);
  for (int k = 0; k < 5; ++k) add(a, "P", cloud("s" + std::to_string(k), k), 0.0);
  EXPECT_EQ(a.counts().scans_dropped, 2u);
  EXPECT_EQ(a.pop(0.0)->scan->id, "s2");
}

TEST_F(ScanAssemblerTest, UnnamedAndIncompleteAreCounted) {
  ScanAssembler a = make(0);
  PoseMessage p;
  p.header = {"", "world", 0};
  const MessageBytes unnamed = encodePose(p);
  add(a, "POSE", unnamed, 0.0);
  EXPECT_EQ(a.counts().unnamed, 1u);
  add(a, "P", cloud("a", 1), 0.0);
  ASSERT_TRUE(a.pop(0.0));
  EXPECT_EQ(a.counts().incomplete, 1u);  // its pose and labels never came
  add(a, "IMU", imu(5), 0.0);
  a.flush();
  EXPECT_EQ(a.counts().samples_dropped, 1u);  // after the last cloud
}

// With cameras listed, a scan waits for an image and a calibration of each.
TEST_F(ScanAssemblerTest, ScanWaitsForEachCamerasImageAndCalibration) {
  ScanAssembler::Options o;
  o.channels.points = "P";
  o.channels.images = "IMG";
  o.channels.camera_info = "CAL";
  o.cameras = {"left", "right"};
  o.wait_s = 1;
  ScanAssembler a(o);
  Image img;
  img.width = 1;
  img.height = 1;
  img.channels = 1;
  img.data = {5};
  CameraModel m;
  m.width = m.height = 1;
  const auto image = [&](const std::string& cam) { return encodeImage(img, cam, {"a", "lidar", 0}); };
  const auto info = [&](const std::string& cam) {
    m.name = cam;
    return encodeCameraInfo(m, {"a", "lidar", 0});
  };
  add(a, "IMG", image("left"), 0.0);
  add(a, "CAL", info("left"), 0.0);
  add(a, "P", cloud("a", 1.0), 0.0);
  add(a, "IMG", image("right"), 0.1);
  EXPECT_FALSE(a.pop(0.1));  // right's calibration still missing
  add(a, "CAL", info("right"), 0.2);
  const auto r = a.pop(0.2);
  ASSERT_TRUE(r && r->scan);
  EXPECT_EQ(r->scan->images.size(), 2u);
  EXPECT_EQ(r->scan->camera_infos.size(), 2u);
  EXPECT_EQ(a.counts().incomplete, 0u);
}

// Images of cameras not listed are dropped (counted); a second image of one camera for one scan
// is the scan's error and is not kept; a truth image comes along; held bytes are bounded.
TEST_F(ScanAssemblerTest, CameraMessagesAreBoundedAndCounted) {
  ScanAssembler::Options o;
  o.channels.points = "P";
  o.channels.images = "IMG";
  o.channels.camera_info = "CAL";
  o.channels.image_truth = "TRUTH";
  o.cameras = {"left"};
  o.wait_s = 0;
  o.max_held_bytes = 3000;
  ScanAssembler a(o);
  Image img;
  img.width = 30;
  img.height = 30;
  img.channels = 1;
  img.data.assign(900, 1);
  CameraModel m;
  m.name = "left";
  m.width = m.height = 30;
  const auto image = [&](const std::string& id, const std::string& cam) {
    return encodeImage(img, cam, {id, "lidar", 0});
  };
  add(a, "IMG", image("a", "right"), 0.0);
  EXPECT_EQ(a.counts().unlisted, 1u);
  add(a, "IMG", image("a", "left"), 0.0);
  add(a, "IMG", image("a", "left"), 0.0);  // a second: an error, not kept
  add(a, "TRUTH", image("a", "left"), 0.0);
  add(a, "CAL", encodeCameraInfo(m, {"a", "lidar", 0}), 0.0);
  add(a, "P", cloud("a", 1.0), 0.0);
  const auto r = a.pop(0.0);
  ASSERT_TRUE(r);
  EXPECT_FALSE(r->scan);
  EXPECT_NE(r->error.find("two image_t messages of camera 'left' for scan 'a'"),
            std::string::npos)
      << r->error;

  add(a, "IMG", image("b", "left"), 0.0);
  add(a, "TRUTH", image("b", "left"), 0.0);
  add(a, "CAL", encodeCameraInfo(m, {"b", "lidar", 0}), 0.0);
  add(a, "P", cloud("b", 2.0), 0.0);
  const auto rb = a.pop(0.0);
  ASSERT_TRUE(rb && rb->scan);
  EXPECT_EQ(rb->scan->image_truths.size(), 1u);

  // ~1 KB per image, 3 KB held at most: the fourth scan's image evicts the first's.
  for (const char* id : {"c", "d", "e", "f"}) add(a, "IMG", image(id, "left"), 0.0);
  EXPECT_EQ(a.counts().unclaimed, 1u);
}

}  // namespace
}  // namespace terramrf
