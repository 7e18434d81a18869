#include "terramrf/lcm/grid_codec.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <terramrf_msgs/point_cloud_t.hpp>
#include <terramrf_msgs/terrain_grid_t.hpp>

#include "terramrf/errors.hpp"
#include "test_grid.hpp"

namespace terramrf {
namespace {

TEST(GridCodec, WireFieldsHaveTheDocumentedMeaning) {
  const TerrainGrid grid = test::smallGrid();
  MessageHeader h{"000042", "lidar", 12.345678};
  const MessageBytes bytes = encodeGrid(grid, LabelSet::defaults(), h);

  terramrf_msgs::terrain_grid_t m;
  ASSERT_EQ(m.decode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  EXPECT_EQ(m.utime, 12345678);
  EXPECT_EQ(m.frame_id, "000042");
  EXPECT_EQ(m.coordinate_frame, "lidar");
  EXPECT_EQ(m.rows, 4);
  EXPECT_EQ(m.cols, 4);
  EXPECT_EQ(m.num_cells, 16);
  EXPECT_DOUBLE_EQ(m.cell_m, 0.5);
  EXPECT_DOUBLE_EQ(m.origin_x_m, 9.0);
  EXPECT_DOUBLE_EQ(m.origin_y_m, -4.0);
  EXPECT_EQ(m.label_names, (std::vector<std::string>{"unknown", "road", "rough", "obstacle"}));
  ASSERT_EQ(m.num_labels, 16);
  EXPECT_EQ(m.labels[3 * 4 + 0], 3);  // row-major: row * cols + col
  EXPECT_EQ(m.labels[0 * 4 + 3], 1);
  EXPECT_EQ(m.labels[1 * 4 + 2], 2);
  EXPECT_EQ(m.labels[0], 0);
  ASSERT_EQ(m.num_point_counts, 16);
  EXPECT_EQ(m.point_counts[0], 2);
  EXPECT_EQ(m.point_counts[15], 1);
  EXPECT_EQ(m.point_counts[5], 0);
  ASSERT_EQ(m.num_layers, 2);
  EXPECT_EQ(m.layer_names, (std::vector<std::string>{"height", "rough"}));  // name order
  EXPECT_FLOAT_EQ(m.layers[0][2 * 4 + 3], 2.3f);
  EXPECT_TRUE(std::isnan(m.layers[0][2 * 4 + 2]));
  EXPECT_EQ(m.layers[1][5], 0.125f);
}

TEST(GridCodec, RoundTripKeepsGeometryLabelsLayersAndNaN) {
  const TerrainGrid grid = test::smallGrid();
  const MessageBytes bytes = encodeGrid(grid, LabelSet::defaults(), {"7", "world", 1.5});
  const DecodedGrid d = decodeGrid(bytes);
  EXPECT_EQ(d.header.frame_id, "7");
  EXPECT_EQ(d.header.coordinate_frame, "world");
  EXPECT_DOUBLE_EQ(d.header.timestamp_s, 1.5);
  EXPECT_EQ(d.grid.rows(), 4);
  EXPECT_EQ(d.grid.cols(), 4);
  EXPECT_DOUBLE_EQ(d.grid.geometry().cell_m, 0.5);
  EXPECT_NEAR(d.grid.geometry().origin().x(), 9.0, 1e-12);
  EXPECT_NEAR(d.grid.geometry().origin().y(), -4.0, 1e-12);
  EXPECT_NEAR(d.grid.geometry().centre_m.x(), 10.0, 1e-12);
  EXPECT_TRUE(d.has_labels);
  EXPECT_EQ(d.grid.labels(), grid.labels());
  EXPECT_EQ(d.label_names.size(), 4u);
  EXPECT_EQ(d.grid.layerNames(), grid.layerNames());
  EXPECT_TRUE(test::sameLayer(d.grid.layer("height"), grid.layer("height")));
  EXPECT_TRUE(test::sameLayer(d.grid.layer("rough"), grid.layer("rough")));
  EXPECT_EQ(d.point_counts, pointCounts(grid));
}

TEST(GridCodec, LayerSubsetAndMissingLayer) {
  const TerrainGrid grid = test::smallGrid();
  const DecodedGrid d = decodeGrid(encodeGrid(grid, LabelSet::defaults(), {}, {"rough"}));
  EXPECT_EQ(d.grid.layerNames(), std::vector<std::string>{"rough"});
  try {
    encodeGrid(grid, LabelSet::defaults(), {}, {"slope"});
    FAIL() << "missing layer accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'slope'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("height, rough"), std::string::npos) << e.what();
  }
}

TEST(GridCodec, UnbinnedGridSendsNoPointCounts) {
  GridGeometry g;
  g.size_m = 1.0;
  g.cell_m = 0.5;
  TerrainGrid grid(g);
  EXPECT_EQ(pointCounts(grid), std::vector<uint32_t>(4, 0));
  const DecodedGrid d = decodeGrid(encodeGrid(grid, LabelSet::defaults(), {}));
  EXPECT_TRUE(d.point_counts.empty());
  EXPECT_TRUE(d.grid.layerNames().empty());
}

// A label id the label set does not name is refused by the sender, naming the cell, rather than
// sent to receivers that refuse it (decodeGrid) or read it as another class.
TEST(GridCodec, LabelWithoutANameIsRefusedWhenSent) {
  GridGeometry g;
  g.size_m = 1.0;
  g.cell_m = 0.5;
  TerrainGrid grid(g);
  grid.labels()[2] = 4;  // the default set names ids 0-3
  try {
    encodeGrid(grid, LabelSet::defaults(), {});
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(),
                 "encodeGrid: cell 2 has label id 4 but the label set names only 4 classes");
  }
  grid.labels()[2] = 3;
  EXPECT_EQ(decodeGrid(encodeGrid(grid, LabelSet::defaults(), {})).grid.labels()[2], 3);
}

TEST(GridCodec, RejectsForeignTruncatedAndInconsistentMessages) {
  const MessageBytes good = encodeGrid(test::smallGrid(), LabelSet::defaults(), {});
  // Another type (fingerprint mismatch).
  terramrf_msgs::point_cloud_t pc{};
  pc.num_points = 0;
  pc.num_times = 0;
  MessageBytes other(pc.getEncodedSize());
  pc.encode(other.data(), 0, static_cast<int>(other.size()));
  EXPECT_THROW(decodeGrid(other, "CHAN"), InputError);
  // Truncated.
  try {
    decodeGrid(good.data(), good.size() / 2, "CHAN");
    FAIL() << "truncated message accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "CHAN");
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
  }
  EXPECT_THROW(decodeGrid(nullptr, 0), InputError);

  // Non-square grid and a label id without a name.
  terramrf_msgs::terrain_grid_t m{};
  m.rows = 2;
  m.cols = 3;
  m.num_cells = 6;
  m.cell_m = 1.0;
  auto enc = [](const terramrf_msgs::terrain_grid_t& msg) {
    MessageBytes b(msg.getEncodedSize());
    msg.encode(b.data(), 0, static_cast<int>(b.size()));
    return b;
  };
  EXPECT_THROW(decodeGrid(enc(m)), InputError);
  m.cols = 2;
  m.num_cells = 4;
  m.num_label_names = 2;
  m.label_names = {"unknown", "road"};
  m.num_labels = 4;
  m.labels = {0, 1, 5, 0};
  try {
    decodeGrid(enc(m));
    FAIL() << "label id without a name accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("label id 5"), std::string::npos) << e.what();
  }
  m.labels = {0, 1, 1, 0};
  EXPECT_NO_THROW(decodeGrid(enc(m)));
  m.cell_m = 0;
  EXPECT_THROW(decodeGrid(enc(m)), InputError);
}

}  // namespace
// A message from another program or a damaged log: each inconsistent count is named, with the
// channel it came on, instead of being read past its arrays.
TEST(GridCodec, EachInconsistentCountIsNamedWithItsChannel) {
  auto enc = [](const terramrf_msgs::terrain_grid_t& msg) {
    MessageBytes b(msg.getEncodedSize());
    msg.encode(b.data(), 0, static_cast<int>(b.size()));
    return b;
  };
  auto base = [] {
    terramrf_msgs::terrain_grid_t m{};
    m.rows = m.cols = 2;
    m.num_cells = 4;
    m.cell_m = 0.5;
    return m;
  };
  auto expectError = [&](const terramrf_msgs::terrain_grid_t& m, const std::string& what) {
    try {
      decodeGrid(enc(m), "CHAN");
      ADD_FAILURE() << "accepted; expected: " << what;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), "CHAN");
      EXPECT_NE(std::string(e.what()).find("terrain_grid_t: " + what), std::string::npos)
          << e.what();
    }
  };
  terramrf_msgs::terrain_grid_t m = base();
  m.rows = m.cols = 0;
  m.num_cells = 0;
  expectError(m, "rows and cols must be positive (got 0 x 0)");
  m = base();
  m.num_cells = 5;
  expectError(m, "num_cells 5 != rows * cols = 4");
  m = base();
  m.num_labels = 3;
  m.labels = {0, 0, 0};
  expectError(m, "num_labels must be 0 or num_cells (4), got 3");
  m = base();
  m.num_point_counts = 2;
  m.point_counts = {1, 2};
  expectError(m, "num_point_counts must be 0 or num_cells, got 2");
  m = base();
  m.cell_m = std::nan("");
  expectError(m, "cell_m must be finite and > 0 and the origin finite");
  EXPECT_NO_THROW(decodeGrid(enc(base()), "CHAN"));
}

}  // namespace terramrf
