#pragma once
// A bounded, deterministic sample of a stream of records (one cell's feature values each), for the
// estimates that need the values themselves (robust estimates, mixtures): a long training run
// kept every cell, 170 KB per SemanticKITTI frame without bound.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace terramrf {

/// Reservoir sampling (Vitter's algorithm R): every record until `cap` are held, then record n
/// (counting from 0) replaces a held one with probability cap / (n + 1), so the records held are a
/// uniform sample of the whole stream. The choices come from a hash of n, not from a generator's
/// state: the same stream gives the same sample on every run. (Taking every 2^k-th record instead
/// aliases with the grid's raster order: the same cells of every frame.)
class ReservoirSample {
 public:
  explicit ReservoirSample(std::size_t width = 1, std::size_t cap = std::size_t(1) << 20)
      : width_(width), cap_(std::max<std::size_t>(cap, 1)) {}

  void push(const float* record) {
    const uint64_t n = seen_++;
    if (n < cap_) {
      values_.insert(values_.end(), record, record + width_);
      return;
    }
    const uint64_t j = mix(n) % (n + 1);
    if (j < cap_) std::copy_n(record, width_, &values_[j * width_]);
  }
  void push(float v) { push(&v); }

  /// The records held, `width` values each.
  std::vector<float>& values() { return values_; }
  const std::vector<float>& values() const { return values_; }
  /// Records held, and records seen.
  std::size_t size() const { return values_.size() / width_; }
  uint64_t seen() const { return seen_; }
  bool thinned() const { return seen_ > cap_; }

 private:
  /// SplitMix64's finaliser: consecutive n give unrelated 64-bit values.
  static uint64_t mix(uint64_t z) {
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }

  std::size_t width_, cap_;
  std::vector<float> values_;
  uint64_t seen_ = 0;
};

}  // namespace terramrf
