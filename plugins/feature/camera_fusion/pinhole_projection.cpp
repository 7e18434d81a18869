#include "pinhole_projection.hpp"

#include "terramrf/simd.hpp"

namespace terramrf {

namespace {

/// Points [i0, n) one at a time.
std::size_t onePointAtATime(const PinholeScan& s, std::size_t i0) {
  const double w_max = s.width - 0.5, h_max = s.height - 0.5;
  std::size_t visible = 0;
  for (std::size_t i = i0; i < s.n; ++i) {
    const double x = s.x[i], y = s.y[i], z = s.z[i];
    const double cz = s.zc[0] * x + s.zc[1] * y + s.zc[2] * z + s.zc[3];
    const double w = s.M[2][0] * x + s.M[2][1] * y + s.M[2][2] * z + s.M[2][3];
    s.pix[i] = -1;
    if (s.depth) s.depth[i] = 0.f;
    if (!(cz > 1e-6 && w > 1e-9)) continue;  // behind the camera: no divisions
    const double u = (s.M[0][0] * x + s.M[0][1] * y + s.M[0][2] * z + s.M[0][3]) / w;
    const double v = (s.M[1][0] * x + s.M[1][1] * y + s.M[1][2] * z + s.M[1][3]) / w;
    if (!(u >= -0.5 && v >= -0.5 && u < w_max && v < h_max)) continue;
    // The nearest pixel centre; u, v ≥ −0.5, so the sums are ≥ 0 and truncation rounds. Within
    // half a pixel beyond the last column or row there is no pixel.
    const int iu = int(u + 0.5), iv = int(v + 0.5);
    if (iu >= s.width || iv >= s.height) continue;
    s.pix[i] = iv * s.width + iu;
    if (s.depth) s.depth[i] = float(w);
    ++visible;
  }
  return visible;
}

#if defined(TERRAMRF_SIMD_DISPATCH)
/// ((r0·x + r1·y) + r2·z) + r3, as the one-point loop evaluates it.
TERRAMRF_TARGET_AVX2 inline __m256d row(const __m256d* r, __m256d x, __m256d y, __m256d z) {
  const __m256d xy = _mm256_add_pd(_mm256_mul_pd(r[0], x), _mm256_mul_pd(r[1], y));
  return _mm256_add_pd(_mm256_add_pd(xy, _mm256_mul_pd(r[2], z)), r[3]);
}

/// Four points per vector, the same operations in the same order as onePointAtATime (AVX2
/// without FMA, so no product is fused into a sum).
TERRAMRF_TARGET_AVX2 std::size_t fourPointsAtATime(const PinholeScan& s) {
  __m256d zc[4], m[3][4];
  for (int j = 0; j < 4; ++j) {
    zc[j] = _mm256_set1_pd(s.zc[j]);
    for (int r = 0; r < 3; ++r) m[r][j] = _mm256_set1_pd(s.M[r][j]);
  }
  const __m256d c_min = _mm256_set1_pd(1e-6), w_min = _mm256_set1_pd(1e-9);
  const __m256d lo = _mm256_set1_pd(-0.5), half = _mm256_set1_pd(0.5);
  const __m256d u_max = _mm256_set1_pd(s.width - 0.5), v_max = _mm256_set1_pd(s.height - 0.5);
  const __m128i width = _mm_set1_epi32(s.width), height = _mm_set1_epi32(s.height);
  const __m128i none = _mm_set1_epi32(-1);
  const __m256i even = _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6);  // 64-bit mask → 32-bit lanes
  std::size_t visible = 0, i = 0;
  for (; i + 4 <= s.n; i += 4) {
    const __m256d x = _mm256_cvtps_pd(_mm_loadu_ps(s.x + i));
    const __m256d y = _mm256_cvtps_pd(_mm_loadu_ps(s.y + i));
    const __m256d z = _mm256_cvtps_pd(_mm_loadu_ps(s.z + i));
    const __m256d cz = row(zc, x, y, z), w = row(m[2], x, y, z);
    const __m256d u = _mm256_div_pd(row(m[0], x, y, z), w);
    const __m256d v = _mm256_div_pd(row(m[1], x, y, z), w);
    __m256d in =
        _mm256_and_pd(_mm256_cmp_pd(cz, c_min, _CMP_GT_OQ), _mm256_cmp_pd(w, w_min, _CMP_GT_OQ));
    in = _mm256_and_pd(
        in, _mm256_and_pd(_mm256_cmp_pd(u, lo, _CMP_GE_OQ), _mm256_cmp_pd(v, lo, _CMP_GE_OQ)));
    in = _mm256_and_pd(in, _mm256_and_pd(_mm256_cmp_pd(u, u_max, _CMP_LT_OQ),
                                         _mm256_cmp_pd(v, v_max, _CMP_LT_OQ)));
    // Points outside convert 0 (+0.0 through the mask), never an out-of-range coordinate.
    const __m128i iu = _mm256_cvttpd_epi32(_mm256_add_pd(_mm256_and_pd(in, u), half));
    const __m128i iv = _mm256_cvttpd_epi32(_mm256_add_pd(_mm256_and_pd(in, v), half));
    __m128i ok = _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(_mm256_castpd_si256(in), even));
    ok = _mm_and_si128(ok, _mm_and_si128(_mm_cmplt_epi32(iu, width), _mm_cmplt_epi32(iv, height)));
    const __m128i p = _mm_add_epi32(_mm_mullo_epi32(iv, width), iu);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(s.pix + i), _mm_blendv_epi8(none, p, ok));
    if (s.depth) _mm_storeu_ps(s.depth + i, _mm_and_ps(_mm256_cvtpd_ps(w), _mm_castsi128_ps(ok)));
    visible += std::size_t(__builtin_popcount(_mm_movemask_ps(_mm_castsi128_ps(ok))));
  }
  return visible + onePointAtATime(s, i);
}
#endif

}  // namespace

std::size_t projectPinhole(const PinholeScan& s) {
#if defined(TERRAMRF_SIMD_DISPATCH)
  if (useAvx2()) return fourPointsAtATime(s);
#endif
  return onePointAtATime(s, 0);
}

}  // namespace terramrf
