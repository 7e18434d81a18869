// The "lcm_log" source on logs written here with LcmLogWriter (lcm_publish's writer). The round
// trip through lcm_publish and the CLI is in tests/configs (LcmConfigsE2E).
#include <gtest/gtest.h>

#include <filesystem>
#include <limits>
#include <memory>

#include "terramrf/errors.hpp"
#include "terramrf/lcm/camera_codec.hpp"
#include "terramrf/lcm/grid_codec.hpp"
#include "terramrf/lcm/labels_codec.hpp"
#include "terramrf/lcm/log_writer.hpp"
#include "terramrf/lcm/origins_codec.hpp"
#include "terramrf/lcm/pose_codec.hpp"
#include "terramrf/lcm/sensor_codec.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

PointCloud threePoints() {
  PointCloud c;
  c.push_back(1, 2, 0.5f, 0.1f, 3);
  c.push_back(-4, 1, 0.2f, 0.2f, 4);
  c.push_back(6, -3, 1.5f, 0.3f, 5);
  return c;
}

class LcmLogSourceTest : public ::testing::Test {
 protected:
  LcmLogSourceTest() : reg_({test::pluginDir()}) { ctx_.labels = &labels_; }
  std::string log() const { return dir_.str() + "/run.lcm"; }
  std::unique_ptr<Source> make(const std::string& extra = "") {
    auto p = reg_.create("lcm_log");
    setParams(*p, "{path: " + log() + (extra.empty() ? "" : ", " + extra) + "}", ctx_);
    return std::unique_ptr<Source>(dynamic_cast<Source*>(p.release()));
  }
  void put(LcmLogWriter& w, const std::string& channel, const MessageBytes& b) {
    w.write(channel, b.data(), b.size(), 0);
  }
  MessageBytes cloud(const std::string& id, double t_s) {
    return encodePointCloud(threePoints(), {id, "lidar", t_s});
  }
  MessageBytes labels(const std::string& id, std::size_t n = 3) {
    PointLabels t;
    t.label.assign(n, labels::kRoad);
    t.label[0] = labels::kObstacle;
    t.raw.assign(n, 40);
    return encodePointLabels(t, labels_, {id, "lidar", 0});
  }
  MessageBytes pose(const std::string& id, double x) {
    PoseMessage p;
    p.header = {id, "world", 0};
    p.pose = Eigen::Translation3d(x, 0, 0);
    return encodePose(p);
  }
  /// Scans "a" and "b" with labels, poses, truth poses and IMU samples on the channels
  /// lcm_publish uses.
  void writeTwoScans() {
    LcmLogWriter w(log(), false);
    ImuSample s;
    s.t_s = 0.05;
    put(w, "IMU", encodeImu(s));
    put(w, "G_POSE", pose("a", 1));
    put(w, "G_TRUTH_POSE", pose("a", 1.5));
    put(w, "G_LABELS", labels("a"));
    put(w, "G_POINTS", cloud("a", 0.1));
    s.t_s = 0.15;
    put(w, "IMU", encodeImu(s));
    put(w, "G_POSE", pose("b", 2));
    put(w, "G_POINTS", cloud("b", 0.2));
    w.close();
  }
  /// Each {params, expected}: the source with points_channel G_POINTS and `params` is refused,
  /// its message holding `expected`.
  void expectRefused(const std::vector<std::pair<std::string, std::string>>& cases) {
    for (const auto& [params, expected] : cases) {
      try {
        make("points_channel: G_POINTS, " + params);
        ADD_FAILURE() << params << " accepted";
      } catch (const std::exception& e) {
        EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
      }
    }
  }
  const std::string kAll =
      "points_channel: G_POINTS, labels_channel: G_LABELS, pose_channel: G_POSE, "
      "truth_pose_channel: G_TRUTH_POSE, imu_channel: IMU";

  test::TempDir dir_;
  PluginRegistry reg_;
  LabelSet labels_ = LabelSet::defaults();
  PluginContext ctx_;
};

TEST_F(LcmLogSourceTest, ReadsScansWithTheirTruthPosesAndSamples) {
  writeTwoScans();
  auto src = make(kAll);
  EXPECT_FALSE(src->streaming());
  EXPECT_TRUE(src->concurrentReads());
  ASSERT_EQ(src->size(), 2u);
  EXPECT_EQ(src->frameId(0), "a");
  EXPECT_EQ(src->frameId(1), "b");
  EXPECT_EQ(src->writes(), std::vector<std::string>{artefacts::kPose});

  const Frame a = src->read(0);
  EXPECT_EQ(a.id, "a");
  EXPECT_EQ(a.source_path, log());
  EXPECT_DOUBLE_EQ(a.timestamp_s, 0.1);
  ASSERT_EQ(a.points.size(), 3u);
  EXPECT_EQ(a.points.x, threePoints().x);
  EXPECT_EQ(a.points.ring, threePoints().ring);
  ASSERT_EQ(a.truth.label.size(), 3u);
  EXPECT_EQ(a.truth.label[0], labels::kObstacle);
  EXPECT_EQ(a.truth.raw[2], 40u);
  ASSERT_TRUE(a.pose && a.truth_pose);
  EXPECT_DOUBLE_EQ(a.pose->translation().x(), 1.0);
  EXPECT_DOUBLE_EQ(a.truth_pose->translation().x(), 1.5);
  ASSERT_EQ(a.imu.size(), 1u);
  EXPECT_DOUBLE_EQ(a.imu[0].t_s, 0.05);

  const Frame b = src->read(1);  // no labels, no truth pose: not scored, not an error
  EXPECT_TRUE(b.truth.empty());
  EXPECT_FALSE(b.truth_pose);
  ASSERT_TRUE(b.pose);
  EXPECT_DOUBLE_EQ(b.pose->translation().x(), 2.0);
  ASSERT_EQ(b.imu.size(), 1u);
  EXPECT_DOUBLE_EQ(b.imu[0].t_s, 0.15);
}

// A grid made by another process (its feature stages): the declared layers, exactly as sent,
// become Frame::grid, its labels only when '@labels' is asked for (mapped by class name into the
// run's ids). A grid without a declared layer fails its scan naming the event; a scan without
// a grid fails naming the channel; the other scans read.
TEST_F(LcmLogSourceTest, GridsMadeElsewhereComeWithTheirScans) {
  GridGeometry geom;  // the run's (ctx_.grid), 80 x 80 cells of 0.5 m
  auto grid = [&](const std::string& id, float value, bool with_roughness) {
    TerrainGrid g(geom);
    g.add("height_diff", value).at(0) = 0.123456789f;
    if (with_roughness) g.add("roughness", 2 * value);
    g.add("other", 7);
    g.labels()[5] = labels::kObstacle;
    // The sender orders its classes otherwise: mapped by name, not id.
    LabelSet sender({{"unknown", {0, 0, 0}},
                     {"obstacle", {1, 1, 1}},
                     {"road", {2, 2, 2}},
                     {"rough", {3, 3, 3}}});
    g.labels()[5] = 1;
    return encodeGrid(g, sender, {id, "lidar", 0});
  };
  {
    LcmLogWriter w(log(), false);
    put(w, "G", grid("a", 0.5f, true));
    put(w, "G_POINTS", cloud("a", 0.1));
    put(w, "G_POINTS", cloud("b", 0.2));  // no grid
    put(w, "G", grid("c", 1.5f, false));  // no roughness
    put(w, "G_POINTS", cloud("c", 0.3));
    w.close();
  }
  ctx_.grid = geom;
  auto src = make(
      "points_channel: G_POINTS, grid_channel: G, grid_layers: [height_diff, "
      "roughness, '@labels']");
  EXPECT_EQ(src->writes(), (std::vector<std::string>{"height_diff", "roughness", "@labels"}));
  const Frame a = src->read(0);
  ASSERT_TRUE(a.grid);
  EXPECT_EQ(a.grid->layerNames(), (std::vector<std::string>{"height_diff", "roughness"}));
  EXPECT_EQ(a.grid->layer("height_diff")[0], 0.123456789f);
  EXPECT_EQ(a.grid->layer("height_diff")[1], 0.5f);
  EXPECT_EQ(a.grid->layer("roughness")[9], 1.0f);
  EXPECT_EQ(a.grid->labels()[5], labels::kObstacle);
  EXPECT_EQ(a.grid->labels()[6], labels::kUnknown);
  try {
    src->read(1);
    FAIL() << "a scan without its grid was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no terrain_grid_t on channel G for scan 'b'; a grid "
                                         "channel is read, so every scan needs its grid"),
              std::string::npos)
        << e.what();
  }
  try {
    src->read(2);
    FAIL() << "a grid without a declared layer was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(" (G): terrain_grid_t of scan 'c' has no layer "
                                         "'roughness' (grid_layers lists it); its layers: "
                                         "height_diff, other, and labels"),
              std::string::npos)
        << e.what();
  }
  // A grid in another frame than the scan's is refused: its cells would be other cells.
  {
    LcmLogWriter w(log(), false);
    TerrainGrid g(geom);
    g.add("height_diff", 1);
    put(w, "G", encodeGrid(g, labels_, {"m", "world", 0}));
    put(w, "G_POINTS", cloud("m", 0.1));
    w.close();
  }
  try {
    make("points_channel: G_POINTS, grid_channel: G, grid_layers: [height_diff]")->read(0);
    FAIL() << "a grid in the world frame was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("grid of scan 'm' in frame 'world'; expected \"lidar\""),
              std::string::npos)
        << e.what();
  }
  {
    LcmLogWriter w(log(), false);
    put(w, "G", grid("a", 0.5f, true));
    put(w, "G_POINTS", cloud("a", 0.1));
    w.close();
  }
  // Without '@labels' the grid's labels stay behind.
  auto layers_only = make("points_channel: G_POINTS, grid_channel: G, grid_layers: [height_diff]");
  EXPECT_EQ(layers_only->read(0).grid->labels()[5], labels::kUnknown);
  // A grid channel without layers, and layers without a channel, are refused.
  const std::vector<std::pair<std::string, std::string>> refused = {
      {"grid_channel: G", "parameter 'grid_layers': is empty, but grid_channel is G"},
      {"grid_layers: [height_diff]", "parameter 'grid_channel': is empty, but grid_layers lists 1"},
      {"grid_channel: G, grid_layers: ['@energy']",
       "parameter 'grid_layers': lists '@energy'; expected layer names, or '@labels'"}};
  expectRefused(refused);
}

// The feature node publishes how its layers were computed (layer_origins_t on <channel>_ORIGINS);
// the source hands those of the layers it takes to the pipeline (Source::layerOrigins), so
// potts_gaussian checks its model against received layers. Every scan must bring its own, and
// the same: a scan whose taken layers were computed otherwise, whose origins cannot be decoded
// or that has none fails alone.
TEST_F(LcmLogSourceTest, GridOriginsComeWithTheLayersAndScansDescribedOtherwiseFailAlone) {
  GridGeometry geom;
  ctx_.grid = geom;
  auto grid = [&](const std::string& id) {
    TerrainGrid g(geom);
    g.add("height_diff", 1);
    g.add("roughness", 2);
    return encodeGrid(g, labels_, {id, "lidar", 0});
  };
  const std::map<std::string, std::string> first = {{"height_diff", "{stage: height_difference}"},
                                                    {"roughness", "{stage: roughness, window: 2}"},
                                                    {"other", "{stage: other}"}};
  std::map<std::string, std::string> changed = first;
  changed["roughness"] = "{stage: roughness, window: 3}";
  changed.erase("other");
  {
    LcmLogWriter w(log(), false);
    put(w, "G_ORIGINS", encodeLayerOrigins(first, {"a", "lidar", 0}));
    put(w, "G", grid("a"));
    put(w, "G_POINTS", cloud("a", 0.1));
    put(w, "G_ORIGINS", encodeLayerOrigins(changed, {"b", "lidar", 0}));
    put(w, "G", grid("b"));
    put(w, "G_POINTS", cloud("b", 0.2));
    put(w, "G", grid("c"));  // no origins
    put(w, "G_POINTS", cloud("c", 0.3));
    MessageBytes cut = encodeLayerOrigins(first, {"d", "lidar", 0});
    cut.resize(cut.size() - 4);
    put(w, "G_ORIGINS", cut);
    put(w, "G", grid("d"));
    put(w, "G_POINTS", cloud("d", 0.4));
    w.close();
  }
  auto src =
      make("points_channel: G_POINTS, grid_channel: G, grid_layers: [height_diff, roughness]");
  EXPECT_EQ(src->layerOrigins(),
            (std::map<std::string, std::string>{{"height_diff", "{stage: height_difference}"},
                                                {"roughness", "{stage: roughness, window: 2}"}}));
  EXPECT_NO_THROW(src->read(0));
  const auto expectFails = [&](Source& s, std::size_t i, const std::string& what) {
    try {
      s.read(i);
      ADD_FAILURE() << "scan " << i << " was read";
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(log() + ": ", 0), 0u) << e.what();
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  expectFails(*src, 1,
              "event 3 (G_ORIGINS): layer 'roughness' of scan 'b' was computed otherwise than "
              "the log's first scan's (event 0 (G_ORIGINS)): the sender's stages changed during "
              "the recording");
  expectFails(*src, 2,
              "(G_POINTS): no layer_origins_t on channel G_ORIGINS for scan 'c'; the log carries "
              "them for other scans, so every scan needs its own");
  expectFails(*src, 3, "event 8 (G_ORIGINS): ");
  // Scan b differs only in a layer not taken: it is read.
  auto hd = make("points_channel: G_POINTS, grid_channel: G, grid_layers: [height_diff]");
  EXPECT_EQ(hd->layerOrigins().size(), 1u);
  EXPECT_NO_THROW(hd->read(1));
  // Named, the channel must be in the log; and it describes a grid channel's layers.
  const std::vector<std::pair<std::string, std::string>> refused = {
      {"grid_channel: G, grid_layers: [height_diff], grid_origins_channel: NOPE",
       "parameter 'grid_origins_channel': '" + log() + "' has no event on channel NOPE"},
      {"grid_origins_channel: G_ORIGINS",
       "parameter 'grid_origins_channel': is G_ORIGINS, but grid_channel is empty"}};
  expectRefused(refused);
  // A log without origins (another sender): the layers' origins are unknown, nothing fails.
  {
    LcmLogWriter w(log(), false);
    put(w, "G", grid("a"));
    put(w, "G_POINTS", cloud("a", 0.1));
    w.close();
  }
  auto unknown = make("points_channel: G_POINTS, grid_channel: G, grid_layers: [height_diff]");
  EXPECT_TRUE(unknown->layerOrigins().empty());
  EXPECT_NO_THROW(unknown->read(0));
}

TEST_F(LcmLogSourceTest, WithoutAPoseChannelItWritesNoPose) {
  writeTwoScans();
  auto src = make("points_channel: G_POINTS");
  EXPECT_TRUE(src->writes().empty());
  const Frame a = src->read(0);
  EXPECT_FALSE(a.pose);
  EXPECT_TRUE(a.truth.empty());
}

// A channel the log does not carry is a typo or the wrong log: refused, naming the parameter's
// channel and listing the log's channels.
TEST_F(LcmLogSourceTest, ChannelTheLogLacksIsRefusedListingItsChannels) {
  writeTwoScans();
  try {
    make("points_channel: G_POINTS, pose_channel: G_POSES");
    FAIL() << "expected an error";
  } catch (const std::exception& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("pose_channel"), std::string::npos) << w;
    EXPECT_NE(w.find("no event on channel G_POSES"), std::string::npos) << w;
    EXPECT_NE(w.find("G_POSE (2)"), std::string::npos) << w;
    EXPECT_NE(w.find(log()), std::string::npos) << w;
  }
  try {
    make();  // default points channel TERRAMRF_GRID_POINTS
    FAIL() << "expected an error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("TERRAMRF_GRID_POINTS"), std::string::npos) << e.what();
  }
}

TEST_F(LcmLogSourceTest, PoseAndTruthOnOneChannelAreRefused) {
  writeTwoScans();
  EXPECT_THROW(make("points_channel: G_POINTS, pose_channel: G_POSE, truth_pose_channel: G_POSE"),
               std::exception);
}

// With a pose channel every scan needs its pose: one without fails alone, named.
TEST_F(LcmLogSourceTest, ScanWithoutItsPoseFailsAlone) {
  {
    LcmLogWriter w(log(), false);
    put(w, "G_POSE", pose("a", 1));
    put(w, "G_POINTS", cloud("a", 0.1));
    put(w, "G_POINTS", cloud("b", 0.2));
    w.close();
  }
  auto src = make("points_channel: G_POINTS, pose_channel: G_POSE");
  EXPECT_NO_THROW(src->read(0));
  try {
    src->read(1);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string w = e.what();
    EXPECT_EQ(e.file(), log() + " event 2 (G_POINTS)");
    EXPECT_NE(w.find("event 2 (G_POINTS): no pose_t on channel G_POSE for scan 'b'"),
              std::string::npos)
        << w;
  }
}

// Damaged or mismatched messages fail their scan with the event and channel named; the other
// scans read.
TEST_F(LcmLogSourceTest, DamagedMessagesFailTheirScanNamingTheEvent) {
  {
    LcmLogWriter w(log(), false);
    put(w, "G_POINTS", cloud("a", 0.1));
    put(w, "G_LABELS", labels("b", 2));  // two labels for three points
    put(w, "G_POINTS", cloud("b", 0.2));
    ImuSample s;
    put(w, "G_POINTS", encodeImu(s));  // not a point cloud
    MessageBytes cut = cloud("d", 0.4);
    cut.resize(cut.size() - 5);
    put(w, "G_POINTS", cut);
    w.close();
  }
  auto src = make("points_channel: G_POINTS, labels_channel: G_LABELS");
  ASSERT_EQ(src->size(), 4u);
  EXPECT_NO_THROW(src->read(0));
  const auto refused = [&](std::size_t i, const std::string& expect) {
    try {
      src->read(i);
      ADD_FAILURE() << "scan " << i << " read; expected: " << expect;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(expect), std::string::npos) << e.what();
    }
  };
  refused(1, log() + " event 1 (G_LABELS): point_labels_t has 2 labels for the 3 points");
  EXPECT_EQ(src->frameId(2), "event3");
  refused(2, log() + " event 3 (G_POINTS)");
  EXPECT_EQ(src->frameId(3), "d");
  refused(3, log() + " event 4 (G_POINTS)");
}

// As every reader: NaN/inf points and no-returns at the origin are dropped and counted, their
// rings, times and labels with them.
TEST_F(LcmLogSourceTest, DropsNonFinitePointsAndNoReturnsWithTheirLabels) {
  PointCloud c = threePoints();
  c.push_back(std::numeric_limits<float>::quiet_NaN(), 0, 0, 0, 7);
  c.push_back(0, 0, 0, 0.4f, 8);
  c.push_back(2, 2, 2, std::numeric_limits<float>::infinity(), 9);
  c.push_back(3, 3, 3, 0.5f, 10);
  c.time_s = {0, 0.01f, 0.02f, 0.03f, 0.04f, 0.05f, 0.06f};
  PointLabels t;
  t.label = {1, 2, 3, 1, 2, 3, 3};
  t.raw = {10, 20, 30, 40, 50, 60, 70};
  {
    LcmLogWriter w(log(), false);
    put(w, "L", encodePointLabels(t, labels_, {"a", "lidar", 0}));
    put(w, "P", encodePointCloud(c, {"a", "lidar", 0.1}));
    w.close();
  }
  const Frame f = make("points_channel: P, labels_channel: L")->read(0);
  EXPECT_EQ(f.dropped_nonfinite_points, 2u);
  EXPECT_EQ(f.dropped_no_return_points, 1u);
  ASSERT_EQ(f.points.size(), 4u);
  EXPECT_EQ(f.points.ring, (std::vector<uint16_t>{3, 4, 5, 10}));
  EXPECT_EQ(f.points.time_s, (std::vector<float>{0, 0.01f, 0.02f, 0.06f}));
  EXPECT_EQ(f.truth.label, (std::vector<LabelId>{1, 2, 3, 3}));
  EXPECT_EQ(f.truth.raw, (std::vector<uint32_t>{10, 20, 30, 70}));

  const Frame kept = make("points_channel: P, labels_channel: L, drop_no_return: false")->read(0);
  EXPECT_EQ(kept.points.size(), 5u);
  EXPECT_EQ(kept.dropped_no_return_points, 0u);
}

TEST_F(LcmLogSourceTest, ScanWithTwoLabelMessagesFailsAlone) {
  {
    LcmLogWriter w(log(), false);
    put(w, "G_LABELS", labels("a"));
    put(w, "G_LABELS", labels("a"));
    put(w, "G_POINTS", cloud("a", 0.1));
    put(w, "G_LABELS", labels("b"));
    put(w, "G_POINTS", cloud("b", 0.2));
    w.close();
  }
  auto src = make("points_channel: G_POINTS, labels_channel: G_LABELS");
  ASSERT_EQ(src->size(), 2u);
  try {
    src->read(0);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), log());
    EXPECT_NE(std::string(e.what()).find("both carry point_labels_t for scan 'a'"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(src->read(1).truth.label.size(), 3u);
}

TEST_F(LcmLogSourceTest, CloudOutsideTheLidarFrameIsRefused) {
  {
    LcmLogWriter w(log(), false);
    const MessageBytes c = encodePointCloud(threePoints(), {"a", "world", 0.1});
    put(w, "G_POINTS", c);
    w.close();
  }
  try {
    make("points_channel: G_POINTS")->read(0);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("in frame 'world'; expected \"lidar\""),
              std::string::npos)
        << e.what();
  }
}

// A log whose only event was cut (a writer killed mid-write) has no channel at all: said so,
// with the bytes that belong to no event, rather than "empty".
TEST_F(LcmLogSourceTest, LogOfOneCutEventSaysSo) {
  {
    LcmLogWriter w(log(), false);
    put(w, "G_POINTS", cloud("a", 0.1));
    w.close();
  }
  const auto size = std::filesystem::file_size(log());
  std::filesystem::resize_file(log(), size - 10);
  try {
    make("points_channel: G_POINTS");
    FAIL() << "expected an error";
  } catch (const std::exception& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("no whole event in the log"), std::string::npos) << w;
    EXPECT_NE(w.find(std::to_string(size - 10) + " byte(s) belong to no whole event"),
              std::string::npos)
        << w;
  }
}

// Cameras: each scan's image and calibration, matched by scan and camera name; a missing one,
// two of one camera, or an image whose size is not its calibration's fail that scan, named.
TEST_F(LcmLogSourceTest, CamerasComeWithTheirCalibrationsAndBadOnesFailTheirScan) {
  Image img;
  img.width = 4;
  img.height = 2;
  img.channels = 3;
  img.data.assign(24, 9);
  CameraModel m;
  m.name = "cam";
  m.width = 4;
  m.height = 2;
  m.P(0, 0) = m.P(1, 1) = 2;
  m.P(2, 2) = 1;
  m.calibration = "rig.yaml";
  CameraModel wrong = m;
  wrong.width = 8;
  {
    LcmLogWriter w(log(), false);
    const auto scan = [&](const std::string& id, int images, const CameraModel& cal) {
      for (int k = 0; k < images; ++k) put(w, "IMG", encodeImage(img, "cam", {id, "lidar", 0}));
      put(w, "CAL", encodeCameraInfo(cal, {id, "lidar", 0}));
      put(w, "G_POINTS", cloud(id, 0.1));
    };
    scan("ok", 1, m);
    scan("none", 0, m);
    scan("two", 2, m);
    scan("size", 1, wrong);
    w.close();
  }
  auto src = make("points_channel: G_POINTS, images_channel: IMG, camera_info_channel: CAL, "
                  "cameras: [cam]");
  EXPECT_EQ(src->cameraNames(), std::vector<std::string>{"cam"});
  const Frame f = src->read(0);
  ASSERT_EQ(f.cameras.size(), 1u);
  EXPECT_EQ(f.cameras[0].model.name, "cam");
  EXPECT_EQ(f.cameras[0].model.P, m.P);
  EXPECT_EQ(f.cameras[0].image->data, img.data);
  EXPECT_NE(f.cameras[0].source_path.find("(IMG)"), std::string::npos) << f.cameras[0].source_path;
  const auto refused = [&](std::size_t i, const std::string& expect) {
    try {
      src->read(i);
      ADD_FAILURE() << "scan " << i << " read; expected: " << expect;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(expect), std::string::npos) << e.what();
    }
  };
  refused(1, "scan 'none' has no image_t on channel IMG for camera 'cam'");
  refused(2, "a second image_t of camera 'cam' for scan 'two'");
  refused(3, "image of camera 'cam' is 4 x 2 px, its calibration (" + log() +
                 " event 10 (CAL), from rig.yaml) is for 8 x 2 px");
  // Without cameras listed the images are not read.
  EXPECT_TRUE(make("points_channel: G_POINTS")->read(0).cameras.empty());
  // Cameras without the channels that carry them, or image channels without cameras: refused
  // at the config.
  EXPECT_THROW(make("points_channel: G_POINTS, cameras: [cam]"), std::exception);
  try {
    make("points_channel: G_POINTS, images_channel: IMG");
    ADD_FAILURE() << "images_channel without cameras accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("cameras lists none"), std::string::npos) << e.what();
  }
}

// Per-pixel truth images come with their camera; one of another size is refused.
TEST_F(LcmLogSourceTest, TruthImagesComeWithTheirCamera) {
  Image img;
  img.width = 4;
  img.height = 2;
  img.channels = 3;
  img.data.assign(24, 9);
  Image truth;
  truth.width = 4;
  truth.height = 2;
  truth.channels = 1;
  truth.data = {0, 1, 1, 2, 3, 3, 1, 0};
  Image bad = truth;
  bad.width = 2;
  bad.data.resize(4);
  CameraModel m;
  m.name = "cam";
  m.width = 4;
  m.height = 2;
  m.P(0, 0) = m.P(1, 1) = 2;
  m.P(2, 2) = 1;
  {
    LcmLogWriter w(log(), false);
    for (const auto& [id, t] : {std::pair<std::string, const Image*>{"a", &truth}, {"b", &bad}}) {
      put(w, "IMG", encodeImage(img, "cam", {id, "lidar", 0}));
      put(w, "CAL", encodeCameraInfo(m, {id, "lidar", 0}));
      put(w, "TRUTH", encodeImage(*t, "cam", {id, "lidar", 0}));
      put(w, "G_POINTS", cloud(id, 0.1));
    }
    w.close();
  }
  auto src = make("points_channel: G_POINTS, images_channel: IMG, camera_info_channel: CAL, "
                  "image_truth_channel: TRUTH, cameras: [cam]");
  const Frame f = src->read(0);
  ASSERT_EQ(f.cameras.size(), 1u);
  ASSERT_TRUE(f.cameras[0].truth);
  EXPECT_EQ(f.cameras[0].truth->data, truth.data);
  try {
    src->read(1);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("truth image of camera 'cam' is 2 x 2 x 1"),
              std::string::npos)
        << e.what();
  }
}

TEST_F(LcmLogSourceTest, MissingLogIsRefusedNamingIt) {
  try {
    make("points_channel: G_POINTS");
    FAIL() << "expected an error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find(log()), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace terramrf
