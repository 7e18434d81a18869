#include "glcm_features.hpp"

#include <algorithm>

namespace terramrf {

void GlcmAccumulator::setLevels(int levels) {
  levels_ = levels;
  const std::size_t entries = std::size_t(levels + 1) * (levels + 1);
  counts_.assign(entries, 0);
  // One slot more than there are entries: addRow writes the slot past the last touched one
  // whether or not the entry is new.
  touched_.assign(entries + 1, 0);
  n_touched_ = 0;
  idm_weight_.resize(levels);
  for (int k = 0; k < levels; ++k) idm_weight_[k] = 1.0 / (1.0 + double(k) * k);
  diag_.assign(levels, 0);
  diag_touched_.clear();
  diag_touched_.reserve(levels);
}

GlcmFeatures GlcmAccumulator::finish() {
  // With P = H + Hᵀ and n = Σ H (so R = 2n):
  //   Σ P² = Σ_{i,j} (H_ij + H_ji)²,   μ = Σ_{i,j} H_ij (i + j) / 2n,
  //   f4 = Σ_{i,j} H_ij (i² + j²) / 2n − μ²,   f5 = Σ_k w(k) Σ_{|i − j| = k} H_ij / n.
  // Only the entries counted since the last finish are visited (a cell has a few hundred pairs at
  // most, the table (L + 1)² entries: 66 049 at L = 256). Integer sums are exact in any order;
  // the one floating-point sum, f5's over k, runs in increasing k as a scan of the whole table
  // would (its zero terms add nothing), so the features are the same to the bit.
  const int L = levels_, s = stride();
  const uint32_t* h = counts_.data();
  uint64_t sum_p2 = 0, n = 0, sum_i = 0, sum_i2 = 0;
  for (std::size_t t = 0; t < n_touched_; ++t) {
    const uint32_t code = touched_[t];
    const int i = int(code) / s, j = int(code) - i * s;
    if (i == L || j == L) continue;  // a pixel outside the set
    const uint64_t hij = h[code];
    n += hij;
    sum_i += hij * uint64_t(i + j);
    sum_i2 += hij * uint64_t(i * i + j * j);
    const int k = i > j ? i - j : j - i;
    if (diag_[k] == 0) diag_touched_.push_back(k);
    diag_[k] += hij;
    // (H_ij + H_ji)² once for each of (i, j) and (j, i): from the entry with i < j, or from
    // (i, j) alone when (j, i) was never counted.
    if (i == j) {
      sum_p2 += 4 * hij * hij;
    } else {
      const uint64_t hji = h[std::size_t(j) * s + i];
      if (i < j)
        sum_p2 += 2 * (hij + hji) * (hij + hji);
      else if (hji == 0)
        sum_p2 += 2 * hij * hij;
    }
  }
  std::sort(diag_touched_.begin(), diag_touched_.end());
  double sum_idm = 0;
  for (const int k : diag_touched_) {
    sum_idm += idm_weight_[k] * double(diag_[k]);
    diag_[k] = 0;
  }
  diag_touched_.clear();
  GlcmFeatures f;
  f.pairs = std::size_t(n);
  if (n > 0) {
    const double r = 2.0 * double(n);
    f.asm_ = double(sum_p2) / (r * r);
    const double mu = double(sum_i) / r;
    f.variance = std::max(0.0, double(sum_i2) / r - mu * mu);  // clamp rounding on flat patches
    f.idm = sum_idm / double(n);
  }
  for (std::size_t t = 0; t < n_touched_; ++t) counts_[touched_[t]] = 0;
  n_touched_ = 0;
  return f;
}

}  // namespace terramrf
