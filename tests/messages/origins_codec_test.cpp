#include "terramrf/lcm/origins_codec.hpp"

#include <gtest/gtest.h>

#include <terramrf_msgs/layer_origins_t.hpp>

#include "terramrf/errors.hpp"
#include "terramrf/lcm/message_peek.hpp"

namespace terramrf {
namespace {

const std::map<std::string, std::string> kOrigins = {
    {"height_diff", "{stage: height_difference, cell_m: 0.5, params: {min_points: 1}}"},
    {"roughness", "{stage: roughness, cell_m: 0.5, params: {window: 2}}"}};

TEST(OriginsCodec, RoundTripAndWireFields) {
  const MessageBytes b = encodeLayerOrigins(kOrigins, {"000042", "lidar", 12.5});
  terramrf_msgs::layer_origins_t m;
  ASSERT_EQ(m.decode(b.data(), 0, static_cast<int>(b.size())), static_cast<int>(b.size()));
  EXPECT_EQ(m.utime, 12500000);
  EXPECT_EQ(m.frame_id, "000042");
  EXPECT_EQ(m.layer_names, (std::vector<std::string>{"height_diff", "roughness"}));
  EXPECT_EQ(m.origins[1], kOrigins.at("roughness"));
  const DecodedLayerOrigins d = decodeLayerOrigins(b);
  EXPECT_EQ(d.origins, kOrigins);
  EXPECT_EQ(d.header.frame_id, "000042");
  EXPECT_DOUBLE_EQ(d.header.timestamp_s, 12.5);
  // A log index tells it by its hash and matches it to its scan by frame_id.
  const auto stamp = peekMessageStamp(b.data(), b.size());
  ASSERT_TRUE(stamp);
  EXPECT_EQ(stamp->type, "layer_origins_t");
  EXPECT_EQ(stamp->frame_id, "000042");
}

TEST(OriginsCodec, BadMessagesAreInputErrorsNamingTheSource) {
  const auto expectError = [](const terramrf_msgs::layer_origins_t& m, const std::string& what) {
    MessageBytes b(static_cast<std::size_t>(m.getEncodedSize()));
    m.encode(b.data(), 0, static_cast<int>(b.size()));
    try {
      decodeLayerOrigins(b, "log event 3 (G_ORIGINS)");
      ADD_FAILURE() << "accepted: " << what;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), "log event 3 (G_ORIGINS)");
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  terramrf_msgs::layer_origins_t m;
  m.frame_id = "a";
  m.num_layers = 2;
  m.layer_names = {"roughness", "roughness"};
  m.origins = {"{stage: roughness}", "{stage: roughness, cell_m: 1}"};
  expectError(m, "layer_origins_t: layer 'roughness' is named twice");
  m.layer_names = {"roughness", "height_diff"};
  m.origins[1] = "";
  expectError(m, "layer 1 ('height_diff') has an empty name or origin");
  m.origins[1] = "{stage: height_difference";  // cut: not YAML
  expectError(m,
              "the origin of layer 'height_diff' is not a stage's record (a YAML map with "
              "'stage'): '{stage: height_difference'");
  m.origins[1] = "[1, 2]";
  expectError(m, "the origin of layer 'height_diff' is not a stage's record");
  m.origins[1] = "{cell_m: 0.5}";
  expectError(m, "the origin of layer 'height_diff' is not a stage's record");
  m.origins[1] = "{stage: height_difference, cell_m: x}";
  expectError(m, "the origin of layer 'height_diff' is not a stage's record");
  m.origins[1] = "{stage: height_difference, params: [1]}";
  expectError(m, "the origin of layer 'height_diff' is not a stage's record");
  // Another message type, and cut bytes.
  const MessageBytes good = encodeLayerOrigins(kOrigins, {"a", "lidar", 0});
  EXPECT_THROW(decodeLayerOrigins(MessageBytes(good.begin(), good.end() - 5)), InputError);
  MessageBytes other = good;
  other[0] ^= 0xff;
  EXPECT_THROW(decodeLayerOrigins(other), InputError);
  // What cannot be sent is refused when encoding.
  EXPECT_THROW(encodeLayerOrigins({{"", "{stage: x}"}}, {"a", "lidar", 0}), std::invalid_argument);
  EXPECT_THROW(encodeLayerOrigins({{"x", ""}}, {"a", "lidar", 0}), std::invalid_argument);
}

}  // namespace
}  // namespace terramrf
