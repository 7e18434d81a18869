#pragma once
// A 32-bit integer hash for values that must be pure functions of their inputs (simulated
// textures, per-cell random numbers), where a stateful generator would tie a value to the order
// of the calls.
#include <cstdint>

namespace terramrf {

/// Wellons' "lowbias32": full avalanche for two multiplies; a bijection, so distinct inputs
/// never collide.
inline uint32_t lowbias32(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}

}  // namespace terramrf
