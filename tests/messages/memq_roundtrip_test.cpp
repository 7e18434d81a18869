// Publishes through GridPublisher on an in-process memq:// LCM instance and reads the messages
// back from the same instance, as a subscriber on the network would.
#include <gtest/gtest.h>

#include <lcm/lcm-cpp.hpp>
#include <terramrf_msgs/terrain_grid_t.hpp>
#include <vector>

#include "terramrf/errors.hpp"
#include "terramrf/lcm/grid_codec.hpp"
#include "terramrf/lcm/grid_publisher.hpp"
#include "terramrf/lcm/sensor_codec.hpp"
#include "test_grid.hpp"

namespace terramrf {
namespace {

struct Received {
  std::vector<std::pair<std::string, MessageBytes>> raw;
  std::vector<terramrf_msgs::terrain_grid_t> typed;
};

void onRaw(const lcm::ReceiveBuffer* rbuf, const std::string& channel, Received* r) {
  const auto* p = static_cast<const uint8_t*>(rbuf->data);
  r->raw.emplace_back(channel, MessageBytes(p, p + rbuf->data_size));
}
void onGrid(const lcm::ReceiveBuffer*, const std::string&, const terramrf_msgs::terrain_grid_t* m,
            Received* r) {
  r->typed.push_back(*m);
}

TEST(MemqRoundTrip, GridPublishedAndDecodedMatchesOriginal) {
  lcm::LCM lc("memq://");
  ASSERT_TRUE(lc.good());
  Received rx;
  lc.subscribeFunction("TEST_GRID", &onRaw, &rx);
  lc.subscribeFunction("TEST_GRID", &onGrid, &rx);
  lc.subscribeFunction("TEST_GRID_POINTS", &onRaw, &rx);

  GridPublisher pub(lc.getUnderlyingLCM(), "TEST_GRID");
  EXPECT_EQ(pub.pointsChannel(), "TEST_GRID_POINTS");
  const TerrainGrid grid = test::smallGrid();
  pub.publish(grid, LabelSet::defaults(), {"000042", "lidar", 3.25});
  PointCloud cloud;
  cloud.push_back(1.f, 2.f, 3.f, 0.5f, 7);
  pub.publishPoints(cloud, {"000042", "lidar", 3.25});

  int handled = 0;
  while (lc.handleTimeout(50) > 0) ++handled;
  EXPECT_EQ(handled, 2);
  ASSERT_EQ(rx.raw.size(), 2u);
  ASSERT_EQ(rx.typed.size(), 1u);

  EXPECT_EQ(rx.raw[0].first, "TEST_GRID");
  const DecodedGrid d = decodeGrid(rx.raw[0].second, rx.raw[0].first);
  EXPECT_EQ(d.header.frame_id, "000042");
  EXPECT_DOUBLE_EQ(d.header.timestamp_s, 3.25);
  EXPECT_EQ(d.grid.rows(), grid.rows());
  EXPECT_DOUBLE_EQ(d.grid.geometry().cell_m, grid.geometry().cell_m);
  EXPECT_NEAR(d.grid.geometry().origin().x(), 9.0, 1e-12);
  EXPECT_NEAR(d.grid.geometry().origin().y(), -4.0, 1e-12);
  EXPECT_EQ(d.grid.labels(), grid.labels());
  EXPECT_EQ(d.grid.labels()[d.grid.index(3, 0)], labels::kObstacle);
  EXPECT_TRUE(test::sameLayer(d.grid.layer("height"), grid.layer("height")));
  EXPECT_TRUE(std::isnan(d.grid.layer("height")[d.grid.index(2, 2)]));
  EXPECT_TRUE(test::sameLayer(d.grid.layer("rough"), grid.layer("rough")));
  EXPECT_EQ(d.point_counts, pointCounts(grid));
  EXPECT_EQ(rx.typed[0].labels[3 * 4], labels::kObstacle);

  EXPECT_EQ(rx.raw[1].first, "TEST_GRID_POINTS");
  const DecodedPointCloud pc = decodePointCloud(rx.raw[1].second.data(), rx.raw[1].second.size());
  EXPECT_EQ(pc.cloud.x, cloud.x);
  EXPECT_EQ(pc.cloud.ring, cloud.ring);
}

TEST(MemqRoundTrip, OwnedInstanceAndBadUrl) {
  GridPublisher own("memq://", "G");
  EXPECT_NO_THROW(own.publish(test::smallGrid(), LabelSet::defaults(), {}));
  try {
    GridPublisher bad("nosuchprovider://x", "G");
    FAIL() << "bad URL accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("nosuchprovider://x"), std::string::npos) << e.what();
  }
  EXPECT_THROW(GridPublisher(static_cast<_lcm_t*>(nullptr), "G"), std::invalid_argument);
}

}  // namespace
}  // namespace terramrf
