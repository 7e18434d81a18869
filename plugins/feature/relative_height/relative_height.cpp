// Relative height: a cell's lowest point minus the median lowest point of the cells around it.
//
// Why: height difference and eq. 1 only see inside a cell, so the flat floor of a ditch or a pit
// (a negative obstacle, a limitation paper 000 names) looks like road. Against its surroundings
// the floor sits clearly below the local ground; raised flat tops (a low wall, a car roof seen
// alone in a cell) sit above it. Units: metres, negative = below the surroundings.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "terramrf/plugin.hpp"
#include "terramrf/simd.hpp"

namespace terramrf {

#define TERRAMRF_RANK_WALK_NS sse2
#define TERRAMRF_RANK_WALK_LANES 4
#include "rank_walk.inc"
#undef TERRAMRF_RANK_WALK_NS
#undef TERRAMRF_RANK_WALK_LANES
#if defined(TERRAMRF_SIMD_DISPATCH)
#pragma GCC push_options
#pragma GCC target("avx2")
#define TERRAMRF_RANK_WALK_NS avx2
#define TERRAMRF_RANK_WALK_LANES 8
#include "rank_walk.inc"
#undef TERRAMRF_RANK_WALK_NS
#undef TERRAMRF_RANK_WALK_LANES
#pragma GCC pop_options
#endif

class RelativeHeight final : public Stage {
 public:
  void declare(ParamDecl& d) override {
    d.add("layer", layer_, "name of the output layer: lowest point − local median of lowest points [m]");
    d.add("radius_cells", radius_, "half-width of the square neighbourhood").unit("cells").range(1, 20);
    d.add("quantile", quantile_,
          "which quantile of the neighbours' lowest points is the reference: 0.5 = median; lower "
          "values keep the foot of a hedge or car, whose neighbours' lowest points are raised by "
          "the object, near 0")
        .unit("1")
        .range(0, 1);
    d.add("min_neighbours", min_neighbours_, "cells with fewer neighbours holding points get NaN")
        .unit("cells").range(1, 1000);
  }
  std::vector<std::string> reads() const override { return {artefacts::kPoints}; }
  std::vector<std::string> writes() const override { return {layer_}; }

  void process(FrameContext& ctx) override {
    TerrainGrid& g = *ctx.grid;
    const std::vector<float>& zmin = g.zRange(ctx.frame->points).min;
    Layer& out = g.add(layer_);
    const int R = g.rows(), C = g.cols();
    // The median of up to (2r+1)² − 1 values per cell by rank counting (rankSelect): counts of
    // smaller and not larger values vectorise, where a selection's comparisons are branches the
    // CPU cannot predict (nth_element 1.59 → 0.62 ms on KITTI object 000000, radius 3).
    //
    // The window is not compacted: it is copied row by row from the lowest points bordered by
    // `radius` cells, with +inf for cells without points, beyond the grid and the centre. +inf
    // is never a candidate inside rankSelect's (lo, hi) and never counted as smaller or not
    // larger than a finite value, so the result is that of the compacted neighbours, whose
    // count n comes from a summed-area table. Rows are padded to whole vectors with +inf.
    constexpr float kInf = std::numeric_limits<float>::infinity();
    const int rad = radius_, side = 2 * rad + 1, stride = (side + 3) / 4 * 4;
    const int BC = C + 2 * rad;                                      // bordered row length
    bordered_.assign(std::size_t(R + 2 * rad) * BC + stride, kInf);  // + stride: row overrun
    valid_.assign(std::size_t(R + 1) * (C + 1), 0);
    for (int r = 0; r < R; ++r)
      for (int c = 0; c < C; ++c) {
        const float z = zmin[r * C + c];
        if (!std::isnan(z)) bordered_[(r + rad) * BC + c + rad] = z;
        valid_[(r + 1) * (C + 1) + c + 1] = !std::isnan(z) + valid_[(r + 1) * (C + 1) + c] +
                                            valid_[r * (C + 1) + c + 1] - valid_[r * (C + 1) + c];
      }
    const int padded = side * stride;
    ref_.assign(g.cells(), std::numeric_limits<float>::quiet_NaN());
    // + 3: room to align; the walk's AVX2 copy reads whole eight-float vectors, so the window
    // ends in +inf up to the next multiple of 8.
    const int padded8 = (padded + 7) / 8 * 8;
    window_.assign(padded8 + 3, kInf);
    float* win = window_.data();
    while (reinterpret_cast<std::uintptr_t>(win) % 16) ++win;
#if defined(TERRAMRF_SIMD_DISPATCH)
    const bool wide = useAvx2();
#else
    const bool wide = false;
#endif
    auto walk = [&](int k, float guess, float& result) {
#if defined(TERRAMRF_SIMD_DISPATCH)
      if (wide) return avx2::rankWalk(win, padded8, k, guess, result);
#endif
      return sse2::rankWalk(win, padded, k, guess, result);
    };
    // keep_[row kind][q]: all ones where a row's value q is in the window; kind 1 = centre row.
    keep_.assign(2 * stride, 0);
    for (int q = 0; q < side; ++q) keep_[q] = keep_[stride + q] = ~0u;
    keep_[stride + rad] = 0;
    for (int r = 0; r < R; ++r) {
      for (int c = 0; c < C; ++c) {
        const float z = zmin[r * C + c];
        if (std::isnan(z)) continue;
        const int r0 = std::max(0, r - rad), r1 = std::min(R - 1, r + rad);
        const int c0 = std::max(0, c - rad), c1 = std::min(C - 1, c + rad);
        const int n = valid_[(r1 + 1) * (C + 1) + c1 + 1] - valid_[r0 * (C + 1) + c1 + 1] -
                      valid_[(r1 + 1) * (C + 1) + c0] + valid_[r0 * (C + 1) + c0] - 1;  // − centre
        if (n < min_neighbours_) continue;
        for (int w = 0; w < side; ++w) {
          const float* src = &bordered_[(r + w) * BC + c];
          const uint32_t* keep = &keep_[w == rad ? stride : 0];
          float* dst = win + w * stride;
#if defined(__SSE2__)
          // Whole-vector stores: rankSelect's vector loads of single-float stores would stall.
          for (int q = 0; q < stride; q += 4) {
            const __m128 m = _mm_loadu_ps(reinterpret_cast<const float*>(keep + q));
            _mm_store_ps(dst + q, _mm_or_ps(_mm_and_ps(m, _mm_loadu_ps(src + q)),
                                            _mm_andnot_ps(m, _mm_set1_ps(kInf))));
          }
#else
          for (int q = 0; q < stride; ++q) dst[q] = keep[q] ? src[q] : kInf;
#endif
        }
        const int k = std::min(n - 1, static_cast<int>(quantile_ * n));
        float ref;
#if defined(__SSE2__)
        // Neighbouring windows share most values, so the reference of the cell to the left (or
        // above) is a few ranks from this one's: walking from it is cheaper than rankSelect
        // (stage 0.58 → 0.33 ms on KITTI object 000000, radius 3).
        const int guess_at = c > 0 && !std::isnan(ref_[r * C + c - 1])     ? r * C + c - 1
                             : r > 0 && !std::isnan(ref_[(r - 1) * C + c]) ? (r - 1) * C + c
                                                                           : -1;
        if (guess_at < 0 || !walk(k, ref_[guess_at], ref)) ref = rankSelect(win, padded, k);
#else
        ref = rankSelect(win, padded, k);
#endif
        ref_[r * C + c] = ref;
        out[r * C + c] = z - ref;
      }
    }
  }

 private:
  /// The value of rank k (0-based, ascending) among the finite values of v[0..padded), where
  /// the other entries hold +inf and padded is a multiple of 4. A value
  /// whose count of smaller values is ≤ k and of not larger values is > k is it; any other value
  /// evaluated narrows the interval the answer lies in, and values outside that interval are not
  /// counted at all, so only a handful of the n are (as in a quickselect with random pivots).
  static float rankSelect(const float* v, int padded, int k) {
    float lo = -std::numeric_limits<float>::infinity(), hi = std::numeric_limits<float>::infinity();
    // x with `less` values below it and `leq` not above it: the answer, or a new bound.
    auto isRankK = [&](float x, int less, int leq) {
      if (less > k) {
        hi = x;
      } else if (leq <= k) {
        lo = x;
      } else {
        return true;
      }
      return false;
    };
#if defined(__SSE2__)
    // The same candidates in the same order as the loop below (the first value inside (lo, hi)
    // after the last one evaluated; a value skipped once stays outside, as the interval only
    // shrinks), so the same value is returned, ±0 included. They are found four values at a time
    // (the scalar test per value was a branch the CPU mispredicts, a third of the stage's time),
    // and counted two at a time: the second is used if it is still inside (lo, hi) after the
    // first, which is then exactly the loop's next candidate. +inf is never inside (lo, hi).
    for (int i = 0;;) {
      const __m128 vlo = _mm_set1_ps(lo), vhi = _mm_set1_ps(hi);
      auto inside = [&](int at) {
        const __m128 a = _mm_loadu_ps(v + at);
        return _mm_movemask_ps(_mm_and_ps(_mm_cmpgt_ps(a, vlo), _mm_cmplt_ps(a, vhi)));
      };
      // The next candidate at or after index `from`, or −1.
      auto next = [&](int from) {
        int base = from & ~3;
        if (base >= padded) return -1;
        int bits = inside(base) & (0xF << (from - base));
        while (!bits) {
          base += 4;
          if (base >= padded) return -1;
          bits = inside(base);
        }
        return base + __builtin_ctz(static_cast<unsigned>(bits));
      };
      const int i1 = next(i);
      if (i1 < 0) return v[0];  // unreachable for k < the number of finite values
      const int i2 = next(i1 + 1);
      const float x1 = v[i1], x2 = i2 >= 0 ? v[i2] : x1;
      const __m128 vx1 = _mm_set1_ps(x1), vx2 = _mm_set1_ps(x2);
      __m128i less1 = _mm_setzero_si128(), leq1 = less1, less2 = less1, leq2 = less1;
      for (int j = 0; j < padded; j += 4) {
        const __m128 a = _mm_loadu_ps(v + j);
        less1 = _mm_sub_epi32(less1, _mm_castps_si128(_mm_cmplt_ps(a, vx1)));
        leq1 = _mm_sub_epi32(leq1, _mm_castps_si128(_mm_cmple_ps(a, vx1)));
        less2 = _mm_sub_epi32(less2, _mm_castps_si128(_mm_cmplt_ps(a, vx2)));
        leq2 = _mm_sub_epi32(leq2, _mm_castps_si128(_mm_cmple_ps(a, vx2)));
      }
      const __m128i s1 = hsum4(less1, leq1, less2, leq2);  // {less1, leq1, less2, leq2}
      alignas(16) int32_t c[4];
      _mm_store_si128(reinterpret_cast<__m128i*>(c), s1);
      if (isRankK(x1, c[0], c[1])) return x1;
      if (i2 < 0) return v[0];  // unreachable: x1 was the last candidate and not the answer
      i = i2 + 1;               // values between i1 and i2 were outside (lo, hi) already
      if (!(x2 > lo && x2 < hi)) continue;
      if (isRankK(x2, c[2], c[3])) return x2;
    }
#else
    for (int i = 0; i < padded; ++i) {
      const float x = v[i];
      if (!(x > lo && x < hi)) continue;
      int less = 0, leq = 0;
      for (int j = 0; j < padded; ++j) {
        less += v[j] < x;
        leq += v[j] <= x;
      }
      if (isRankK(x, less, leq)) return x;
    }
    return v[0];  // unreachable for k < the number of finite values
#endif
  }

#if defined(__SSE2__)
  /// {Σ a, Σ b, Σ c, Σ d} over the lanes of each.
  static __m128i hsum4(__m128i a, __m128i b, __m128i c, __m128i d) {
    const __m128i ab = _mm_add_epi32(_mm_unpacklo_epi32(a, b), _mm_unpackhi_epi32(a, b));
    const __m128i cd = _mm_add_epi32(_mm_unpacklo_epi32(c, d), _mm_unpackhi_epi32(c, d));
    return _mm_add_epi32(_mm_unpacklo_epi64(ab, cd), _mm_unpackhi_epi64(ab, cd));
  }
#endif

  std::string layer_ = "relative_height";
  int radius_ = 3;
  int min_neighbours_ = 4;
  double quantile_ = 0.5;
  std::vector<float> window_, bordered_, ref_;
  std::vector<int> valid_;
  std::vector<uint32_t> keep_;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::RelativeHeight, terramrf::PluginKind::kFeature, "relative_height",
                "lowest point of a cell relative to the median lowest point around it "
                "(negative obstacles such as ditches)")
