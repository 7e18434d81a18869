#pragma once
// Random numbers of the chromatic Gibbs sampler, one per (sweep, cell), computed from the two
// rather than drawn from a stream: a cell's draw is the same whichever cells are drawn with it and
// in whatever order, so the vector sweep and the one-cell-at-a-time sweep are the same chain, and
// a cell whose draw is certain can skip it without shifting any other cell's.
#include <cstdint>

#include "terramrf/hash.hpp"

namespace terramrf {

/// The two 32-bit keys of one sweep of one seed (SplitMix64 of seed and sweep number).
struct SweepKeys {
  uint32_t k1 = 0, k2 = 0;
  SweepKeys(uint64_t seed, uint64_t sweep) {
    uint64_t z = seed * 0x9e3779b97f4a7c15ull + (sweep + 1) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    k1 = static_cast<uint32_t>(z);
    k2 = static_cast<uint32_t>(z >> 32);
  }
  /// The 32 random bits of `cell` in this sweep: two rounds, so that neither a cell's
  /// neighbours nor its earlier sweeps (inputs a constant apart) give related bits.
  uint32_t bits(uint32_t cell) const { return lowbias32(lowbias32(cell + k1) ^ k2); }
  /// Uniform in [0, 1) with 24 bits (a float's mantissa).
  float uniform(uint32_t cell) const {
    return static_cast<float>(bits(cell) >> 8) * (1.0f / 16777216.0f);
  }
};

}  // namespace terramrf
