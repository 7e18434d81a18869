#pragma once
// Label indices on the grid padded by one cell, as ICM, α-expansion's ICM start and block moves,
// and the score layers read them: the pad and the fixed cells hold the sentinel K, whose score
// slot is scratch, so an 8-neighbour loop needs neither bounds nor fixed-cell tests. (The Gibbs
// sampler has its own layout, one plane per colour: plugins/optimiser/gibbs/colour_planes.hpp.)
#include <cstddef>
#include <cstdint>
#include <vector>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "terramrf/energy_model.hpp"

namespace terramrf {

class PaddedLabels {
 public:
  /// Copies `lab` (label indices per cell; fixed cells ignored) into the padded grid.
  void assign(const EnergyModel& em, const std::vector<uint8_t>& lab) {
    rows_ = em.rows;
    cols_ = em.cols;
    stride_ = cols_ + 2;
    data_.assign(std::size_t(rows_ + 2) * stride_, static_cast<uint8_t>(em.numLabels()));
    for (int r = 0; r < rows_; ++r)
      for (int c = 0; c < cols_; ++c) {
        const int i = r * cols_ + c;
        if (!em.fixed[i]) *at(r, c) = lab[i];
      }
  }
  /// Writes the labels of the non-fixed cells back into `lab`.
  void extract(const EnergyModel& em, std::vector<uint8_t>& lab) const {
    for (int r = 0; r < rows_; ++r)
      for (int c = 0; c < cols_; ++c) {
        const int i = r * cols_ + c;
        if (!em.fixed[i]) lab[i] = *at(r, c);
      }
  }
  /// Padded row length (cols + 2): the offset between vertical neighbours.
  int stride() const { return stride_; }
  uint8_t* at(int r, int c) { return &data_[std::size_t(r + 1) * stride_ + c + 1]; }
  const uint8_t* at(int r, int c) const { return &data_[std::size_t(r + 1) * stride_ + c + 1]; }
  std::vector<uint8_t>& data() { return data_; }
  const std::vector<uint8_t>& data() const { return data_; }

 private:
  int rows_ = 0, cols_ = 0, stride_ = 2;
  std::vector<uint8_t> data_;
};

/// Local energies of cell `cell` at padded position `p` (row stride W) for every label k, minus
/// the constant Σ_n w_n: s[k] = unary_k − 2 Σ_{n: l_n = k} w_n (eq. 12 up to a per-cell constant,
/// δ(equal) = −1). s needs K + 1 slots (s[K] is the sentinel's scratch). KK > 0 fixes K at
/// compile time for the hot loops.
template <int KK = 0>
inline void localScores(const EnergyModel& em, const uint8_t* p, std::size_t cell, int W, float* s) {
  const int K = KK > 0 ? KK : em.numLabels();
  const float we = 2.f * em.beta, wd = 2.f * em.beta_diagonal;
  const float* u = &em.unary[cell * K];
#if defined(__SSE2__)
  if constexpr (KK == 3 || KK == 4) {
    // Labels 0..3 in the four lanes: each neighbour subtracts its weight in its label's lane and
    // 0 (exact) in the others, in the same order as below, so the same bits. Scattering into s[]
    // instead chains each neighbour's update through memory when neighbours share a label, as
    // most do; here the lanes' chains run side by side. s gets 4 floats (KK + 1 ≥ 4).
    const __m128i lanes = _mm_setr_epi32(0, 1, 2, 3);
    const __m128 e4 = _mm_set1_ps(we), d4 = _mm_set1_ps(wd);
    __m128 v = _mm_setr_ps(u[0], u[1], u[2], KK == 4 ? u[KK - 1] : 0.f);
    auto sub = [&](uint8_t label, __m128 w) {
      const __m128 hit = _mm_castsi128_ps(_mm_cmpeq_epi32(lanes, _mm_set1_epi32(label)));
      v = _mm_sub_ps(v, _mm_and_ps(hit, w));
    };
    sub(p[-W - 1], d4);
    sub(p[-W], e4);
    sub(p[-W + 1], d4);
    sub(p[-1], e4);
    sub(p[1], e4);
    sub(p[W - 1], d4);
    sub(p[W], e4);
    sub(p[W + 1], d4);
    _mm_storeu_ps(s, v);
    return;
  }
#endif
  for (int k = 0; k < K; ++k) s[k] = u[k];
  s[p[-W - 1]] -= wd;
  s[p[-W]] -= we;
  s[p[-W + 1]] -= wd;
  s[p[-1]] -= we;
  s[p[1]] -= we;
  s[p[W - 1]] -= wd;
  s[p[W]] -= we;
  s[p[W + 1]] -= wd;
}

/// ICM (Besag 1986) on padded labels, in raster order, until a sweep changes nothing or
/// `max_sweeps` sweeps ran; returns the sweeps run and sets `converged`. A cell is re-examined
/// only when a neighbour changed since its last visit (otherwise it would choose the same again)
/// and ties keep the current label, so the labelling equals that of plain sweeps at a fraction
/// of the work after the first sweep. `dirty` is scratch.
int icmSweeps(const EnergyModel& em, PaddedLabels& lab, int max_sweeps, std::vector<uint8_t>& dirty,
              bool& converged);

}  // namespace terramrf
