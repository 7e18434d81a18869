#include "colour_sweep.hpp"

#include <algorithm>
#include <array>
#include <cstring>

#include "terramrf/simd.hpp"

namespace terramrf {
namespace {

// Per cell, both versions compute, in this order:
//   s_k = u_k − (n_k·2β + d_k·2β_d)   n_k, d_k: edge and corner neighbours labelled k
//   m = min_k s_k, a = its first index;   x_k = (s_k − m) / T;   q_k = e^{−x_k} (NegExp)
//   Z = q_0 + … + q_{K−1};   u = U·Z, U uniform of (sweep, cell);   pick = first k with
//   u − q_0 − … − q_k < 0, else K − 1;   sums_k += q_k · (1/Z)
// s_k is eq. 12's local energy less Σ_n w_n, the same for every k, which cancels in the
// conditional. When every x_k but x_a is beyond NegExp::kMax (q = 1 at a, 0 elsewhere) the draw is
// certain: pick = a, whatever U is, and the one-at-a-time version skips the exponentials.

/// What a kernel reads of plane p: its labels, its neighbours' offsets, and per label its
/// unaries and (when averaging) its sums.
template <int kMax>
struct PlaneRows {
  std::array<std::ptrdiff_t, 8> off;
  uint8_t* lab;
  const float* u[kMax];
  float* acc[kMax];
  PlaneRows(ColourPlanes& cp, int p, float* sums) : off(cp.neighbourOffsets(p)), lab(cp.plane(p)) {
    for (int k = 0; k < cp.labels(); ++k) {
      u[k] = cp.unary(p, k);
      acc[k] = sums ? sums + (std::size_t(p) * cp.labels() + k) * cp.planeSize() : nullptr;
    }
  }
};

template <int KK>
int sweepScalar(ColourPlanes& cp, const ColourSweepParams& sp, double& energy) {
  const int K = KK > 0 ? KK : cp.labels();
  constexpr int kMax = KK > 0 ? KK : 255;
  uint8_t* all = cp.data().data();
  float s[kMax], x[kMax], q[kMax];
  int n_edge[kMax + 1], n_diag[kMax + 1];
  int changed = 0;
  for (int p = 0; p < 4; ++p) {
    const PlaneRows<kMax> pr(cp, p, sp.sums);
    for (int i = 0; i < cp.subRows(); ++i) {
      const uint32_t row_cell = uint32_t((2 * i + (p >> 1)) * cp.gridCols() + (p & 1));
      uint8_t* settled = cp.settled(p, i);
      // By groups of the vector sweep's lanes, so that both settle and skip the same groups.
      for (int j0 = 0, g = 0; j0 < cp.subCols(); j0 += ColourPlanes::kLanes, ++g) {
        const int j_end = std::min(j0 + ColourPlanes::kLanes, cp.subCols());
        if (sp.skip_settled && settled[g]) {  // certain draws of the current labels
          if (sp.sums)
            for (int j = j0; j < j_end; ++j) {
              const std::size_t idx = cp.index(i, j);
              if (pr.lab[idx] != K) pr.acc[pr.lab[idx]][idx] += 1.f;
            }
          continue;
        }
        unsigned moved = 0;  // bit l: lane l changed label
        bool any_active = false, any_uncertain = false;
        for (int j = j0; j < j_end; ++j) {
          const std::size_t idx = cp.index(i, j);
          const int cur = pr.lab[idx];
          if (cur == K) continue;  // fixed, or beyond the grid
          any_active = true;
          if constexpr (KK > 0 && KK < 8) {
            // One byte counter per label (and the sentinel's) in a word: no stores to reload.
            uint64_t e = 0, d = 0;
            for (int n = 0; n < 4; ++n) e += uint64_t(1) << (8 * all[pr.off[n] + idx]);
            for (int n = 4; n < 8; ++n) d += uint64_t(1) << (8 * all[pr.off[n] + idx]);
            for (int k = 0; k < K; ++k) {
              n_edge[k] = int(e >> (8 * k) & 0xff);
              n_diag[k] = int(d >> (8 * k) & 0xff);
            }
          } else {
            for (int k = 0; k <= K; ++k) n_edge[k] = n_diag[k] = 0;
            for (int n = 0; n < 4; ++n) ++n_edge[all[pr.off[n] + idx]];
            for (int n = 4; n < 8; ++n) ++n_diag[all[pr.off[n] + idx]];
          }
          int arg = 0;
          for (int k = 0; k < K; ++k) {
            s[k] = pr.u[k][idx] - (float(n_edge[k]) * sp.we + float(n_diag[k]) * sp.wd);
            if (s[k] < s[arg]) arg = k;
          }
          bool certain = true;
          for (int k = 0; k < K; ++k) {
            x[k] = (s[k] - s[arg]) * sp.inv_t;
            certain = certain && (k == arg || NegExp::zero(x[k]));
          }
          int pick = arg;
          float inv_z = 1.f;
          if (!certain) {
            any_uncertain = true;
            float z = 0.f;
            for (int k = 0; k < K; ++k) z += q[k] = NegExp::eval(x[k]);
            float v = sp.keys.uniform(row_cell + 2 * uint32_t(j)) * z;
            pick = K - 1;
            for (int k = 0; k < K - 1; ++k)
              if ((v -= q[k]) < 0.f) {
                pick = k;
                break;
              }
            inv_z = 1.f / z;
          }
          if (pick != cur) {
            energy += double(s[pick]) - double(s[cur]);
            pr.lab[idx] = static_cast<uint8_t>(pick);
            ++changed;
            moved |= 1u << (j - j0);
          }
          if (sp.sums) {
            if (certain) {
              pr.acc[arg][idx] += 1.f;
            } else {
              for (int k = 0; k < K; ++k) pr.acc[k][idx] += q[k] * inv_z;
            }
          }
        }
        if (moved != 0)
          cp.unsettleNeighbours(p, i, g, moved);
        else if (any_active && !any_uncertain)
          settled[g] = 1;
      }
    }
  }
  return changed;
}

#if defined(TERRAMRF_SIMD_DISPATCH)
#pragma GCC push_options
#pragma GCC target("avx2")

inline __m256i loadLabels8(const uint8_t* p) {
  return _mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p)));
}

inline void storeLabels8(uint8_t* p, __m256i v) {
  const __m256i w = _mm256_packus_epi16(_mm256_packus_epi32(v, v), _mm256_setzero_si256());
  const uint32_t lo = uint32_t(_mm_cvtsi128_si32(_mm256_castsi256_si128(w)));
  const uint32_t hi = uint32_t(_mm_cvtsi128_si32(_mm256_extracti128_si256(w, 1)));
  const uint64_t both = uint64_t(lo) | uint64_t(hi) << 32;
  std::memcpy(p, &both, 8);
}

/// lowbias32 for eight values.
inline __m256i lowbias8(__m256i x) {
  x = _mm256_xor_si256(x, _mm256_srli_epi32(x, 16));
  x = _mm256_mullo_epi32(x, _mm256_set1_epi32(int(0x7feb352dU)));
  x = _mm256_xor_si256(x, _mm256_srli_epi32(x, 15));
  x = _mm256_mullo_epi32(x, _mm256_set1_epi32(int(0x846ca68bU)));
  return _mm256_xor_si256(x, _mm256_srli_epi32(x, 16));
}

/// SweepKeys::uniform for eight cells.
inline __m256 uniform8(const SweepKeys& keys, __m256i cells) {
  const __m256i h =
      lowbias8(_mm256_xor_si256(lowbias8(_mm256_add_epi32(cells, _mm256_set1_epi32(int(keys.k1)))),
                                _mm256_set1_epi32(int(keys.k2))));
  return _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_srli_epi32(h, 8)),
                       _mm256_set1_ps(1.0f / 16777216.0f));
}

/// NegExp::eval for eight exponents, operation by operation.
inline __m256 negExp8(__m256 x) {
  const __m256 lim = _mm256_set1_ps(NegExp::kMax);
  const __m256 in = _mm256_cmp_ps(x, lim, _CMP_LT_OQ);  // false for NaN, as NegExp::zero
  // Beyond kMax the lane is masked to 0; min keeps its exponent bits in range meanwhile.
  const __m256 y = _mm256_mul_ps(_mm256_min_ps(x, lim), _mm256_set1_ps(NegExp::kLog2e));
  const __m256i n = _mm256_cvttps_epi32(y);
  const __m256 f = _mm256_sub_ps(y, _mm256_cvtepi32_ps(n));
  __m256 p = _mm256_set1_ps(NegExp::kC[5]);
  for (int c = 4; c >= 0; --c)
    p = _mm256_add_ps(_mm256_mul_ps(p, f), _mm256_set1_ps(NegExp::kC[c]));
  const __m256 scale =
      _mm256_castsi256_ps(_mm256_slli_epi32(_mm256_sub_epi32(_mm256_set1_epi32(127), n), 23));
  return _mm256_and_ps(in, _mm256_mul_ps(p, scale));
}

template <int KK>
int sweepAvx2(ColourPlanes& cp, const ColourSweepParams& sp, double& energy) {
  const int K = KK > 0 ? KK : cp.labels();
  constexpr int kMax = KK > 0 ? KK : 255;
  const uint8_t* all = cp.data().data();
  const __m256 we = _mm256_set1_ps(sp.we), wd = _mm256_set1_ps(sp.wd);
  const __m256 inv_t = _mm256_set1_ps(sp.inv_t), lim = _mm256_set1_ps(NegExp::kMax);
  const __m256 one = _mm256_set1_ps(1.f), zero = _mm256_setzero_ps();
  const __m256i sentinel = _mm256_set1_epi32(K),
                lane_cells = _mm256_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14);
  __m256 s[kMax], q[kMax];
  int changed = 0;
  for (int p = 0; p < 4; ++p) {
    const PlaneRows<kMax> pr(cp, p, sp.sums);
    for (int i = 0; i < cp.subRows(); ++i) {
      const int row_cell = (2 * i + (p >> 1)) * cp.gridCols() + (p & 1);
      uint8_t* settled = cp.settled(p, i);
      for (int j = 0, g = 0; j < cp.subCols(); j += ColourPlanes::kLanes, ++g) {
        const std::size_t idx = cp.index(i, j);
        const __m256i cur = loadLabels8(pr.lab + idx);
        const __m256 active = _mm256_castsi256_ps(
            _mm256_xor_si256(_mm256_cmpeq_epi32(cur, sentinel), _mm256_set1_epi32(-1)));
        const int active_bits = _mm256_movemask_ps(active);
        if (active_bits == 0) continue;
        // Certain draws of the current labels: only their conditionals count.
        if (sp.skip_settled && settled[g]) {
          if (sp.sums)
            for (int k = 0; k < K; ++k) {
              const __m256 hit = _mm256_castsi256_ps(_mm256_cmpeq_epi32(cur, _mm256_set1_epi32(k)));
              _mm256_storeu_ps(pr.acc[k] + idx, _mm256_add_ps(_mm256_loadu_ps(pr.acc[k] + idx),
                                                              _mm256_and_ps(hit, one)));
            }
          continue;
        }
        __m256i nb[8];
        for (int n = 0; n < 8; ++n) nb[n] = loadLabels8(all + pr.off[n] + idx);
        // Counts as sums of −1 (equal-compare masks): u + (−n·2β + −d·2β_d) is the same float
        // as u − (n·2β + d·2β_d), rounding being symmetric.
        __m256 m = zero;
        __m256i arg = _mm256_setzero_si256();
        for (int k = 0; k < K; ++k) {
          const __m256i kk = _mm256_set1_epi32(k);
          const __m256i ne = _mm256_add_epi32(
              _mm256_add_epi32(_mm256_cmpeq_epi32(nb[0], kk), _mm256_cmpeq_epi32(nb[1], kk)),
              _mm256_add_epi32(_mm256_cmpeq_epi32(nb[2], kk), _mm256_cmpeq_epi32(nb[3], kk)));
          const __m256i nd = _mm256_add_epi32(
              _mm256_add_epi32(_mm256_cmpeq_epi32(nb[4], kk), _mm256_cmpeq_epi32(nb[5], kk)),
              _mm256_add_epi32(_mm256_cmpeq_epi32(nb[6], kk), _mm256_cmpeq_epi32(nb[7], kk)));
          s[k] = _mm256_add_ps(_mm256_loadu_ps(pr.u[k] + idx),
                               _mm256_add_ps(_mm256_mul_ps(_mm256_cvtepi32_ps(ne), we),
                                             _mm256_mul_ps(_mm256_cvtepi32_ps(nd), wd)));
          if (k == 0) {
            m = s[0];
          } else {
            const __m256 lower = _mm256_cmp_ps(s[k], m, _CMP_LT_OQ);
            m = _mm256_blendv_ps(m, s[k], lower);
            arg = _mm256_blendv_epi8(arg, kk, _mm256_castps_si256(lower));
          }
        }
        // Lanes where some label other than the least has a weight NegExp does not give as 0.
        __m256i within = _mm256_setzero_si256();
        for (int k = 0; k < K; ++k) {
          q[k] = _mm256_mul_ps(_mm256_sub_ps(s[k], m), inv_t);  // x_k until the exponential
          within =
              _mm256_sub_epi32(within, _mm256_castps_si256(_mm256_cmp_ps(q[k], lim, _CMP_LT_OQ)));
        }
        const __m256 uncertain = _mm256_and_ps(
            active, _mm256_castsi256_ps(_mm256_cmpgt_epi32(within, _mm256_set1_epi32(1))));
        __m256i pick = arg;
        __m256 inv_z = one;
        if (_mm256_movemask_ps(uncertain) != 0) {
          __m256 z = zero;
          for (int k = 0; k < K; ++k) z = _mm256_add_ps(z, q[k] = negExp8(q[k]));
          const __m256i cells = _mm256_add_epi32(_mm256_set1_epi32(row_cell + 2 * j), lane_cells);
          __m256 v = _mm256_mul_ps(uniform8(sp.keys, cells), z);
          pick = _mm256_set1_epi32(K - 1);
          __m256 found = zero;
          for (int k = 0; k < K - 1; ++k) {
            v = _mm256_sub_ps(v, q[k]);
            const __m256 first = _mm256_andnot_ps(found, _mm256_cmp_ps(v, zero, _CMP_LT_OQ));
            pick = _mm256_blendv_epi8(pick, _mm256_set1_epi32(k), _mm256_castps_si256(first));
            found = _mm256_or_ps(found, first);
          }
          inv_z = _mm256_div_ps(one, z);
        } else {
          for (int k = 0; k < K; ++k)
            q[k] = _mm256_and_ps(
                one, _mm256_castsi256_ps(_mm256_cmpeq_epi32(arg, _mm256_set1_epi32(k))));
        }
        const __m256i moved =
            _mm256_andnot_si256(_mm256_cmpeq_epi32(pick, cur), _mm256_castps_si256(active));
        const int moved_bits = _mm256_movemask_ps(_mm256_castsi256_ps(moved));
        if (moved_bits != 0) {
          __m256 s_cur = s[0], s_pick = s[0];
          for (int k = 1; k < K; ++k) {
            const __m256i kk = _mm256_set1_epi32(k);
            s_cur = _mm256_blendv_ps(s_cur, s[k], _mm256_castsi256_ps(_mm256_cmpeq_epi32(cur, kk)));
            s_pick =
                _mm256_blendv_ps(s_pick, s[k], _mm256_castsi256_ps(_mm256_cmpeq_epi32(pick, kk)));
          }
          alignas(32) float sc[8], sk[8];
          _mm256_store_ps(sc, s_cur);
          _mm256_store_ps(sk, s_pick);
          for (int l = 0; l < 8; ++l)
            if (moved_bits >> l & 1) energy += double(sk[l]) - double(sc[l]);
          changed += __builtin_popcount(unsigned(moved_bits));
          storeLabels8(pr.lab + idx, _mm256_blendv_epi8(cur, pick, moved));
          cp.unsettleNeighbours(p, i, g, unsigned(moved_bits));
        } else if (_mm256_movemask_ps(uncertain) == 0) {
          settled[g] = 1;
        }
        if (sp.sums) {
          for (int k = 0; k < K; ++k) {
            const __m256 add = _mm256_and_ps(active, _mm256_mul_ps(q[k], inv_z));
            _mm256_storeu_ps(pr.acc[k] + idx, _mm256_add_ps(_mm256_loadu_ps(pr.acc[k] + idx), add));
          }
        }
      }
    }
  }
  return changed;
}

#pragma GCC pop_options
#endif

template <int KK>
int sweepK(ColourPlanes& cp, const ColourSweepParams& sp, double& energy) {
#if defined(TERRAMRF_SIMD_DISPATCH)
  if (sp.avx2) return sweepAvx2<KK>(cp, sp, energy);
#endif
  return sweepScalar<KK>(cp, sp, energy);
}

}  // namespace

int colourSweep(ColourPlanes& cp, const ColourSweepParams& sp, double& energy) {
  cp.sweepAt(sp.inv_t);
  // The usual label counts at compile time, so that the K scores stay in registers.
  switch (cp.labels()) {
    case 2:
      return sweepK<2>(cp, sp, energy);
    case 3:
      return sweepK<3>(cp, sp, energy);
    case 4:
      return sweepK<4>(cp, sp, energy);
    case 5:
      return sweepK<5>(cp, sp, energy);
    case 6:
      return sweepK<6>(cp, sp, energy);
    default:
      return sweepK<0>(cp, sp, energy);
  }
}

}  // namespace terramrf
