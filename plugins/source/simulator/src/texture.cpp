// Procedural surface colours for the camera: every surface gets a colour and a texture that a
// colour/texture feature can pick up (asphalt grain, lane lines, grass blotches, windows, bark).
#include <algorithm>
#include <cmath>

#include "noise.hpp"
#include "world_internal.hpp"

namespace terramrf::sim {

namespace {
Eigen::Vector3f rgb(const std::array<uint8_t, 3>& c) {
  return {float(c[0]), float(c[1]), float(c[2])};
}
Eigen::Vector3f rgb(float r, float g, float b) { return {r, g, b}; }
}  // namespace

Eigen::Vector3f World::albedo(const RayHit& hit) const {
  using noise::fbm2;
  using noise::value2;
  using noise::value3;
  const double x = hit.point.x(), y = hit.point.y(), z = hit.point.z();
  const uint32_t s = noise_seed_ + 5003u;
  switch (hit.material) {
    case Material::kNone:
      return rgb(0, 0, 0);
    case Material::kAsphalt: {
      const float n = 0.6f * value2(x * 6, y * 6, s) + 0.4f * value2(x * 31, y * 31, s + 1);
      const float patch = 0.5f * fbm2(x * 0.3, y * 0.3, s + 2, 2);
      return rgb(96, 96, 100) * (1.0f + 0.12f * n + 0.1f * patch);
    }
    case Material::kLaneMarking:
      return rgb(228, 226, 215) * (1.0f + 0.05f * value2(x * 20, y * 20, s + 3));
    case Material::kGrass: {
      const float blotch = fbm2(x * 0.35, y * 0.35, s + 4, 3);
      const float blade = value2(x * 23, y * 23, s + 5);
      Eigen::Vector3f c = rgb(68, 118, 38) + blotch * rgb(28, 22, 6);
      return c * (1.0f + 0.22f * blade);
    }
    case Material::kGravel: {
      const float stone = value2(x * 28, y * 28, s + 6);
      const float big = value2(x * 3, y * 3, s + 7);
      return rgb(142, 124, 98) * (1.0f + 0.25f * stone + 0.08f * big);
    }
    case Material::kDitchFloor:
      return rgb(72, 58, 42) * (1.0f + 0.2f * value2(x * 9, y * 9, s + 8));
    case Material::kDitchWall:
      return rgb(112, 88, 62) * (1.0f + 0.2f * value3(x * 8, y * 8, z * 8, s + 9));
    case Material::kBuildingWall: {
      const detail::Primitive& pr = prims_[hit.primitive];
      const Building& b = buildings_[pr.owner_index];
      // Coordinate along the wall face and height above the ground: windows on a 3 m storey grid.
      const double dx = x - pr.cx, dy = y - pr.cy;
      const double lx = pr.cs * dx + pr.sn * dy, ly = -pr.sn * dx + pr.cs * dy;
      const bool long_face = std::abs(std::abs(ly) - pr.hy) < std::abs(std::abs(lx) - pr.hx);
      const double u = long_face ? lx + pr.hx : ly + pr.hy;
      const double span = long_face ? 2 * pr.hx : 2 * pr.hy;
      const double h = z - b.ground_z_m;
      const double fu = std::fmod(u, 2.6), fh = std::fmod(h, 3.0);
      const bool window = h > 0.8 && h < b.height_m() - 0.6 && u > 0.8 && u < span - 0.8 &&
                          fu > 0.7 && fu < 1.9 && fh > 0.9 && fh < 2.2;
      if (window) return rgb(58, 70, 86) * (1.0f + 0.15f * value2(u * 0.7, h * 0.7, s + 10));
      return rgb(b.wall_rgb) * (1.0f + 0.06f * value3(x * 12, y * 12, z * 12, s + 11));
    }
    case Material::kBuildingRoof: {
      const Building& b = buildings_[prims_[hit.primitive].owner_index];
      return rgb(b.roof_rgb) * (1.0f + 0.08f * value2(x * 5, y * 5, s + 12));
    }
    case Material::kTreeTrunk: {
      const detail::Primitive& pr = prims_[hit.primitive];
      const double ang = std::atan2(y - pr.cy, x - pr.cx);
      return rgb(88, 64, 44) * (1.0f + 0.25f * value2(ang * 4, z * 1.5, s + 13));
    }
    case Material::kTreeCrown: {
      const float leaf = value3(x * 7, y * 7, z * 7, s + 14);
      const float clump = value3(x * 1.2, y * 1.2, z * 1.2, s + 15);
      return rgb(46, 92, 32) * (1.0f + 0.3f * leaf + 0.15f * clump);
    }
    case Material::kRock:
      return rgb(124, 120, 114) * (1.0f + 0.18f * value3(x * 6, y * 6, z * 6, s + 16));
    case Material::kCar: {
      const detail::Primitive& pr = prims_[hit.primitive];
      const Car& c = cars_[pr.owner_index];
      // Cabin sides are glass; its roof has the body colour.
      if (pr.owner == detail::Primitive::kCarCabin && hit.normal.z() < 0.7f) return rgb(35, 40, 50);
      return rgb(c.rgb);
    }
  }
  return rgb(255, 0, 255);
}

}  // namespace terramrf::sim
