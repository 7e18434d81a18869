// The "lcm_publish" output. memq:// is private to the plugin's own LCM instance, so what it sends
// is observed through LCM's file:// provider (an LCM log), read back with lcm::LogFile.
#include <gtest/gtest.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <lcm/lcm-cpp.hpp>
#include <vector>

#include "output_test_support.hpp"
#include "terramrf/lcm/camera_codec.hpp"
#include "terramrf/lcm/grid_codec.hpp"
#include "terramrf/lcm/labels_codec.hpp"
#include "terramrf/lcm/origins_codec.hpp"
#include "terramrf/lcm/pose_codec.hpp"
#include "terramrf/lcm/sensor_codec.hpp"

namespace terramrf {
namespace {

class LcmPublishTest : public ::testing::Test {
 protected:
  LcmPublishTest() : grid(test::outputTestGeometry()) {
    frame.id = "000005";
    frame.timestamp_s = 0.5;
    grid.labels()[grid.index(3, 0)] = labels::kObstacle;
    grid.labels()[grid.index(0, 3)] = labels::kRoad;
    grid.add("height")[grid.index(3, 0)] = 0.75f;
    grid.add("slope", 0.2f);
    frame.points.push_back(1.5f, -1.5f, 0.3f, 0.01f, 12);
    grid.binPoints(frame.points);
  }
  PluginContext pctx() const {
    PluginContext c;
    c.output_dir = dir.str();
    c.grid = test::outputTestGeometry();
    c.labels = &labels;
    return c;
  }
  RunInfo info() const {
    RunInfo r;
    r.output_dir = dir.str();
    r.labels = &labels;
    r.grid = test::outputTestGeometry();
    return r;
  }
  FrameContext ctx() {
    FrameContext c;
    c.frame = &frame;
    c.grid = &grid;
    c.labels = &labels;
    return c;
  }
  test::TempDir dir;
  LabelSet labels = LabelSet::defaults();
  Frame frame;
  TerrainGrid grid;
};

TEST_F(LcmPublishTest, DefaultsAreDocumentedOnes) {
  PluginRegistry reg({test::pluginDir()});
  auto p = reg.create("lcm_publish");
  std::map<std::string, std::string> d;
  for (const ParamSpec& s : declaredParams(*p)) d[s.name] = toYaml(s.default_value);
  EXPECT_NE(d["url"].find("udpm://239.255.76.67:7667?ttl=0"), std::string::npos) << d["url"];
  EXPECT_NE(d["channel"].find("TERRAMRF_GRID"), std::string::npos);
  EXPECT_EQ(d["publish_points"], "false");
  EXPECT_EQ(d["publish_pose"], "false");
  EXPECT_EQ(d["publish_truth"], "false");
  EXPECT_EQ(d["publish_samples"], "false");
  EXPECT_TRUE(d.count("layers"));
}

TEST_F(LcmPublishTest, PublishesOnMemqWithoutError) {
  auto out = test::makeOutput("lcm_publish", "{url: 'memq://', publish_points: true}", pctx());
  ASSERT_TRUE(out);
  out->begin(info());
  EXPECT_NO_THROW(out->write(ctx()));
  EXPECT_NO_THROW(out->write(ctx()));
  out->end(RunSummary{});
  // Nothing on disk.
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

TEST_F(LcmPublishTest, WhatIsPublishedDecodesToTheGrid) {
  const std::string log = dir.str() + "/run.lcmlog";
  auto out = test::makeOutput(
      "lcm_publish",
      "{url: 'file://" + log + "?mode=w', channel: GRIDS, layers: [height], publish_points: true}",
      pctx());
  ASSERT_TRUE(out);
  out->begin(info());
  out->write(ctx());
  out->end(RunSummary{});  // closes the log

  lcm::LogFile file(log, "r");
  ASSERT_TRUE(file.good());
  std::vector<std::pair<std::string, MessageBytes>> events;
  while (const lcm::LogEvent* e = file.readNextEvent()) {
    const auto* p = static_cast<const uint8_t*>(e->data);
    events.emplace_back(e->channel, MessageBytes(p, p + e->datalen));
  }
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].first, "GRIDS");
  EXPECT_EQ(events[1].first, "GRIDS_POINTS");

  const DecodedGrid d = decodeGrid(events[0].second, events[0].first);
  EXPECT_EQ(d.header.frame_id, "000005");
  EXPECT_DOUBLE_EQ(d.header.timestamp_s, 0.5);
  EXPECT_EQ(d.grid.labels(), grid.labels());
  EXPECT_EQ(d.grid.layerNames(), std::vector<std::string>{"height"});  // only the listed layer
  EXPECT_EQ(d.grid.layer("height")[grid.index(3, 0)], 0.75f);
  EXPECT_TRUE(std::isnan(d.grid.layer("height")[0]));
  EXPECT_EQ(d.point_counts[grid.index(3, 0)], 1u);

  const DecodedPointCloud pc = decodePointCloud(events[1].second.data(), events[1].second.size());
  ASSERT_EQ(pc.cloud.size(), 1u);
  EXPECT_EQ(pc.cloud.z[0], 0.3f);
  EXPECT_EQ(pc.cloud.ring[0], 12);
}

// How the run computed the layers sent goes out just before each grid (layer_origins_t on
// <channel>_ORIGINS), for the layers sent only; a run that knows no origins sends none.
TEST_F(LcmPublishTest, LayerOriginsPrecedeEachGridForTheLayersSent) {
  const std::map<std::string, std::string> origins = {
      {"height", "{stage: height_difference, cell_m: 0.5}"},
      {"slope", "{stage: slope, cell_m: 0.5}"},
      {"elsewhere", "{stage: other}"}};
  const auto events = [&](const std::string& extra, const std::map<std::string, std::string>* o) {
    const std::string log = dir.str() + "/o.lcmlog";
    PluginContext c = pctx();
    c.layer_origins = o;
    auto out = test::makeOutput("lcm_publish",
                                "{url: 'file://" + log + "?mode=w', channel: G" + extra + "}", c);
    EXPECT_TRUE(out);
    std::vector<std::pair<std::string, MessageBytes>> ev;
    if (!out) return ev;
    out->begin(info());
    out->write(ctx());
    out->write(ctx());
    out->end(RunSummary{});
    lcm::LogFile file(log, "r");
    while (const lcm::LogEvent* e = file.readNextEvent()) {
      const auto* p = static_cast<const uint8_t*>(e->data);
      ev.emplace_back(e->channel, MessageBytes(p, p + e->datalen));
    }
    return ev;
  };
  auto ev = events("", &origins);
  ASSERT_EQ(ev.size(), 4u);
  EXPECT_EQ(ev[0].first, "G_ORIGINS");
  EXPECT_EQ(ev[1].first, "G");
  EXPECT_EQ(ev[2].first, "G_ORIGINS");
  const DecodedLayerOrigins d = decodeLayerOrigins(ev[0].second);
  EXPECT_EQ(d.header.frame_id, "000005");
  EXPECT_EQ(d.origins, (std::map<std::string, std::string>{{"height", origins.at("height")},
                                                           {"slope", origins.at("slope")}}));
  ev = events(", layers: [height]", &origins);
  ASSERT_EQ(ev.size(), 4u);
  EXPECT_EQ(decodeLayerOrigins(ev[0].second).origins.size(), 1u);
  ev = events("", nullptr);
  ASSERT_EQ(ev.size(), 2u);
  EXPECT_EQ(ev[0].first, "G");
}

// With publish_pose and publish_truth the scan's pose, ground-truth pose and per-point classes
// go out too, before the points: a receiver takes the cloud as the scan's last message.
TEST_F(LcmPublishTest, PublishesPoseAndTruthBeforeThePoints) {
  frame.pose = Eigen::Isometry3d(Eigen::Translation3d(1, 2, 3));
  Eigen::Matrix<double, 6, 6> cov = Eigen::Matrix<double, 6, 6>::Identity() * 0.01;
  frame.pose_covariance = cov;
  frame.truth_pose = Eigen::Isometry3d(Eigen::Translation3d(1, 2.5, 3));
  frame.truth.label = {labels::kObstacle};
  frame.truth.raw = {50};
  const std::string log = dir.str() + "/run.lcmlog";
  auto out = test::makeOutput("lcm_publish",
                              "{url: 'file://" + log +
                                  "?mode=w', channel: G, publish_points: true, "
                                  "publish_pose: true, publish_truth: true, log_time: frame}",
                              pctx());
  ASSERT_TRUE(out);
  out->begin(info());
  out->write(ctx());
  Frame bare;  // no pose, no truth: only the grid and the points
  bare.id = "000006";
  bare.points = frame.points;
  FrameContext c = ctx();
  c.frame = &bare;
  out->write(c);
  out->end(RunSummary{});

  lcm::LogFile file(log, "r");
  ASSERT_TRUE(file.good());
  std::vector<std::pair<std::string, MessageBytes>> events;
  std::vector<int64_t> times;
  while (const lcm::LogEvent* e = file.readNextEvent()) {
    const auto* p = static_cast<const uint8_t*>(e->data);
    events.emplace_back(e->channel, MessageBytes(p, p + e->datalen));
    times.push_back(e->timestamp);
  }
  std::vector<std::string> channels;
  for (const auto& e : events) channels.push_back(e.first);
  EXPECT_EQ(channels, (std::vector<std::string>{"G", "G_POSE", "G_TRUTH_POSE", "G_LABELS",
                                                "G_POINTS", "G", "G_POINTS"}));
  ASSERT_EQ(events.size(), 7u);
  EXPECT_EQ(times[1], 500000);  // the scan's time (log_time: frame)

  const PoseMessage pose = decodePose(events[1].second.data(), events[1].second.size());
  EXPECT_EQ(pose.header.frame_id, "000005");
  EXPECT_TRUE(pose.pose.isApprox(*frame.pose));
  ASSERT_TRUE(pose.covariance);
  EXPECT_EQ(*pose.covariance, cov);
  const PoseMessage truth = decodePose(events[2].second.data(), events[2].second.size());
  EXPECT_TRUE(truth.pose.isApprox(*frame.truth_pose));
  EXPECT_EQ(truth.child_frame, "lidar");
  EXPECT_FALSE(truth.covariance);
  const DecodedPointLabels l =
      decodePointLabels(events[3].second.data(), events[3].second.size());
  EXPECT_EQ(l.header.frame_id, "000005");
  EXPECT_EQ(l.truth.label, frame.truth.label);
  EXPECT_EQ(l.truth.raw, frame.truth.raw);
  EXPECT_EQ(l.label_names, labels.names());
}

// publish_samples: the frame's IMU, GPS and odometry samples, each at its own time in a log.
TEST_F(LcmPublishTest, PublishesSamplesAtTheirOwnTimes) {
  ImuSample imu;
  imu.t_s = 0.42;
  imu.accel_m_s2 = Eigen::Vector3d(0, 0, 9.81);
  frame.imu = {imu};
  GpsSample gps;
  gps.t_s = 0.45;
  frame.gps = {gps};
  OdometrySample odo;
  odo.t_s = 0.48;
  odo.speed_m_s = 9;
  frame.odometry = {odo};
  const std::string log = dir.str() + "/run.lcmlog";
  auto out = test::makeOutput(
      "lcm_publish",
      "{url: 'file://" + log + "?mode=w', channel: G, publish_samples: true, log_time: frame}",
      pctx());
  ASSERT_TRUE(out);
  out->begin(info());
  out->write(ctx());
  out->end(RunSummary{});
  lcm::LogFile file(log, "r");
  std::vector<std::pair<std::string, int64_t>> events;
  MessageBytes imu_bytes;
  while (const lcm::LogEvent* e = file.readNextEvent()) {
    events.emplace_back(e->channel, e->timestamp);
    const auto* p = static_cast<const uint8_t*>(e->data);
    if (e->channel == "G_IMU") imu_bytes.assign(p, p + e->datalen);
  }
  EXPECT_EQ(events, (std::vector<std::pair<std::string, int64_t>>{
                        {"G", 500000}, {"G_IMU", 420000}, {"G_GPS", 450000},
                        {"G_ODOMETRY", 480000}}));
  EXPECT_EQ(decodeImu(imu_bytes.data(), imu_bytes.size()).accel_m_s2.z(), 9.81);
}

// publish_images: each camera's image and calibration; publish_grid: false records without a
// classification (reads nothing from the stages).
TEST_F(LcmPublishTest, PublishesImagesWithCalibrationsAndRecordsWithoutTheGrid) {
  auto img = std::make_shared<Image>();
  img->width = 2;
  img->height = 1;
  img->channels = 3;
  img->data = {1, 2, 3, 4, 5, 6};
  CameraImage cam;
  cam.model.name = "image_2";
  cam.model.width = 2;
  cam.model.height = 1;
  cam.model.P(0, 0) = cam.model.P(1, 1) = 1;
  cam.model.P(2, 2) = 1;
  cam.image = img;
  frame.cameras = {cam};
  const std::string log = dir.str() + "/run.lcmlog";
  auto out = test::makeOutput("lcm_publish",
                              "{url: 'file://" + log +
                                  "?mode=w', channel: G, publish_grid: false, publish_images: "
                                  "true, publish_points: true}",
                              pctx());
  ASSERT_TRUE(out);
  EXPECT_TRUE(out->reads().empty());
  out->begin(info());
  out->write(ctx());
  out->end(RunSummary{});
  lcm::LogFile file(log, "r");
  std::vector<std::string> channels;
  MessageBytes image, calibration;
  while (const lcm::LogEvent* e = file.readNextEvent()) {
    channels.push_back(e->channel);
    const auto* p = static_cast<const uint8_t*>(e->data);
    if (e->channel == "G_IMAGE") image.assign(p, p + e->datalen);
    if (e->channel == "G_CAMERA_INFO") calibration.assign(p, p + e->datalen);
  }
  EXPECT_EQ(channels, (std::vector<std::string>{"G_IMAGE", "G_CAMERA_INFO", "G_POINTS"}));
  const DecodedImage d = decodeImage(image.data(), image.size());
  EXPECT_EQ(d.camera, "image_2");
  EXPECT_EQ(d.image.data, img->data);
  EXPECT_EQ(decodeCameraInfo(calibration.data(), calibration.size()).model.width, 2);

  // A camera without its image: the frame fails here, not on the receiving side.
  frame.cameras[0].image.reset();
  auto again = test::makeOutput(
      "lcm_publish", "{url: 'file://" + log + "?mode=w', publish_grid: false, publish_images: true}",
      pctx());
  again->begin(info());
  try {
    again->write(ctx());
    ADD_FAILURE() << "a camera without an image was published";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("camera 'image_2' of frame 000005 has no image"),
              std::string::npos)
        << e.what();
  }
  again->end(RunSummary{});

  // Nothing to send, or layers of a grid not sent: refused.
  EXPECT_THROW(test::makeOutput("lcm_publish", "{url: 'memq://', publish_grid: false}", pctx()),
               std::exception);
  EXPECT_THROW(test::makeOutput("lcm_publish",
                                "{url: 'memq://', publish_grid: false, publish_points: true, "
                                "layers: [height]}",
                                pctx()),
               std::exception);
}

// LCM's own file provider returned 0 from lcm_publish when the write failed (and dropped the
// buffered bytes' fflush error at close): a full disk cut the log while every frame was "ok".
TEST_F(LcmPublishTest, LogWriteFailureFailsTheFrameNamingTheFile) {
  auto out = test::makeOutput("lcm_publish", "{url: 'file:///dev/full?mode=w'}", pctx());
  ASSERT_TRUE(out);
  out->begin(info());
  for (int i = 0; i < 2; ++i) {
    try {
      out->write(ctx());
      FAIL() << "frame logged to /dev/full reported ok";
    } catch (const std::exception& e) {
      EXPECT_NE(std::string(e.what()).find("LCM log '/dev/full': cannot write event 0 (channel "
                                           "'TERRAMRF_GRID', "),
                std::string::npos)
          << e.what();
      EXPECT_NE(std::string(e.what()).find(std::strerror(ENOSPC)), std::string::npos) << e.what();
    }
  }
  EXPECT_NO_THROW(out->end(RunSummary{}));
}

// The log's timestamps are the wall clock at the write [µs], as LCM's provider recorded them, and
// mode=a adds to a log instead of replacing it.
TEST_F(LcmPublishTest, LogTimestampsAndAppend) {
  const std::string log = dir.str() + "/run.lcmlog";
  const auto now = [] {
    return std::chrono::duration_cast<std::chrono::microseconds>(
               std::chrono::system_clock::now().time_since_epoch())
        .count();
  };
  const std::int64_t t0 = now();
  for (const char* mode : {"w", "a"}) {
    auto out = test::makeOutput(
        "lcm_publish", "{url: 'file://" + log + "?mode=" + mode + "', publish_points: true}",
        pctx());
    ASSERT_TRUE(out);
    out->begin(info());
    out->write(ctx());
    out->end(RunSummary{});
  }
  const std::int64_t t1 = now();
  lcm::LogFile file(log, "r");
  ASSERT_TRUE(file.good());
  std::vector<std::string> channels;
  while (const lcm::LogEvent* e = file.readNextEvent()) {
    channels.push_back(e->channel);
    EXPECT_GE(e->timestamp, t0);
    EXPECT_LE(e->timestamp, t1);
  }
  EXPECT_EQ(channels, (std::vector<std::string>{"TERRAMRF_GRID", "TERRAMRF_GRID_POINTS",
                                                "TERRAMRF_GRID", "TERRAMRF_GRID_POINTS"}));
}

// log_time: frame stamps each event with its frame's time, so a log made from a dataset replays
// at the recorded rate (10 Hz here) instead of the speed the run processed it; grid and points
// of one frame share the stamp. It only means something for a log: a live URL refuses it.
TEST_F(LcmPublishTest, LogTimeFrameStampsEventsWithTheFramesTime) {
  const std::string log = dir.str() + "/replay.lcmlog";
  auto out = test::makeOutput(
      "lcm_publish", "{url: 'file://" + log + "?mode=w', publish_points: true, log_time: frame}",
      pctx());
  ASSERT_TRUE(out);
  out->begin(info());
  for (int k = 0; k < 3; ++k) {
    frame.timestamp_s = 1234.5 + 0.1 * k;
    out->write(ctx());
  }
  out->end(RunSummary{});
  lcm::LogFile file(log, "r");
  ASSERT_TRUE(file.good());
  std::vector<std::int64_t> stamps;
  while (const lcm::LogEvent* e = file.readNextEvent()) stamps.push_back(e->timestamp);
  EXPECT_EQ(stamps, (std::vector<std::int64_t>{1234500000, 1234500000, 1234600000, 1234600000,
                                               1234700000, 1234700000}));

  try {
    test::makeOutput("lcm_publish", "{url: 'memq://', log_time: frame}", pctx());
    FAIL() << "log_time: frame accepted for a live URL";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("parameter 'log_time': 'frame' applies to a log being "
                                         "written"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(test::makeOutput("lcm_publish", "{log_time: recorded}", pctx()), std::exception);
}

TEST_F(LcmPublishTest, BadParamsAndMissingLayer) {
  try {
    test::makeOutput("lcm_publish", "{url: 'http://example'}", pctx());
    FAIL() << "non-LCM URL accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("http://example"), std::string::npos) << e.what();
  }
  EXPECT_THROW(test::makeOutput("lcm_publish", "{channel: ''}", pctx()), std::exception);
  // A log URL without a write mode is opened for reading by LCM: every publish used to fail.
  try {
    test::makeOutput("lcm_publish", "{url: 'file:///tmp/x.lcmlog'}", pctx());
    FAIL() << "a log URL that LCM opens for reading accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("parameter 'url': 'file:///tmp/x.lcmlog' opens the log "
                                         "for reading; to write one give ?mode=w"),
              std::string::npos)
        << e.what();
  }
  EXPECT_NO_THROW(test::makeOutput("lcm_publish", "{url: 'file:///tmp/x.lcmlog?mode=a'}", pctx()));
  // "mode=w" inside another option's text passed a substring check; LCM then opened the log
  // for reading ("Invalid value for mode: wx").
  try {
    test::makeOutput("lcm_publish", "{url: 'file:///tmp/x.lcmlog?mode=wx'}", pctx());
    FAIL() << "mode=wx accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("mode 'wx' is not a write mode"), std::string::npos)
        << e.what();
  }
  // Options LCM only reads when playing a log back are refused when writing.
  try {
    test::makeOutput("lcm_publish", "{url: 'file:///tmp/x.lcmlog?mode=w&speed=2'}", pctx());
    FAIL() << "a reading option accepted for a log being written";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("option 'speed' has no meaning for a log being written"),
              std::string::npos)
        << e.what();
  }

  auto out = test::makeOutput("lcm_publish", "{url: 'memq://', layers: [roughness]}", pctx());
  ASSERT_TRUE(out);
  out->begin(info());
  try {
    out->write(ctx());
    FAIL() << "missing layer accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("'roughness'"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace terramrf
