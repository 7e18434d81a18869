// The "lcm_publish" output. memq:// is private to the plugin's own LCM instance, so what it sends
// is observed through LCM's file:// provider (an LCM log), read back with lcm::LogFile.
#include <gtest/gtest.h>

#include <filesystem>
#include <lcm/lcm-cpp.hpp>
#include <vector>

#include "output_test_support.hpp"
#include "terramrf/lcm/grid_codec.hpp"
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
