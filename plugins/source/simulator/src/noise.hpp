#pragma once
// Lattice value noise: cheap, smooth (C1) and a pure function of position and seed. Used for the
// ground's small-scale roughness (hot path of the terrain marcher) and for textures.
#include <cmath>
#include <cstdint>

#include "terramrf/hash.hpp"

namespace terramrf::sim::noise {

inline uint32_t hash32(uint32_t x) { return lowbias32(x); }

inline float lattice(int32_t ix, int32_t iy, uint32_t seed) {
  const uint32_t h = hash32(uint32_t(ix) * 0x8da6b343U ^ hash32(uint32_t(iy) * 0xd8163841U ^ seed));
  return float(h >> 8) * (2.0f / 16777216.0f) - 1.0f;  // [-1, 1)
}

inline float lattice3(int32_t ix, int32_t iy, int32_t iz, uint32_t seed) {
  return lattice(ix, int32_t(hash32(uint32_t(iy) ^ hash32(uint32_t(iz) + seed))), seed);
}

inline float fade(float t) { return t * t * (3.0f - 2.0f * t); }

/// 2D value noise in [-1, 1] with lattice spacing 1.
inline float value2(double x, double y, uint32_t seed) {
  const double fx = std::floor(x), fy = std::floor(y);
  const int32_t ix = int32_t(fx), iy = int32_t(fy);
  const float tx = fade(float(x - fx)), ty = fade(float(y - fy));
  const float a = lattice(ix, iy, seed), b = lattice(ix + 1, iy, seed);
  const float c = lattice(ix, iy + 1, seed), d = lattice(ix + 1, iy + 1, seed);
  const float ab = a + (b - a) * tx, cd = c + (d - c) * tx;
  return ab + (cd - ab) * ty;
}

/// 3D value noise in [-1, 1] with lattice spacing 1.
inline float value3(double x, double y, double z, uint32_t seed) {
  const double fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const int32_t ix = int32_t(fx), iy = int32_t(fy), iz = int32_t(fz);
  const float tx = fade(float(x - fx)), ty = fade(float(y - fy)), tz = fade(float(z - fz));
  float v[2];
  for (int k = 0; k < 2; ++k) {
    const float a = lattice3(ix, iy, iz + k, seed), b = lattice3(ix + 1, iy, iz + k, seed);
    const float c = lattice3(ix, iy + 1, iz + k, seed), d = lattice3(ix + 1, iy + 1, iz + k, seed);
    const float ab = a + (b - a) * tx, cd = c + (d - c) * tx;
    v[k] = ab + (cd - ab) * ty;
  }
  return v[0] + (v[1] - v[0]) * tz;
}

/// Fractal sum of `octaves` 2D octaves, normalised to [-1, 1].
inline float fbm2(double x, double y, uint32_t seed, int octaves) {
  float sum = 0, amp = 1, norm = 0;
  for (int o = 0; o < octaves; ++o) {
    sum += amp * value2(x, y, seed + 1013u * o);
    norm += amp;
    amp *= 0.5f;
    x *= 2.03;
    y *= 2.03;
  }
  return sum / norm;
}

}  // namespace terramrf::sim::noise
