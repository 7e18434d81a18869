#include "terramrf/io/label_map.hpp"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <fstream>

#include "terramrf/errors.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

std::string shipped(const std::string& f) { return test::sourceDir() + "/configs/label_maps/" + f; }

/// Raw ids listed under `labels:` of an upstream dataset config.
std::vector<uint32_t> upstreamIds(const std::string& path) {
  std::vector<uint32_t> ids;
  const YAML::Node n = YAML::LoadFile(path)["labels"];
  for (auto it = n.begin(); it != n.end(); ++it) ids.push_back(it->first.as<uint32_t>());
  return ids;
}

TEST(LabelMap, SemanticKittiMapsTheProjectConvention) {
  const LabelMap m = LabelMap::load(shipped("semantickitti.yaml"), LabelSet::defaults());
  EXPECT_EQ(m.dataset(), "semantickitti");
  for (uint32_t id : {40u, 44u, 48u, 60u}) EXPECT_EQ(m.map(id), labels::kRoad) << id;
  for (uint32_t id : {49u, 72u}) EXPECT_EQ(m.map(id), labels::kRough) << id;
  for (uint32_t id : {10u, 11u, 13u, 15u, 16u, 18u, 20u, 30u, 31u,  32u,
                      50u, 51u, 52u, 70u, 71u, 80u, 81u, 99u, 252u, 259u})
    EXPECT_EQ(m.map(id), labels::kObstacle) << id;
  EXPECT_EQ(m.map(0), labels::kUnknown);
  EXPECT_EQ(m.map(1), labels::kUnknown);
  EXPECT_EQ(m.name(70), "vegetation");
}

TEST(LabelMap, ShippedMapsCoverEveryUpstreamId) {
  const LabelMap sk = LabelMap::load(shipped("semantickitti.yaml"), LabelSet::defaults());
  const auto sk_ids = upstreamIds(test::dataPath("label_maps/semantic-kitti.yaml"));
  ASSERT_EQ(sk_ids.size(), 34u);
  for (uint32_t id : sk_ids) EXPECT_TRUE(sk.contains(id)) << "semantickitti id " << id;
  EXPECT_EQ(sk.rawIds().size(), sk_ids.size());

  const LabelMap rl = LabelMap::load(shipped("rellis3d.yaml"), LabelSet::defaults());
  const auto rl_ids = upstreamIds(test::dataPath("label_maps/rellis.yaml"));
  ASSERT_EQ(rl_ids.size(), 20u);
  for (uint32_t id : rl_ids) EXPECT_TRUE(rl.contains(id)) << "rellis id " << id;
  EXPECT_EQ(rl.map(23), labels::kRoad);      // concrete
  EXPECT_EQ(rl.map(31), labels::kRough);     // puddle
  EXPECT_EQ(rl.map(19), labels::kObstacle);  // bush
  EXPECT_EQ(rl.map(7), labels::kUnknown);    // sky
}

TEST(LabelMap, UnmappedIdNamesMapIdAndDataFile) {
  const std::string path = shipped("semantickitti.yaml");
  const LabelMap m = LabelMap::load(path, LabelSet::defaults());
  try {
    std::vector<uint32_t> raw{40, 77, 77};
    std::vector<LabelId> out;
    m.mapAll(raw, out, "/data/scan_000042.label");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find(path), std::string::npos) << w;
    EXPECT_NE(w.find("77"), std::string::npos) << w;
    EXPECT_NE(w.find("/data/scan_000042.label"), std::string::npos) << w;
    EXPECT_NE(w.find("2 times"), std::string::npos) << w;
  }
  EXPECT_THROW(m.map(100000), InputError);
}

TEST(LabelMap, RejectsBadFiles) {
  test::TempDir dir;
  auto write = [&](const std::string& name, const std::string& text) {
    const std::string p = dir.str() + "/" + name;
    std::ofstream(p) << text;
    return p;
  };
  const LabelSet ls = LabelSet::defaults();
  EXPECT_THROW(LabelMap::load(dir.str() + "/missing.yaml", ls), InputError);
  EXPECT_THROW(LabelMap::load(write("a.yaml", "classes: {grass: [1]}"), ls), InputError);
  EXPECT_THROW(LabelMap::load(write("b.yaml", "classes: {road: [1], rough: [1]}"), ls), InputError);
  EXPECT_THROW(LabelMap::load(write("c.yaml", "dataset: x"), ls), InputError);
  EXPECT_THROW(LabelMap::load(write("d.yaml", "classes: {road: [-3]}"), ls), InputError);
  EXPECT_THROW(LabelMap::load(write("e.yaml", "classes: {road: [a]}"), ls), InputError);
  EXPECT_THROW(LabelMap::load(write("f.yaml", "classes: [1, 2"), ls), InputError);
  try {
    LabelMap::load(write("g.yaml", "classes: {grass: [1]}"), ls);
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("grass"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("g.yaml"), std::string::npos);
  }
  // A second `road:` list would be ignored by every lookup; its ids would then read as unmapped
  // in the data, far from the cause.
  try {
    LabelMap::load(write("i.yaml", "classes:\n  road: [40]\n  rough: [72]\n  road: [44]\n"), ls);
    ADD_FAILURE() << "accepted a repeated class";
  } catch (const InputError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("i.yaml: line 4:3: duplicate key 'road' (first at line 2)"), std::string::npos)
        << w;
  }
  // A file that is YAML but not a label map, or not YAML: found by fuzzing, these let yaml-cpp's
  // own message out ("operator[] call on a scalar", "bad conversion") without the file's name.
  struct Case {
    const char *name, *text, *expect;
  };
  for (const Case& c :
       {Case{"j.yaml", "abc\n", "j.yaml: line 1:1: not a label map"},
        Case{"k.yaml", "classes: {[1]: [1]}\n", "k.yaml: line 1:11: not a label map"},
        Case{"l.yaml", "classes: {road: [1, 2\n",
             "l.yaml: line 2:1: YAML syntax error: end of sequence flow not found"},
        Case{"m.yaml", "classes: {road: [1]}\nnames: {1: [a]}\n", "m.yaml: line 2:"}}) {
    try {
      LabelMap::load(write(c.name, c.text), ls);
      ADD_FAILURE() << "accepted " << c.text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(c.expect), std::string::npos) << e.what();
    }
  }
  // A bare id (brackets forgotten) or a map is not a list of ids: refused, naming the class and
  // the form expected.
  for (const char* text : {"classes: {road: 40}\n", "classes: {road: {40: x}}\n"}) {
    try {
      LabelMap::load(write("n.yaml", text), ls);
      ADD_FAILURE() << "accepted " << text;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), dir.str() + "/n.yaml");
      EXPECT_NE(
          std::string(e.what()).find("class 'road': expected a list of raw ids, e.g. [40, 44]"),
          std::string::npos)
          << e.what();
    }
  }
  // Listing an id twice under the same class is harmless.
  const LabelMap ok =
      LabelMap::load(write("h.yaml", "classes: {road: [5, 5], rough: [70000]}"), ls);
  EXPECT_EQ(ok.map(5), labels::kRoad);
  EXPECT_EQ(ok.map(70000), labels::kRough);
}

TEST(LabelMap, MapsPixelIds) {
  const LabelMap m = LabelMap::load(shipped("rellis3d.yaml"), LabelSet::defaults());
  const std::vector<uint8_t> px{3, 4, 7, 10, 31};
  std::vector<LabelId> out(px.size());
  m.mapAll(px.data(), px.size(), out.data(), "img.png");
  EXPECT_EQ(out, (std::vector<LabelId>{labels::kRough, labels::kObstacle, labels::kUnknown,
                                       labels::kRoad, labels::kRough}));
  const std::vector<uint8_t> bad{3, 2};
  EXPECT_THROW(m.mapAll(bad.data(), bad.size(), out.data(), "img.png"), InputError);
}

}  // namespace
}  // namespace terramrf
