#pragma once
// Inline helpers shared by the World implementation files (not part of the public API).
#include <algorithm>
#include <cmath>

#include "noise.hpp"
#include "terramrf/sim/world.hpp"

namespace terramrf::sim {

/// Width of the smooth transition from the flat road cross-section to the natural terrain [m].
inline constexpr double kRoadBlendM = 16.0;
/// Gravel yard around buildings [m].
inline constexpr double kYardM = 3.0;
/// Horizontal width of a ditch wall [m]: 1 m deep over 0.25 m is a ~76° wall.
inline constexpr double kDitchWallM = 0.25;
/// Table cells per side of a coarse terrain block (4 m with 0.5 m cells).
inline constexpr int kBlockCells = 8;
/// Side of the roughness-noise lattice table (power of two; the pattern repeats after this many
/// lattice steps, 154 m / 51 m for the two octaves — invisible in a few-cm noise).
inline constexpr int kRoughLattice = 256;

namespace detail_terrain {
inline double smoothstep(double e0, double e1, double x) {
  const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}
}  // namespace detail_terrain

// ---- hot path of the terrain marcher (inline) ----

// Perpendicular distance ≈ vertical distance · cos(heading); exact enough for bends of radius
// ≫ the distance, and the only thing that matters is that it is smooth and consistent.
inline double World::lateralFast(double x, double y) const {
  const double f = std::clamp((x - cl_x0_) * (1.0 / cl_dx_), 0.0, double(cl_y_.size() - 2));
  const int i = int(f);
  const double a = f - i;
  const double cy = cl_y_[i] + a * (cl_y_[i + 1] - cl_y_[i]);
  const double inv = cl_inv_norm_[i] + a * (cl_inv_norm_[i + 1] - cl_inv_norm_[i]);
  return (y - cy) * inv;
}

inline double World::tableHeight(double x, double y) const {
  const double fx = std::clamp((x - tb_x0_) * tb_inv_cell_, 0.0, tb_fx_max_);
  const double fy = std::clamp((y - tb_y0_) * tb_inv_cell_, 0.0, tb_fy_max_);
  const int ix = int(fx), iy = int(fy);
  const float ax = float(fx - ix), ay = float(fy - iy);
  const float* r0 = &tb_h_[std::size_t(iy) * tb_nx_ + ix];
  const float* r1 = r0 + tb_nx_;
  const float a = r0[0] + (r0[1] - r0[0]) * ax;
  const float b = r1[0] + (r1[1] - r1[0]) * ax;
  return a + (b - a) * ay;
}

inline float World::roughNoise(double x, double y) const {
  // Two octaves of value noise (0.6 m and 0.2 m lattice) from the lattice table; |n| <= 1.
  auto octave = [&](double u, double v, int64_t row_offset) {
    constexpr int64_t kMask = kRoughLattice - 1;
    const double fu = std::floor(u), fv = std::floor(v);
    const int64_t iu = int64_t(fu) & kMask, iu1 = (iu + 1) & kMask;
    const int64_t iv = (int64_t(fv) + row_offset) & kMask, iv1 = (iv + 1) & kMask;
    const float tu = noise::fade(float(u - fu)), tv = noise::fade(float(v - fv));
    const float* r0 = rough_lattice_.data() + iv * kRoughLattice;
    const float* r1 = rough_lattice_.data() + iv1 * kRoughLattice;
    const float ab = r0[iu] + (r0[iu1] - r0[iu]) * tu, ce = r1[iu] + (r1[iu1] - r1[iu]) * tu;
    return ab + (ce - ab) * tv;
  };
  return 0.65f * octave(x * (1 / 0.6), y * (1 / 0.6), 0) +
         0.35f * octave(x * (1 / 0.2), y * (1 / 0.2), kRoughLattice / 2);
}

inline double World::roughness(double x, double y, double lateral) const {
  const double half = 0.5 * p_.road_width_m;
  const double d = std::abs(lateral);
  if (d <= half || p_.rough_noise_m <= 0) return 0.0;
  // Gravel shoulder is a bit smoother than grass; ramps avoid a step at the asphalt edge.
  const double w = d < half + p_.shoulder_m
                       ? 0.4 * detail_terrain::smoothstep(half, half + 0.2, d)
                       : 0.4 + 0.6 * detail_terrain::smoothstep(half + p_.shoulder_m,
                                                                half + p_.shoulder_m + 0.5, d);
  return p_.rough_noise_m * w * roughNoise(x, y);
}

inline double World::ditchDepth(double x, double lateral, bool* wall) const {
  const double fx = x - cl_x0_;
  if (!(fx >= 0 && fx < double(ditch_at_.size()))) return 0.0;
  const int k = ditch_at_[std::size_t(fx)];
  if (k < 0) return 0.0;
  const Ditch& dt = ditches_[k];
  if (x <= dt.x_begin_m || x >= dt.x_end_m) return 0.0;
  const double e = std::abs(lateral - dt.offset_m);
  if (e >= dt.half_width_m) return 0.0;
  const double across =
      std::min(1.0, (dt.half_width_m - e) / (dt.half_width_m - dt.floor_half_width_m));
  const double along =
      std::min({1.0, (x - dt.x_begin_m) / kDitchWallM, (dt.x_end_m - x) / kDitchWallM});
  const double f = std::min(across, along);
  if (wall) *wall = f < 1.0;
  return dt.depth_m * f;
}

template <class F>
void World::forEachPrimitiveAt(double x, double y, F&& f) const {
  if (cg_nx_ == 0) return;
  const double fx = (x - cg_x0_) / cg_cell_, fy = (y - cg_y0_) / cg_cell_;
  if (!(fx >= 0 && fy >= 0 && fx < cg_nx_ && fy < cg_ny_)) return;
  const std::size_t c = std::size_t(int(fy)) * cg_nx_ + int(fx);
  for (uint32_t k = cg_offsets_[c]; k < cg_offsets_[c + 1]; ++k) f(prims_[cg_items_[k]]);
}

}  // namespace terramrf::sim
