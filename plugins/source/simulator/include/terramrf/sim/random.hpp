#pragma once
// Counter-based randomness: every random number is a pure function of (seed, stream, index), so a
// frame, a ray or a sensor sample is reproducible no matter in which order frames are read.
// std:: distributions are implementation-defined, so the conversions are done here.
#include <cmath>
#include <cstdint>

namespace terramrf::sim {

/// SplitMix64 finaliser: a good 64-bit mixing bijection.
inline uint64_t mix64(uint64_t z) {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

/// Combines keys into one hash (order matters).
inline uint64_t hashKeys(uint64_t a, uint64_t b, uint64_t c = 0, uint64_t d = 0) {
  uint64_t h = mix64(a);
  h = mix64(h ^ b);
  h = mix64(h ^ c);
  return mix64(h ^ d);
}

/// Uniform in [0, 1) from 53 high bits.
inline double toUnit(uint64_t bits) { return double(bits >> 11) * 0x1.0p-53; }

/// Small deterministic generator seeded by a hash key.
class Rng {
 public:
  explicit Rng(uint64_t key) : state_(key) {}
  uint64_t next() {
    state_ += 0x9E3779B97F4A7C15ull;
    return mix64(state_);
  }
  /// Uniform in [0, 1).
  double uniform() { return toUnit(next()); }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Standard normal (Box–Muller; one value per call keeps the sequence order-free).
  double normal() {
    const double u1 = 1.0 - uniform();  // (0, 1]
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  }
  bool chance(double p) { return uniform() < p; }

 private:
  uint64_t state_;
};

/// Purposes of random streams (second hash key), so streams never overlap.
enum class Stream : uint64_t {
  kWorld = 1,
  kLidar = 2,
  kCamera = 3,
  kImu = 4,
  kGps = 5,
  kOdometry = 6,
  kBias = 7,
  kTrajectory = 8,
};

}  // namespace terramrf::sim
