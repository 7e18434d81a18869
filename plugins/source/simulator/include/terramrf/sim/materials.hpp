#pragma once
// Surface materials of the simulated world. The numeric value is the "raw" simulator id written
// to Frame::truth.raw and to SemanticKITTI-style .label files; configs/label_maps/simulator.yaml
// maps it to the project classes (keep both in sync with projectClass()).
#include <array>
#include <cstdint>

#include "terramrf/label_set.hpp"

namespace terramrf::sim {

enum class Material : uint8_t {
  kNone = 0,         ///< no return / sky
  kAsphalt = 1,      ///< road surface
  kLaneMarking = 2,  ///< painted lines on the road
  kGrass = 3,        ///< rough ground
  kGravel = 4,       ///< road shoulder, yards around buildings, patches
  kBuildingWall = 10,
  kBuildingRoof = 11,
  kTreeTrunk = 12,
  kTreeCrown = 13,  ///< porous: rays pass with a probability
  kRock = 14,
  kCar = 15,         ///< parked cars (body and cabin)
  kDitchFloor = 16,  ///< negative obstacle
  kDitchWall = 17,   ///< negative obstacle
};

/// Every material, in id order.
inline constexpr std::array<Material, 13> kAllMaterials{
    Material::kNone,      Material::kAsphalt,      Material::kLaneMarking,  Material::kGrass,
    Material::kGravel,    Material::kBuildingWall, Material::kBuildingRoof, Material::kTreeTrunk,
    Material::kTreeCrown, Material::kRock,         Material::kCar,          Material::kDitchFloor,
    Material::kDitchWall};

/// Short snake_case name (as in the label map's `names`).
const char* materialName(Material m);

/// Project class (labels::kRoad / kRough / kObstacle; kUnknown for kNone).
LabelId projectClass(Material m);

/// LiDAR reflectivity in [0, 1] at normal incidence (KITTI-like intensity scale).
float reflectivity(Material m);

}  // namespace terramrf::sim
