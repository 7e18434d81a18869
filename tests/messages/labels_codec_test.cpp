#include "terramrf/lcm/labels_codec.hpp"

#include <gtest/gtest.h>

#include <terramrf_msgs/point_labels_t.hpp>

#include "terramrf/errors.hpp"
#include "terramrf/lcm/sensor_codec.hpp"

namespace terramrf {
namespace {

PointLabels someTruth() {
  PointLabels t;
  t.label = {labels::kRoad, labels::kObstacle, labels::kUnknown, labels::kRough};
  t.raw = {40, 50, 0, 72};
  return t;
}

TEST(LabelsCodec, RoundTripKeepsClassesRawIdsAndHeader) {
  const MessageBytes b = encodePointLabels(someTruth(), LabelSet::defaults(), {"000007", "lidar", 0.7});
  const DecodedPointLabels d = decodePointLabels(b.data(), b.size());
  EXPECT_EQ(d.header.frame_id, "000007");
  EXPECT_DOUBLE_EQ(d.header.timestamp_s, 0.7);
  EXPECT_EQ(d.label_names, LabelSet::defaults().names());
  EXPECT_EQ(d.truth.label, someTruth().label);
  EXPECT_EQ(d.truth.raw, someTruth().raw);

  PointLabels no_raw = someTruth();
  no_raw.raw.clear();
  const MessageBytes c = encodePointLabels(no_raw, LabelSet::defaults(), {"1", "lidar", 0});
  EXPECT_TRUE(decodePointLabels(c.data(), c.size()).truth.raw.empty());
}

// The receiver's classes may be ordered otherwise: ids follow the names, not the numbers.
TEST(LabelsCodec, MapsClassesByNameIntoTheReceiversSet) {
  const MessageBytes b = encodePointLabels(someTruth(), LabelSet::defaults(), {"1", "lidar", 0});
  const LabelSet mine({{"unknown", {0, 0, 0}}, {"obstacle", {255, 0, 0}}, {"rough", {1, 1, 1}},
                       {"road", {2, 2, 2}}});
  const PointLabels p = mapPointLabels(decodePointLabels(b.data(), b.size()), mine);
  EXPECT_EQ(p.label, (std::vector<LabelId>{3, 1, 0, 2}));
  EXPECT_EQ(p.raw, someTruth().raw);
}

TEST(LabelsCodec, ClassNoPointCarriesNeedsNoCounterpart) {
  PointLabels t;
  t.label = {labels::kRoad, labels::kRoad};
  const MessageBytes b = encodePointLabels(t, LabelSet::defaults(), {"1", "lidar", 0});
  const LabelSet mine({{"unknown", {0, 0, 0}}, {"road", {2, 2, 2}}});
  EXPECT_EQ(mapPointLabels(decodePointLabels(b.data(), b.size()), mine).label,
            (std::vector<LabelId>{1, 1}));
}

TEST(LabelsCodec, ClassAPointCarriesThatTheRunLacksIsAnErrorNamingIt) {
  const MessageBytes b = encodePointLabels(someTruth(), LabelSet::defaults(), {"1", "lidar", 0});
  const LabelSet mine({{"unknown", {0, 0, 0}}, {"road", {2, 2, 2}}, {"rough", {1, 1, 1}}});
  try {
    mapPointLabels(decodePointLabels(b.data(), b.size()), mine, "log.lcm event 3 (L)");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("log.lcm event 3 (L)"), std::string::npos) << w;
    EXPECT_NE(w.find("\"obstacle\""), std::string::npos) << w;
    EXPECT_NE(w.find("unknown, road, rough"), std::string::npos) << w;
  }
}

// Ids the sender names no class for (a grid decoder lets labels without names through) are an
// error naming the source, not an index past the names.
TEST(LabelsCodec, AnIdWithoutAClassNameIsAnError) {
  std::vector<LabelId> ids = {0, 1, 3};
  try {
    mapLabelsByName(ids, {"unknown", "road"}, LabelSet::defaults(), "chan G", "terrain_grid_t");
    FAIL() << "mapped an id without a name";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("chan G: terrain_grid_t: label id 3 has no class name "
                                         "(2 named)"),
              std::string::npos)
        << e.what();
  }
  std::vector<LabelId> none = {0, 1};
  EXPECT_THROW(mapLabelsByName(none, {}, LabelSet::defaults(), "chan G", "terrain_grid_t"),
               InputError);
}

TEST(LabelsCodec, BadInputIsRefused) {
  PointLabels t = someTruth();
  t.raw.pop_back();
  EXPECT_THROW(encodePointLabels(t, LabelSet::defaults(), {}), std::invalid_argument);
  t = someTruth();
  t.label[0] = 9;
  EXPECT_THROW(encodePointLabels(t, LabelSet::defaults(), {}), std::invalid_argument);

  const MessageBytes b = encodePointLabels(someTruth(), LabelSet::defaults(), {"1", "lidar", 0});
  EXPECT_THROW(decodePointLabels(b.data(), b.size() - 3, "L"), InputError);
  PointCloud c;
  c.push_back(1, 2, 3, 0, 0);
  const MessageBytes cloud = encodePointCloud(c, {"1", "lidar", 0});
  try {
    decodePointLabels(cloud.data(), cloud.size(), "chan");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("point_labels_t"), std::string::npos) << e.what();
  }
}

// Messages from other senders: names that do not start with "unknown" cannot say which points
// are not scored; a class id past the names, or raw ids for another number of points, are
// refused too.
TEST(LabelsCodec, ForeignMessagesThatBreakTheContractAreRefused) {
  const auto encode = [](const terramrf_msgs::point_labels_t& m) {
    MessageBytes b(static_cast<std::size_t>(m.getEncodedSize()));
    m.encode(b.data(), 0, static_cast<int>(b.size()));
    return b;
  };
  terramrf_msgs::point_labels_t m;  // lcm-gen leaves scalars uninitialised
  m.utime = 0;
  m.num_raw = 0;
  m.frame_id = "1";
  m.label_names = {"unknown", "road"};
  m.num_label_names = 2;
  m.label = {0, 1};
  m.num_points = 2;
  MessageBytes ok = encode(m);
  EXPECT_NO_THROW(decodePointLabels(ok.data(), ok.size()));

  terramrf_msgs::point_labels_t bad = m;
  bad.label_names = {"road", "unknown"};
  MessageBytes b = encode(bad);
  EXPECT_THROW(decodePointLabels(b.data(), b.size()), InputError);
  bad = m;
  bad.label = {0, 2};
  b = encode(bad);
  EXPECT_THROW(decodePointLabels(b.data(), b.size()), InputError);
  bad = m;
  bad.raw = {7};
  bad.num_raw = 1;
  b = encode(bad);
  EXPECT_THROW(decodePointLabels(b.data(), b.size()), InputError);
}

}  // namespace
}  // namespace terramrf
