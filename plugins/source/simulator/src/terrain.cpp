// Road centre line, heightfield, ground materials and the ground-truth queries of World.
#include <algorithm>
#include <cmath>

#include "noise.hpp"
#include "world_internal.hpp"

namespace terramrf::sim {

using detail_terrain::smoothstep;

double World::roadCentreY(double x) const {
  double y = 0;
  for (int k = 0; k < 2; ++k) y += road_amp_[k] * std::sin(road_freq_[k] * x + road_phase_[k]);
  return y;
}

double World::roadCentreSlope(double x) const {
  double s = 0;
  for (int k = 0; k < 2; ++k)
    s += road_amp_[k] * road_freq_[k] * std::cos(road_freq_[k] * x + road_phase_[k]);
  return s;
}

double World::lateralOffset(double x, double y) const {
  const double s = roadCentreSlope(x);
  return (y - roadCentreY(x)) / std::sqrt(1.0 + s * s);
}

double World::naturalHeight(double x, double y) const {
  double h = 0;
  for (const Wave& w : hills_) h += w.amp * std::sin(w.fx * x + w.fy * y + w.phase);
  return h;
}

double World::roadProfile(double x) const {
  // Only the long hills: a road is graded, it does not follow every 20 m undulation (keeps
  // vertical accelerations gentle at driving speed). Its grade stays below roadGradeBound():
  // 14 % with the default 2 m hills (12.2 % at the start of seed 1); sim::Simulation refuses
  // hills whose bound exceeds 20 %.
  const double y = roadCentreY(x);
  double h = 0;
  for (std::size_t k = 0; k < std::min<std::size_t>(2, hills_.size()); ++k)
    h += hills_[k].amp * std::sin(hills_[k].fx * x + hills_[k].fy * y + hills_[k].phase);
  return h;
}

double World::smoothHeight(double x, double y) const {
  const double s = roadCentreSlope(x), inv = 1.0 / std::sqrt(1.0 + s * s);
  const double lat = (y - roadCentreY(x)) * inv;
  // The road's height is taken at the foot of the perpendicular, so a cross-section at right
  // angles to the road is level (no cross slope) even where the road climbs in a bend.
  const double x_foot = x + lat * s * inv;
  const double road_z = roadProfile(x_foot);
  const double d0 = 0.5 * p_.road_width_m + p_.shoulder_m;
  const double blend = smoothstep(d0, d0 + kRoadBlendM, std::abs(lat));
  if (blend <= 0) return road_z;
  return road_z + (naturalHeight(x, y) - road_z) * blend;
}

double World::terrainHeight(double x, double y) const {
  const double lat = lateralFast(x, y);
  return tableHeight(x, y) + roughness(x, y, lat) - ditchDepth(x, lat);
}

Eigen::Vector3d World::terrainNormal(double x, double y, double h) const {
  // One-sided differences from the known height: two evaluations; 5 cm resolves the roughness
  // and the ditch walls.
  constexpr double e = 0.05;
  const double gx = (terrainHeight(x + e, y) - h) / e;
  const double gy = (terrainHeight(x, y + e) - h) / e;
  return Eigen::Vector3d(-gx, -gy, 1.0).normalized();
}

Material World::groundMaterial(double x, double y) const {
  const double lat = lateralFast(x, y);
  bool wall = false;
  if (ditchDepth(x, lat, &wall) > 0) return wall ? Material::kDitchWall : Material::kDitchFloor;
  const double d = std::abs(lat), half = 0.5 * p_.road_width_m;
  if (d < half) {
    // Dashed centre line (3 m on, 6 m off) and solid edge lines, 0.15 m wide.
    const bool centre = d < 0.075 && x - 9.0 * std::floor(x / 9.0) < 3.0;
    const bool edge = d > half - 0.3 && d < half - 0.15;
    return centre || edge ? Material::kLaneMarking : Material::kAsphalt;
  }
  if (d < half + p_.shoulder_m) return Material::kGravel;
  bool yard = false;
  forEachPrimitiveAt(x, y, [&](const detail::Primitive& pr) {
    if (pr.owner != detail::Primitive::kBuilding) return;
    const double dx = x - pr.cx, dy = y - pr.cy;
    const double lx = pr.cs * dx + pr.sn * dy, ly = -pr.sn * dx + pr.cs * dy;
    if (std::abs(lx) < pr.hx + kYardM && std::abs(ly) < pr.hy + kYardM) yard = true;
  });
  if (yard) return Material::kGravel;
  if (noise::fbm2(x / 14.0, y / 14.0, noise_seed_ + 99u, 2) > 0.42f) return Material::kGravel;
  return Material::kGrass;
}

// ---- top surface ------------------------------------------------------------------------------

namespace {
/// Height of a primitive's top surface above (x, y), or -inf if it does not cover the point.
double primitiveTop(const detail::Primitive& pr, double x, double y) {
  using P = detail::Primitive;
  const double dx = x - pr.cx, dy = y - pr.cy;
  switch (pr.type) {
    case P::kBox: {
      const double lx = pr.cs * dx + pr.sn * dy, ly = -pr.sn * dx + pr.cs * dy;
      return std::abs(lx) <= pr.hx && std::abs(ly) <= pr.hy ? pr.z1 : -INFINITY;
    }
    case P::kCylinder:
      return dx * dx + dy * dy <= pr.hx * pr.hx ? pr.z1 : -INFINITY;
    case P::kEllipsoid: {
      const double u = dx * pr.inv_radii.x(), v = dy * pr.inv_radii.y();
      const double q = 1.0 - u * u - v * v;
      return q >= 0 ? pr.cz + std::sqrt(q) / pr.inv_radii.z() : -INFINITY;
    }
  }
  return -INFINITY;
}
}  // namespace

Material World::topMaterial(double x, double y) const {
  double best = -INFINITY;
  Material m = Material::kNone;
  forEachPrimitiveAt(x, y, [&](const detail::Primitive& pr) {
    const double top = primitiveTop(pr, x, y);
    if (top > best) {
      best = top;
      m = pr.owner == detail::Primitive::kBuilding ? Material::kBuildingRoof : pr.material;
    }
  });
  if (m != Material::kNone && best > terrainHeight(x, y)) return m;
  return groundMaterial(x, y);
}

double World::surfaceHeight(double x, double y) const {
  double best = terrainHeight(x, y);
  forEachPrimitiveAt(
      x, y, [&](const detail::Primitive& pr) { best = std::max(best, primitiveTop(pr, x, y)); });
  return best;
}

}  // namespace terramrf::sim
