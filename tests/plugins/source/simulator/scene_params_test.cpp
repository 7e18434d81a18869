// The scene parameters away from their defaults (obstacle_density, road_width_m, scene_width_m,
// hill_height_m, frames): the world keeps its documented promises or the setting is refused with
// an error naming the parameter.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "terramrf/errors.hpp"
#include "terramrf/sim/materials.hpp"
#include "terramrf/sim/simulation.hpp"

namespace terramrf::sim {
namespace {

/// True if `raw` is the material of an object (building, tree, rock, car), not of the ground.
bool objectMaterial(uint32_t raw) {
  switch (Material(raw)) {
    case Material::kBuildingWall:
    case Material::kBuildingRoof:
    case Material::kTreeTrunk:
    case Material::kTreeCrown:
    case Material::kRock:
    case Material::kCar:
      return true;
    default:
      return false;
  }
}

TEST(SimSceneParams, ObstacleDensityZeroMeansNoObjects) {
  // The landmark building and its two trees used to be placed whatever the density (6236 wall
  // points in frame 0 of seed 1).
  for (int seed : {1, 2, 3}) {
    const Simulation sim(parseSimulationConfig(
        "{seed: " + std::to_string(seed) +
        ", frames: 2, obstacle_density: 0, enable_camera: false, azimuth_step_deg: 0.36}"));
    const World& w = sim.world();
    EXPECT_TRUE(w.buildings().empty()) << "seed " << seed;
    EXPECT_TRUE(w.trees().empty()) << "seed " << seed;
    EXPECT_TRUE(w.rocks().empty()) << "seed " << seed;
    EXPECT_TRUE(w.cars().empty()) << "seed " << seed;
    EXPECT_FALSE(w.ditches().empty()) << "the ditch is terrain, not an object";
    const Frame f = sim.frame(0);
    std::size_t objects = 0;
    for (uint32_t raw : f.truth.raw) objects += objectMaterial(raw);
    EXPECT_EQ(objects, 0u) << "seed " << seed;
  }
  // Any density above 0 keeps the landmark.
  const Simulation low(
      parseSimulationConfig("{frames: 2, obstacle_density: 0.01, enable_camera: false}"));
  EXPECT_FALSE(low.world().buildings().empty());
}

}  // namespace
}  // namespace terramrf::sim
