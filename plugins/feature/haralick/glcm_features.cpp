#include "glcm_features.hpp"

#include <algorithm>

namespace terramrf {

void GlcmAccumulator::setLevels(int levels) {
  levels_ = levels;
  counts_.assign(std::size_t(levels + 1) * (levels + 1), 0);
  idm_weight_.resize(levels);
  for (int k = 0; k < levels; ++k) idm_weight_[k] = 1.0 / (1.0 + double(k) * k);
}

GlcmFeatures GlcmAccumulator::finish() {
  // With P = H + Hᵀ and n = Σ H (so R = 2n):
  //   Σ P² = Σ_{i,j} (H_ij + H_ji)²,   μ = Σ_i i (row_i + col_i) / 2n,
  //   f4 = Σ_i i² (row_i + col_i) / 2n − μ²,   f5 = Σ_{i,j} H_ij w(|i − j|) / n.
  // Integer sums first (exact, branch-free, vectorisable), doubles only at the end.
  const int L = levels_, s = stride();
  const uint32_t* h = counts_.data();
  uint64_t sum_p2 = 0, n = 0, sum_i = 0, sum_i2 = 0;
  diag_.assign(L, 0);
  for (int i = 0; i < L; ++i) {
    uint64_t row = 0, col = 0;
    for (int j = 0; j < L; ++j) {
      const uint64_t hij = h[i * s + j], hji = h[j * s + i];
      sum_p2 += (hij + hji) * (hij + hji);
      row += hij;
      col += hji;
      diag_[i > j ? i - j : j - i] += hij;
    }
    n += row;
    sum_i += uint64_t(i) * (row + col);
    sum_i2 += uint64_t(i) * i * (row + col);
  }
  double sum_idm = 0;
  for (int k = 0; k < L; ++k) sum_idm += idm_weight_[k] * double(diag_[k]);
  GlcmFeatures f;
  f.pairs = std::size_t(n);
  if (n > 0) {
    const double r = 2.0 * double(n);
    f.asm_ = double(sum_p2) / (r * r);
    const double mu = double(sum_i) / r;
    f.variance = std::max(0.0, double(sum_i2) / r - mu * mu);  // clamp rounding on flat patches
    f.idm = sum_idm / double(n);
  }
  std::fill(counts_.begin(), counts_.end(), 0u);
  return f;
}

}  // namespace terramrf
