#include "terramrf/sim/materials.hpp"

namespace terramrf::sim {

const char* materialName(Material m) {
  switch (m) {
    case Material::kNone:
      return "none";
    case Material::kAsphalt:
      return "asphalt";
    case Material::kLaneMarking:
      return "lane_marking";
    case Material::kGrass:
      return "grass";
    case Material::kGravel:
      return "gravel";
    case Material::kBuildingWall:
      return "building_wall";
    case Material::kBuildingRoof:
      return "building_roof";
    case Material::kTreeTrunk:
      return "tree_trunk";
    case Material::kTreeCrown:
      return "tree_crown";
    case Material::kRock:
      return "rock";
    case Material::kCar:
      return "car";
    case Material::kDitchFloor:
      return "ditch_floor";
    case Material::kDitchWall:
      return "ditch_wall";
  }
  return "invalid";
}

LabelId projectClass(Material m) {
  switch (m) {
    case Material::kNone:
      return labels::kUnknown;
    case Material::kAsphalt:
    case Material::kLaneMarking:
      return labels::kRoad;
    case Material::kGrass:
    case Material::kGravel:
      return labels::kRough;
    default:
      return labels::kObstacle;  // objects and the ditch (negative obstacle)
  }
}

float reflectivity(Material m) {
  switch (m) {
    case Material::kNone:
      return 0.0f;
    case Material::kAsphalt:
      return 0.12f;
    case Material::kLaneMarking:
      return 0.85f;
    case Material::kGrass:
      return 0.35f;
    case Material::kGravel:
      return 0.30f;
    case Material::kBuildingWall:
      return 0.25f;
    case Material::kBuildingRoof:
      return 0.20f;
    case Material::kTreeTrunk:
      return 0.30f;
    case Material::kTreeCrown:
      return 0.40f;
    case Material::kRock:
      return 0.28f;
    case Material::kCar:
      return 0.55f;
    case Material::kDitchFloor:
      return 0.18f;
    case Material::kDitchWall:
      return 0.22f;
  }
  return 0.0f;
}

}  // namespace terramrf::sim
