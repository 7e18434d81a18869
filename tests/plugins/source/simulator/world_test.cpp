// The procedural world: terrain shape, road, ditch, objects and the ground-truth queries.
#include "terramrf/sim/world.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <set>

#include "terramrf/io/label_map.hpp"
#include "terramrf/sim/materials.hpp"
#include "terramrf/sim/random.hpp"
#include "test_support.hpp"

namespace terramrf::sim {
namespace {

WorldParams smallWorld(uint64_t seed) {
  WorldParams p;
  p.seed = seed;
  p.x_min_m = -130;
  p.x_max_m = 250;
  p.terrain_half_width_m = 140;
  return p;
}

const World& world1() {
  static const World w(smallWorld(1));
  return w;
}

Eigen::Vector2d onRoad(const World& w, double x, double lat) {
  const double s = w.roadCentreSlope(x), inv = 1.0 / std::sqrt(1 + s * s);
  return {x - lat * s * inv, w.roadCentreY(x) + lat * inv};
}

TEST(SimWorld, SameSeedSameWorldOtherSeedOtherWorld) {
  const World a(smallWorld(1)), c(smallWorld(2));
  const World& b = world1();
  ASSERT_EQ(a.buildings().size(), b.buildings().size());
  for (std::size_t i = 0; i < a.buildings().size(); ++i) {
    EXPECT_EQ(a.buildings()[i].centre_m, b.buildings()[i].centre_m);
    EXPECT_EQ(a.buildings()[i].top_z_m, b.buildings()[i].top_z_m);
  }
  EXPECT_EQ(a.terrainHeight(12.3, -45.6), b.terrainHeight(12.3, -45.6));
  EXPECT_NE(a.terrainHeight(12.3, -45.6), c.terrainHeight(12.3, -45.6));
  EXPECT_NE(a.roadCentreY(100), c.roadCentreY(100));
}

TEST(SimWorld, ContentDependsOnTheSeedNotOnTheStripLength) {
  // The plugin sizes the strip by frames, ranges and the camera; a seed must still mean one world.
  WorldParams longer = smallWorld(1);
  longer.x_min_m = -240;
  longer.x_max_m = 520;
  longer.terrain_half_width_m = 250;
  const World& a = world1();
  const World b(longer);
  auto inner = [](double x) { return x > -100 && x < 200; };
  std::vector<Eigen::Vector3d> ta, tb, ba, bb;
  for (const Tree& t : a.trees())
    if (inner(t.position_m.x())) ta.push_back(t.crown_centre_m);
  for (const Tree& t : b.trees())
    if (inner(t.position_m.x())) tb.push_back(t.crown_centre_m);
  for (const Building& x : a.buildings())
    if (inner(x.centre_m.x())) ba.emplace_back(x.centre_m.x(), x.centre_m.y(), x.top_z_m);
  for (const Building& x : b.buildings())
    if (inner(x.centre_m.x())) bb.emplace_back(x.centre_m.x(), x.centre_m.y(), x.top_z_m);
  EXPECT_EQ(ta, tb);
  EXPECT_EQ(ba, bb);
  EXPECT_GT(ba.size(), 3u);
  std::size_t rocks_a = 0, rocks_b = 0, cars_a = 0, cars_b = 0;
  for (const Rock& r : a.rocks()) rocks_a += inner(r.centre_m.x());
  for (const Rock& r : b.rocks()) rocks_b += inner(r.centre_m.x());
  for (const Car& c : a.cars()) cars_a += inner(c.centre_m.x());
  for (const Car& c : b.cars()) cars_b += inner(c.centre_m.x());
  EXPECT_EQ(rocks_a, rocks_b);
  EXPECT_EQ(cars_a, cars_b);
  for (double x = -100; x < 200; x += 1.7) {
    const Eigen::Vector2d p = onRoad(a, x, -5.0);
    EXPECT_EQ(a.terrainHeight(p.x(), p.y()), b.terrainHeight(p.x(), p.y())) << x;
    EXPECT_EQ(a.topMaterial(p.x(), p.y()), b.topMaterial(p.x(), p.y())) << x;
  }
}

TEST(SimWorld, GentleSlopesAndLevelRoadCrossSection) {
  const World& w = world1();
  EXPECT_LT(w.slopeBound(), 0.35) << "terrain should have gentle slopes";
  for (double x = -100; x < 220; x += 7.3) {
    double lo = 1e9, hi = -1e9;
    for (double lat = -3.0; lat <= 3.0; lat += 0.25) {
      const Eigen::Vector2d p = onRoad(w, x, lat);
      const double h = w.terrainHeight(p.x(), p.y());
      lo = std::min(lo, h);
      hi = std::max(hi, h);
      const Material m = w.groundMaterial(p.x(), p.y());
      EXPECT_TRUE(m == Material::kAsphalt || m == Material::kLaneMarking) << x << " " << lat;
    }
    EXPECT_LT(hi - lo, 0.01) << "road not level across at x=" << x;
    // Along the road: grade below 15 %.
    const Eigen::Vector2d a = onRoad(w, x, 0), b = onRoad(w, x + 1, 0);
    EXPECT_LT(
        std::abs(w.terrainHeight(b.x(), b.y()) - w.terrainHeight(a.x(), a.y())) / (b - a).norm(),
        0.15);
  }
  // The table used for ray casting agrees with the analytic smooth height on the road.
  const Eigen::Vector2d p = onRoad(w, 33.3, 1.0);
  EXPECT_NEAR(w.terrainHeight(p.x(), p.y()), w.smoothHeight(p.x(), p.y()), 0.005);
}

TEST(SimWorld, RoughGroundHasCentimetreNoise) {
  const World& w = world1();
  // Off the road, the height deviates from the smooth surface by a few cm, never more than the
  // configured bound.
  double max_dev = 0, sum2 = 0;
  int n = 0;
  for (double x = 0; x < 100; x += 0.37) {
    const Eigen::Vector2d p = onRoad(w, x, 25.0);
    if (w.groundMaterial(p.x(), p.y()) != Material::kGrass) continue;
    const double dev = w.terrainHeight(p.x(), p.y()) - w.smoothHeight(p.x(), p.y());
    max_dev = std::max(max_dev, std::abs(dev));
    sum2 += dev * dev;
    ++n;
  }
  ASSERT_GT(n, 50);
  EXPECT_LE(max_dev, w.params().rough_noise_m + 0.003);
  EXPECT_GT(std::sqrt(sum2 / n), 0.005) << "grass should be rough";
}

TEST(SimWorld, DitchIsAMetreDeepTrenchBesideTheRoad) {
  const World& w = world1();
  ASSERT_FALSE(w.ditches().empty());
  bool ahead = false;
  for (const Ditch& d : w.ditches()) {
    ahead |= d.x_begin_m > 0 && d.x_begin_m < 20;
    EXPECT_LT(d.offset_m, -w.params().road_width_m / 2) << "right of the road";
    EXPECT_NEAR(2 * d.half_width_m, 1.5, 1e-9);
    const double x = 0.5 * (d.x_begin_m + d.x_end_m);
    const Eigen::Vector2d c = onRoad(w, x, d.offset_m);
    const Eigen::Vector2d out = onRoad(w, x, d.offset_m - d.half_width_m - 0.5);
    const double depth = w.smoothHeight(c.x(), c.y()) - w.terrainHeight(c.x(), c.y());
    EXPECT_NEAR(depth, 1.0, 0.05);
    EXPECT_EQ(w.groundMaterial(c.x(), c.y()), Material::kDitchFloor);
    EXPECT_EQ(w.classAt(c.x(), c.y()), labels::kObstacle) << "negative obstacle";
    const Eigen::Vector2d wall = onRoad(w, x, d.offset_m + d.half_width_m - 0.1);
    EXPECT_EQ(w.groundMaterial(wall.x(), wall.y()), Material::kDitchWall);
    EXPECT_NE(w.groundMaterial(out.x(), out.y()), Material::kDitchWall);
  }
  EXPECT_TRUE(ahead) << "a ditch starts just ahead of x = 0 (first frames see it)";
}

TEST(SimWorld, BuildingsTreesRocksCars) {
  const World& w = world1();
  ASSERT_GE(w.buildings().size(), 5u);
  int tall_close = 0;
  for (const Building& b : w.buildings()) {
    EXPECT_GE(b.height_m(), 2.9);
    EXPECT_LE(b.height_m(), 15.01);
    EXPECT_LT(b.base_z_m, b.ground_z_m);
    const double lat =
        std::abs(w.lateralOffset(b.centre_m.x(), b.centre_m.y())) - b.half_size_m.y();
    if (b.height_m() >= 8 && lat < 12) ++tall_close;
    // Ground-truth queries on the roof.
    EXPECT_EQ(w.topMaterial(b.centre_m.x(), b.centre_m.y()), Material::kBuildingRoof);
    EXPECT_EQ(w.classAt(b.centre_m.x(), b.centre_m.y()), labels::kObstacle);
    EXPECT_NEAR(w.surfaceHeight(b.centre_m.x(), b.centre_m.y()), b.top_z_m, 1e-9);
  }
  EXPECT_GE(tall_close, 1) << "a tall building close to the road";
  int near_building = 0;
  for (const Tree& t : w.trees()) {
    if (t.near_building < 0) continue;
    ++near_building;
    const Building& b = w.buildings()[t.near_building];
    const Eigen::Vector2d d = t.position_m - b.centre_m;
    const double c = std::cos(b.yaw_rad), s = std::sin(b.yaw_rad);
    const double lx = std::abs(c * d.x() + s * d.y()) - b.half_size_m.x();
    const double ly = std::abs(-s * d.x() + c * d.y()) - b.half_size_m.y();
    EXPECT_LE(std::max(lx, ly), 3.01) << "tree next to its building";
    EXPECT_GE(std::max(lx, ly), 1.49);
    EXPECT_EQ(w.topMaterial(t.position_m.x(), t.position_m.y()), Material::kTreeCrown);
  }
  EXPECT_GE(near_building, 2);
  EXPECT_GE(w.trees().size(), 20u);
  EXPECT_GE(w.rocks().size(), 5u);
  EXPECT_GE(w.cars().size(), 1u);
  // Road is free of objects except parked cars at its left edge.
  for (double x = -100; x < 220; x += 0.5) {
    const Eigen::Vector2d p = onRoad(w, x, -1.625);
    EXPECT_EQ(w.groundClass(p.x(), p.y()), labels::kRoad);
    EXPECT_EQ(w.classAt(p.x(), p.y()), labels::kRoad) << "obstacle in the driving lane at x=" << x;
  }
}

TEST(SimWorld, RayCasting) {
  const World& w = world1();
  RayScratch s = w.makeScratch();
  // Straight down onto the road.
  const Eigen::Vector2d p = onRoad(w, 40, -1.5);
  const double h = w.terrainHeight(p.x(), p.y());
  RayHit hit = w.castRay({p.x(), p.y(), h + 1.73}, {0, 0, -1}, 0, 100, 1, s);
  ASSERT_TRUE(hit.hit());
  EXPECT_NEAR(hit.t_m, 1.73, 0.003);
  EXPECT_TRUE(hit.material == Material::kAsphalt || hit.material == Material::kLaneMarking);
  EXPECT_GT(hit.normal.z(), 0.99);
  // Grazing ray onto flat road: the hit lies on the surface.
  hit =
      w.castRay({p.x(), p.y(), h + 1.73}, Eigen::Vector3d(1, 0, -0.06).normalized(), 0, 100, 2, s);
  ASSERT_TRUE(hit.hit());
  EXPECT_NEAR(hit.point.z(), w.terrainHeight(hit.point.x(), hit.point.y()), 0.01);
  // Towards a building wall at mid height: hits the wall (or something in front of it).
  const Building& b = w.buildings().front();
  const Eigen::Vector3d target(b.centre_m.x(), b.centre_m.y(), b.ground_z_m + 0.6 * b.height_m());
  const Eigen::Vector3d from =
      target + Eigen::Vector3d(0, 0, 0) +
      (Eigen::Vector3d(p.x(), p.y(), target.z()) - target).normalized() * 60.0;
  const Eigen::Vector3d dir = (target - from).normalized();
  hit = w.castRay(from, dir, 0, 200, 3, s);
  ASSERT_TRUE(hit.hit());
  EXPECT_LE(hit.t_m, (target - from).norm());
  // Straight up: sky.
  EXPECT_FALSE(w.castRay({p.x(), p.y(), h + 1.73}, {0, 0, 1}, 0, 100, 4, s).hit());
}

TEST(SimWorld, PorousCrownsLetSomeRaysThrough) {
  const World& w = world1();
  RayScratch s = w.makeScratch();
  const Tree& t = w.trees().front();
  // Horizontal rays through the crown centre from 20 m away: some hit the crown, some pass.
  int crown = 0, through = 0;
  for (uint64_t k = 0; k < 400; ++k) {
    const Eigen::Vector3d o = t.crown_centre_m + Eigen::Vector3d(-20, 0, 0.3);
    const RayHit hit = w.castRay(o, {1, 0, 0}, 0, 200, hashKeys(9, k), s);
    if (hit.hit() && hit.material == Material::kTreeCrown)
      ++crown;
    else
      ++through;
  }
  EXPECT_GT(crown, 200);
  EXPECT_GT(through, 5);
}

TEST(SimWorld, LabelMapFileMatchesMaterials) {
  const LabelMap map = LabelMap::load(test::sourceDir() + "/configs/label_maps/simulator.yaml",
                                      LabelSet::defaults());
  EXPECT_EQ(map.dataset(), "simulator");
  std::set<uint32_t> ids;
  for (Material m : kAllMaterials) {
    const uint32_t id = uint32_t(m);
    ids.insert(id);
    EXPECT_EQ(map.map(id), projectClass(m)) << materialName(m);
    EXPECT_EQ(map.name(id), materialName(m));
  }
  const std::vector<uint32_t> listed = map.rawIds();
  EXPECT_EQ(std::set<uint32_t>(listed.begin(), listed.end()), ids);
  EXPECT_EQ(projectClass(Material::kDitchFloor), labels::kObstacle);
  EXPECT_EQ(projectClass(Material::kDitchWall), labels::kObstacle);
  EXPECT_EQ(projectClass(Material::kGravel), labels::kRough);
  EXPECT_EQ(projectClass(Material::kLaneMarking), labels::kRoad);
  EXPECT_EQ(projectClass(Material::kNone), labels::kUnknown);
}

}  // namespace
}  // namespace terramrf::sim
