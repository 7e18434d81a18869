// The "lcm_subscribe" source, in-process over memq:// (openLcm shares one instance per memq URL,
// so a GridPublisher of the test meets the source's subscriber). A publisher thread sends scans
// until the test has what it needs: a subscriber only receives what comes after it subscribed.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <future>
#include <sstream>
#include <thread>

#include "terramrf/config.hpp"
#include "terramrf/errors.hpp"
#include "terramrf/lcm/camera_codec.hpp"
#include "terramrf/lcm/grid_publisher.hpp"
#include "terramrf/lcm/origins_codec.hpp"
#include "terramrf/lcm/pose_codec.hpp"
#include "terramrf/lcm/sensor_codec.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/pipeline.hpp"
#include "terramrf/registry.hpp"
#include "terramrf/terrain_grid.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

/// A flat patch of ground 4 m ahead (enough for the stages to classify something).
PointCloud patch() {
  PointCloud c;
  for (int i = 0; i < 20; ++i)
    for (int j = 0; j < 20; ++j) c.push_back(3.0f + 0.1f * i, -1.0f + 0.1f * j, -1.7f, 0.2f, 40);
  return c;
}

/// A 4 × 2 camera looking along x, and its image.
CameraModel camModel() {
  CameraModel m;
  m.name = "cam";
  m.width = 4;
  m.height = 2;
  m.P << 2, 0, 2, 0, 0, 2, 1, 0, 0, 0, 1, 0;
  return m;
}
Image camImage(int k) {
  Image img;
  img.width = 4;
  img.height = 2;
  img.channels = 3;
  img.data.assign(24, static_cast<std::uint8_t>(k));
  return img;
}

/// Publishes scan s<k> (pose and camera first, then the points) every 20 ms on `url` until
/// stopped.
class Publisher {
 public:
  Publisher(const std::string& url, bool with_pose, bool with_camera = false,
            bool with_grid = false, bool odd_scans_without_origins = false)
      : pub_(url, "G") {
    thread_ = std::thread([this, with_pose, with_camera, with_grid, odd_scans_without_origins] {
      for (int k = 0; !stop_; ++k) {
        MessageHeader h{"s" + std::to_string(k), "lidar", 0.1 * k};
        if (with_grid) {  // a feature node's grid: height_diff = k in every cell
          TerrainGrid g{GridGeometry{}};
          g.add("height_diff", static_cast<float>(k));
          // How it was computed, before it, as lcm_publish sends it.
          if (!odd_scans_without_origins || k % 2 == 0)
            pub_.publishForScan("G_ORIGINS",
                                encodeLayerOrigins({{"height_diff", "{stage: height_difference}"},
                                                    {"other", "{stage: other}"}},
                                                   h),
                                h);
          pub_.publish(g, LabelSet::defaults(), h);
        }
        if (with_pose) {
          PoseMessage p;
          p.header = {h.frame_id, "world", h.timestamp_s};
          p.pose = Eigen::Translation3d(k, 0, 0);
          pub_.publishForScan("G_POSE", encodePose(p), h);
        }
        if (with_camera) {
          pub_.publishForScan("G_IMAGE", encodeImage(camImage(k), "cam", h), h);
          pub_.publishForScan("G_IMAGE", encodeImage(camImage(k), "other", h), h);
          pub_.publishForScan("G_CAMERA_INFO", encodeCameraInfo(camModel(), h), h);
        }
        pub_.publishPoints(patch(), h);
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
    });
  }
  ~Publisher() { stop(); }
  void stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }

 private:
  GridPublisher pub_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

class LcmSubscribeTest : public ::testing::Test {
 protected:
  LcmSubscribeTest() : reg_({test::pluginDir()}) { ctx_.labels = &labels_; }
  std::unique_ptr<Source> make(const std::string& params) {
    auto p = reg_.create("lcm_subscribe");
    setParams(*p, params, ctx_);
    return std::unique_ptr<Source>(dynamic_cast<Source*>(p.release()));
  }
  /// A memq URL of this test alone: instances are shared per URL within the process.
  std::string url() const {
    return std::string("memq://") + ::testing::UnitTest::GetInstance()->current_test_info()->name();
  }
  PluginRegistry reg_;
  LabelSet labels_ = LabelSet::defaults();
  PluginContext ctx_;
};

TEST_F(LcmSubscribeTest, ReceivesScansWithTheirPosesInOrder) {
  auto src = make("{url: '" + url() + "', points_channel: G_POINTS, pose_channel: G_POSE, "
                  "idle_timeout_s: 5, wait_s: 0.05}");
  EXPECT_TRUE(src->streaming());
  EXPECT_EQ(src->writes(), std::vector<std::string>{artefacts::kPose});
  // The first scan may be cut by the subscription (its pose sent before the source subscribed,
  // its points after): that one fails for want of its pose, as it would in a run; the next is
  // whole.
  auto first = std::async(std::launch::async, [&] {
    try {
      return src->next();
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("no pose_t on channel G_POSE"), std::string::npos)
          << e.what();
      return src->next();
    }
  });
  Publisher pub(url(), true);
  ASSERT_EQ(first.wait_for(std::chrono::seconds(20)), std::future_status::ready);
  const std::optional<Frame> a = first.get();
  ASSERT_TRUE(a);
  const std::optional<Frame> b = src->next();
  ASSERT_TRUE(b);
  pub.stop();
  EXPECT_EQ(a->points.size(), 400u);
  EXPECT_EQ(a->source_path, url());
  ASSERT_TRUE(a->pose && b->pose);
  // Consecutive scans, each with its own pose (the publisher puts scan k at x = k).
  const int ka = std::stoi(a->id.substr(1)), kb = std::stoi(b->id.substr(1));
  EXPECT_EQ(kb, ka + 1);
  EXPECT_DOUBLE_EQ(a->pose->translation().x(), ka);
  EXPECT_DOUBLE_EQ(b->pose->translation().x(), kb);
  EXPECT_DOUBLE_EQ(b->timestamp_s, 0.1 * kb);
}

// Cameras come live too: each scan with its listed camera's image and calibration (another
// camera's image is dropped, counted).
TEST_F(LcmSubscribeTest, ReceivesTheListedCamerasWithTheirCalibrations) {
  auto src = make("{url: '" + url() + "', points_channel: G_POINTS, images_channel: G_IMAGE, "
                  "camera_info_channel: G_CAMERA_INFO, cameras: [cam], idle_timeout_s: 5, "
                  "wait_s: 0.05}");
  EXPECT_EQ(src->cameraNames(), std::vector<std::string>{"cam"});
  // The first scan may be cut by the subscription (its image before, its points after).
  auto first = std::async(std::launch::async, [&] {
    try {
      return src->next();
    } catch (const InputError&) {
      return src->next();
    }
  });
  Publisher pub(url(), false, true);
  ASSERT_EQ(first.wait_for(std::chrono::seconds(20)), std::future_status::ready);
  const std::optional<Frame> f = first.get();
  pub.stop();
  ASSERT_TRUE(f);
  ASSERT_EQ(f->cameras.size(), 1u);
  EXPECT_EQ(f->cameras[0].model.P, camModel().P);
  const int k = std::stoi(f->id.substr(1));
  EXPECT_EQ(f->cameras[0].image->data, camImage(k).data);
}

// A classifier node: each scan comes with the grid a feature node published for it (on the grid
// publisher's own channel, before the points), its declared layers as sent.
TEST_F(LcmSubscribeTest, ReceivesEachScansGridFromAFeatureNode) {
  ctx_.grid = GridGeometry{};
  auto src = make("{url: '" + url() +
                  "', points_channel: G_POINTS, grid_channel: G, "
                  "grid_layers: [height_diff], idle_timeout_s: 5, wait_s: 0.05}");
  EXPECT_EQ(src->writes(), std::vector<std::string>{"height_diff"});
  auto first = std::async(std::launch::async, [&] {
    try {
      return src->next();
    } catch (const InputError& e) {  // the first scan's grid may precede the subscription
      EXPECT_NE(std::string(e.what()).find("no terrain_grid_t on channel G"), std::string::npos)
          << e.what();
      return src->next();
    }
  });
  Publisher pub(url(), false, false, true);
  ASSERT_EQ(first.wait_for(std::chrono::seconds(20)), std::future_status::ready);
  const std::optional<Frame> f = first.get();
  // The next scan was sent whole after the subscription (the first one's origins, sent first,
  // may have preceded it: they are not waited for).
  const std::optional<Frame> g = src->next();
  pub.stop();
  ASSERT_TRUE(f && f->grid);
  const int k = std::stoi(f->id.substr(1));
  EXPECT_EQ(f->grid->layerNames(), std::vector<std::string>{"height_diff"});
  EXPECT_EQ(f->grid->layer("height_diff")[123], static_cast<float>(k));
  // Its layers' origins came with it (<grid_channel>_ORIGINS by default), those of the layers
  // taken only: the energy checks them per scan.
  ASSERT_TRUE(g && g->grid);
  EXPECT_EQ(g->layer_origins,
            (std::map<std::string, std::string>{{"height_diff", "{stage: height_difference}"}}));
}

// Once the stream has brought a scan's layer origins, a scan without its own fails (it could not
// be checked against the model), naming the channel; the others run.
TEST_F(LcmSubscribeTest, AScanWithoutItsOriginsFailsOnceTheStreamHasCarriedThem) {
  ctx_.grid = GridGeometry{};
  auto src = make("{url: '" + url() +
                  "', points_channel: G_POINTS, grid_channel: G, "
                  "grid_layers: [height_diff], idle_timeout_s: 5, wait_s: 0.05}");
  int with = 0, refused = 0;
  auto taken = std::async(std::launch::async, [&] {
    for (int n = 0; n < 8; ++n) {
      try {
        const std::optional<Frame> f = src->next();
        if (f && !f->layer_origins.empty()) ++with;
      } catch (const InputError& e) {
        const std::string what = e.what();
        if (what.find("no layer_origins_t on channel G_ORIGINS for scan 's") != std::string::npos &&
            what.find("the stream has carried them for earlier scans") != std::string::npos)
          ++refused;
        else if (what.find("no terrain_grid_t on channel G") == std::string::npos)
          ADD_FAILURE() << what;  // only the first scan's grid may precede the subscription
      }
    }
  });
  Publisher pub(url(), false, false, true, /*odd_scans_without_origins=*/true);
  ASSERT_EQ(taken.wait_for(std::chrono::seconds(20)), std::future_status::ready);
  pub.stop();
  EXPECT_GE(with, 3);
  EXPECT_GE(refused, 3);
}

// idle_timeout_s ends the stream when no cloud comes.
TEST_F(LcmSubscribeTest, IdleStreamEnds) {
  auto src = make("{url: '" + url() + "', idle_timeout_s: 0.2}");
  auto f = std::async(std::launch::async, [&] { return src->next(); });
  ASSERT_EQ(f.wait_for(std::chrono::seconds(20)), std::future_status::ready);
  EXPECT_FALSE(f.get());
  EXPECT_FALSE(src->next());  // and on every call after
}

// interrupt() ends a next() that waits for a message that never comes (Ctrl-C on a live run).
TEST_F(LcmSubscribeTest, InterruptEndsAWaitingNext) {
  auto src = make("{url: '" + url() + "'}");
  auto f = std::async(std::launch::async, [&] { return src->next(); });
  EXPECT_EQ(f.wait_for(std::chrono::milliseconds(200)), std::future_status::timeout);
  src->interrupt();
  ASSERT_EQ(f.wait_for(std::chrono::seconds(20)), std::future_status::ready);
  EXPECT_FALSE(f.get());
}

// A stream that cannot go on fails once, naming the URL, and then ends: the runner would
// otherwise count a failed frame per call, forever.
TEST_F(LcmSubscribeTest, UrlLcmCannotOpenFailsOnceThenEnds) {
  auto src = make("{url: 'nosuch://x'}");
  try {
    src->next();
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("nosuch://x"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("the stream ends here"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(src->next());
}

TEST_F(LcmSubscribeTest, InterruptBeforeTheFirstNextEndsIt) {
  auto src = make("{url: '" + url() + "'}");
  src->interrupt();
  src->interrupt();  // idempotent
  EXPECT_FALSE(src->next());
}

// Two subscribers on one memq:// URL would run each other's callbacks: the second is refused;
// once the first is gone the URL is free again.
TEST_F(LcmSubscribeTest, OneSubscriberPerMemqUrl) {
  auto a = make("{url: '" + url() + "', idle_timeout_s: 0.05}");
  EXPECT_FALSE(a->next());  // opened (and idle)
  auto b = make("{url: '" + url() + "', idle_timeout_s: 0.05}");
  try {
    b->next();
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("one subscriber per memq:// URL"), std::string::npos)
        << e.what();
  }
  a.reset();
  auto c = make("{url: '" + url() + "', idle_timeout_s: 0.05}");
  EXPECT_FALSE(c->next());
}

TEST_F(LcmSubscribeTest, BadParametersAreRefused) {
  const auto refused = [&](const std::string& params, const std::string& expect) {
    try {
      make(params);
      ADD_FAILURE() << params << " accepted; expected: " << expect;
    } catch (const std::exception& e) {
      EXPECT_NE(std::string(e.what()).find(expect), std::string::npos) << e.what();
    }
  };
  refused("{url: 'file:///tmp/x.lcm'}", "read it with the lcm_log source");
  refused("{url: ''}", "is empty");
  refused("{pose_channel: P, truth_pose_channel: P}", "must come on different channels");
  refused("{wait_s: -1}", "wait_s");
}

// A pipeline over a live stream: the runner takes scans as they come and stops at --limit.
TEST_F(LcmSubscribeTest, PipelineClassifiesLiveScansUntilItsLimit) {
  test::TempDir dir;
  std::ofstream(dir.str() + "/model.yaml") << R"(provenance: hand-written for tests
classes:
  road:     {height_diff: {mean: 0.02, sigma: 0.02}}
  rough:    {height_diff: {mean: 0.08, sigma: 0.05}}
  obstacle: {height_diff: {mean: 1.0, sigma: 0.8}}
)";
  std::ofstream(dir.str() + "/c.yaml")
      << "version: 1\ngrid: {size_m: 20, cell_m: 0.5}\n"
         "source: {type: lcm_subscribe, params: {url: '" + url() +
             "', points_channel: G_POINTS, idle_timeout_s: 10}}\n"
         "stages:\n"
         "  - {name: hdiff, type: height_difference}\n"
         "  - {name: mrf, type: potts_gaussian, params: {model: model.yaml, features: "
         "[height_diff]}}\n"
         "  - {name: solve, type: icm}\n"
         "outputs: [{type: grid_csv}]\n";
  LoadOptions lo;
  lo.output_dir = dir.str() + "/out";
  Pipeline p = loadPipeline(dir.str() + "/c.yaml", lo, reg_);
  RunOptions ro;
  ro.progress = false;
  ro.limit = 3;
  std::ostringstream log;
  ro.log = &log;
  auto run = std::async(std::launch::async, [&] { return runPipeline(p, ro); });
  Publisher pub(url(), false);
  ASSERT_EQ(run.wait_for(std::chrono::seconds(60)), std::future_status::ready) << log.str();
  const RunResult r = run.get();
  pub.stop();
  EXPECT_EQ(r.summary.frames_ok, 3u) << log.str();
  EXPECT_TRUE(r.summary.failed.empty()) << log.str();
  EXPECT_EQ(r.exitCode(), 0);
  int csv = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir.str() + "/out/grid_csv")) {
    (void)e;
    ++csv;
  }
  EXPECT_EQ(csv, 3);
}

}  // namespace
}  // namespace terramrf
