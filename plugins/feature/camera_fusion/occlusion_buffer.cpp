#include "occlusion_buffer.hpp"

#include <algorithm>
#include <cstring>
#include <limits>

#include "terramrf/simd.hpp"

namespace terramrf {

void OcclusionBuffer::build(int width, int height, int splat_px,
                            const std::vector<int32_t>& pixel_of_point,
                            const std::vector<float>& depth,
                            const std::vector<int32_t>& cell_of_point) {
  const int r = std::max(0, splat_px);
  const std::size_t n = pixel_of_point.size();
  // Only the rows the splats reach are stored (a scan fills the lower two thirds of a KITTI
  // image): the buffer is cleared every frame, and that clearing was a quarter of its cost.
  int32_t lo = std::numeric_limits<int32_t>::max(), hi = -1;
  for (std::size_t i = 0; i < n; ++i) {
    const int32_t px = pixel_of_point[i];
    if (px < 0) continue;
    lo = std::min(lo, px);
    hi = std::max(hi, px);
  }
  if (hi < 0) {
    first_ = 0;
    keys_.clear();
    return;
  }
  const int row0 = std::max(0, lo / width - r), row1 = std::min(height - 1, hi / width + r);
  first_ = uint32_t(row0) * uint32_t(width);
  keys_.assign(std::size_t(row1 - row0 + 1) * std::size_t(width), kEmpty);
  const Splat sp{keys_.data(), width, height, row0, r};
#if defined(TERRAMRF_SIMD_DISPATCH)
  if (useAvx2()) return splatAvx2(sp, pixel_of_point, depth, cell_of_point);
#endif
  splatScalar(sp, pixel_of_point, depth, cell_of_point);
}

namespace {

/// Point i's key: depth bits high, cell low (see the header).
inline uint64_t keyOf(float depth, int32_t cell) {
  uint32_t bits;
  std::memcpy(&bits, &depth, sizeof bits);
  return (uint64_t(bits) << 32) | uint32_t(cell);
}

/// Every visible point's key into the (2r + 1)² square around its pixel, keeping the least;
/// `row_min(row, x0, x1, key)` does one row of it. With kR ≥ 0 (= s.r) the squares away from the
/// image border have a size known when compiling, so their rows unroll into a few vector
/// operations each (a 5 × 5 splat: ten); kR = −1 reads r at run time.
template <int kR, class RowMin>
__attribute__((always_inline)) inline void splatBody(const OcclusionBuffer::Splat& s,
                                                     const std::vector<int32_t>& pixel_of_point,
                                                     const std::vector<float>& depth,
                                                     const std::vector<int32_t>& cell_of_point,
                                                     RowMin row_min) {
  const int r = kR >= 0 ? kR : s.r;
  const std::size_t W = std::size_t(s.width);
  for (std::size_t i = 0, n = pixel_of_point.size(); i < n; ++i) {
    const int32_t px = pixel_of_point[i];
    if (px < 0) continue;
    const uint64_t key = keyOf(depth[i], cell_of_point[i]);
    const int u = px % s.width, v = px / s.width;
    if (kR >= 0 && u >= kR && u + kR < s.width && v >= kR && v + kR < s.height) {
      uint64_t* at = s.keys + std::size_t(v - kR - s.row0) * W + std::size_t(u - kR);
      for (int y = 0; y <= 2 * kR; ++y, at += W) row_min(at, 0, 2 * kR, key);
      continue;
    }
    const int u0 = std::max(0, u - r), u1 = std::min(s.width - 1, u + r);
    const int v0 = std::max(0, v - r), v1 = std::min(s.height - 1, v + r);
    for (int y = v0; y <= v1; ++y) row_min(s.keys + std::size_t(y - s.row0) * W, u0, u1, key);
  }
}

/// splatBody for the frame's half-width: the common ones (KITTI's ring gap gives 2) compiled
/// for their size.
template <class RowMin>
__attribute__((always_inline)) inline void splatAny(const OcclusionBuffer::Splat& s,
                                                    const std::vector<int32_t>& pixel_of_point,
                                                    const std::vector<float>& depth,
                                                    const std::vector<int32_t>& cell_of_point,
                                                    RowMin row_min) {
  switch (s.r) {
    case 1:
      return splatBody<1>(s, pixel_of_point, depth, cell_of_point, row_min);
    case 2:
      return splatBody<2>(s, pixel_of_point, depth, cell_of_point, row_min);
    case 3:
      return splatBody<3>(s, pixel_of_point, depth, cell_of_point, row_min);
    default:
      return splatBody<-1>(s, pixel_of_point, depth, cell_of_point, row_min);
  }
}

}  // namespace

void OcclusionBuffer::splatScalar(const Splat& s, const std::vector<int32_t>& pixel_of_point,
                                  const std::vector<float>& depth,
                                  const std::vector<int32_t>& cell_of_point) {
  splatAny(
      s, pixel_of_point, depth, cell_of_point,
      [](uint64_t * row, int x0, int x1, uint64_t key) __attribute__((always_inline)) {
        for (int x = x0; x <= x1; ++x) row[x] = std::min(row[x], key);
      });
}

#if defined(TERRAMRF_SIMD_DISPATCH)
namespace {
/// min over four keys at once: every key is below 2^63 (a positive float's bits high), so the
/// signed comparison AVX2 has orders them as the unsigned one would.
TERRAMRF_TARGET_AVX2 __attribute__((always_inline)) inline void min4(uint64_t* at, __m256i k) {
  __m256i* p = reinterpret_cast<__m256i*>(at);
  const __m256i cur = _mm256_loadu_si256(p);
  _mm256_storeu_si256(p, _mm256_blendv_epi8(cur, k, _mm256_cmpgt_epi64(cur, k)));
}
TERRAMRF_TARGET_AVX2 __attribute__((always_inline)) inline void min2(uint64_t* at, __m128i k) {
  __m128i* p = reinterpret_cast<__m128i*>(at);
  const __m128i cur = _mm_loadu_si128(p);
  _mm_storeu_si128(p, _mm_blendv_epi8(cur, k, _mm_cmpgt_epi64(cur, k)));
}
/// Four keys, then two, then one: no two stores overlap. (Ending on a vector that overlaps the
/// last one makes its load wait for that store: a 5 × 5 splat ran a sixth slower so.)
TERRAMRF_TARGET_AVX2 inline void rowMinAvx2(uint64_t* row, int x0, int x1, uint64_t key) {
  int x = x0;
  if (x + 3 <= x1) {
    const __m256i k = _mm256_set1_epi64x(int64_t(key));
    for (; x + 3 <= x1; x += 4) min4(row + x, k);
  }
  if (x + 1 <= x1) min2(row + x, _mm_set1_epi64x(int64_t(key))), x += 2;
  if (x <= x1) row[x] = std::min(row[x], key);
}
/// rowMinAvx2 as a function object (a lambda would not carry the target), inlined into splatBody.
struct RowMinAvx2 {
  TERRAMRF_TARGET_AVX2 void operator()(uint64_t* row, int x0, int x1, uint64_t key) const {
    rowMinAvx2(row, x0, x1, key);
  }
};
}  // namespace

TERRAMRF_TARGET_AVX2 void OcclusionBuffer::splatAvx2(const Splat& s,
                                                     const std::vector<int32_t>& pixel_of_point,
                                                     const std::vector<float>& depth,
                                                     const std::vector<int32_t>& cell_of_point) {
  splatAny(s, pixel_of_point, depth, cell_of_point, RowMinAvx2{});
}
#endif

}  // namespace terramrf
