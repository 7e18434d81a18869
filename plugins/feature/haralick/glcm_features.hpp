#pragma once
// Haralick, Shanmugam & Dinstein (1973), "Textural Features for Image Classification", IEEE SMC-3:
// features of the normalised, symmetric grey-level co-occurrence matrix p(i, j) = P(i, j) / R of
// one offset d, P(i, j) = #{pixel pairs (x, x + d) or (x + d, x) with levels (i, j)}, R = Σ P.
//   f1 angular second moment  ASM = Σ_i Σ_j p(i, j)²
//   f4 sum of squares: variance    = Σ_i Σ_j (i − μ)² p(i, j),  μ = Σ_i Σ_j i p(i, j)
//   f5 inverse difference moment   = Σ_i Σ_j p(i, j) / (1 + (i − j)²)
// Counting fills the ordered histogram H(a, b) of pairs (x, x + d); P = H + Hᵀ is formed only when
// the features are read, so counting is one unconditional increment per pixel position (and one
// store noting the entry, so that reading visits only the entries counted).
#include <cstdint>
#include <vector>

namespace terramrf {

struct GlcmFeatures {
  double asm_ = 0, variance = 0, idm = 0;
  std::size_t pairs = 0;  ///< unordered pixel pairs counted (R = 2 · pairs)
};

/// Co-occurrence counts of one offset over levels 0 .. L−1, plus a "not in the set" level L whose
/// row and column are ignored, so callers can count without branching on membership. Remembers
/// which entries it counted, so reading and clearing cost O(pairs), not O(L²).
class GlcmAccumulator {
 public:
  explicit GlcmAccumulator(int levels = 16) { setLevels(levels); }
  void setLevels(int levels);
  int levels() const { return levels_; }
  /// Level code meaning "pixel not in the set".
  int outside() const { return levels_; }

  /// One ordered pair of levels a, b ∈ [0, L] (L = outside); adds it to H.
  void add(int a, int b) { addRow(&a, &b, 1); }
  /// The ordered pairs (a[x], b[x]), x < n, levels in [0, L].
  template <class Level>
  void addRow(const Level* a, const Level* b, int n) {
    const uint32_t s = uint32_t(stride());
    uint32_t* counts = counts_.data();
    uint32_t* touched = touched_.data();
    std::size_t nt = n_touched_;
    for (int x = 0; x < n; ++x) {
      const uint32_t code = uint32_t(a[x]) * s + uint32_t(b[x]);
      // Written every time, kept only for an entry's first count: no branch per pair.
      touched[nt] = code;
      nt += counts[code]++ == 0;
    }
    n_touched_ = nt;
  }
  /// f1, f4, f5 of the pairs counted since the last reset; resets. pairs == 0 → all zero.
  GlcmFeatures finish();

 private:
  int stride() const { return levels_ + 1; }

  int levels_ = 0;
  std::vector<uint32_t> counts_;   // H, (L+1) × (L+1), row-major: (a, b) at a · (L + 1) + b
  std::vector<uint32_t> touched_;  // entries of counts_ counted since the last finish, each once
  std::size_t n_touched_ = 0;
  std::vector<double> idm_weight_;  // 1 / (1 + (i − j)²) by |i − j|
  std::vector<uint64_t> diag_;      // Σ H_ij over |i − j| = k; zero between finishes
  std::vector<int> diag_touched_;   // the k with diag_[k] > 0
};

}  // namespace terramrf
