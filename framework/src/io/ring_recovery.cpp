#include "terramrf/io/ring_recovery.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "ring_cut.hpp"
#include "terramrf/run_end.hpp"
#include "terramrf/simd.hpp"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace terramrf {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2 * kPi;
constexpr double kDeg = kPi / 180.0;

double wrapPi(double a) {
  while (a > kPi) a -= kTwoPi;
  while (a <= -kPi) a += kTwoPi;
  return a;
}

/// atan2 to ~1e-5 rad (0.0006°, far below a ring spacing of ~0.35°) at a fraction of libm's
/// cost; two per point were a third of recoverRings.
inline float fastAtan2(float y, float x) {
  const float ax = std::fabs(x), ay = std::fabs(y);
  const float mx = std::max(ax, ay), mn = std::min(ax, ay);
  if (mx == 0.f) return 0.f;
  const float a = mn / mx, s = a * a;
  float r = ((((-0.0117212f * s + 0.05265332f) * s - 0.11643287f) * s + 0.19354346f) * s -
             0.33262347f) * s * a + 0.99997726f * a;
  if (ay > ax) r = 1.57079637f - r;
  if (x < 0.f) r = 3.14159274f - r;
  return y < 0.f ? -r : r;
}

#if defined(__SSE2__)
// GCC does not vectorise the per-point loops by itself (sqrt may set errno, and under the default
// -ftrapping-math it will not if-convert the branches), so they are written with SSE2, which
// every x86-64 has. Each lane performs the same IEEE operations in the same order as the scalar
// code (no FMA without -march), so the results are bit-identical to it.

inline __m128 selectPs(__m128 mask, __m128 if_true, __m128 if_false) {
  return _mm_or_ps(_mm_and_ps(mask, if_true), _mm_andnot_ps(mask, if_false));
}

inline __m128d selectPd(__m128d mask, __m128d if_true, __m128d if_false) {
  return _mm_or_pd(_mm_and_pd(mask, if_true), _mm_andnot_pd(mask, if_false));
}

/// p[0], p[1] widened to double.
inline __m128d loadTwoAsDouble(const float* p) {
  return _mm_cvtps_pd(_mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p))));
}

/// fastAtan2 on four lanes.
inline __m128 fastAtan2x4(__m128 y, __m128 x) {
  const __m128 sign = _mm_set1_ps(-0.f), zero = _mm_setzero_ps();
  const __m128 ax = _mm_andnot_ps(sign, x), ay = _mm_andnot_ps(sign, y);
  // maxps/minps(ay, ax) pick exactly what std::max/std::min(ax, ay) pick, NaN included.
  const __m128 mx = _mm_max_ps(ay, ax), mn = _mm_min_ps(ay, ax);
  const __m128 a = _mm_div_ps(mn, mx), s = _mm_mul_ps(a, a);
  __m128 r = _mm_add_ps(_mm_mul_ps(_mm_set1_ps(-0.0117212f), s), _mm_set1_ps(0.05265332f));
  r = _mm_sub_ps(_mm_mul_ps(r, s), _mm_set1_ps(0.11643287f));
  r = _mm_add_ps(_mm_mul_ps(r, s), _mm_set1_ps(0.19354346f));
  r = _mm_sub_ps(_mm_mul_ps(r, s), _mm_set1_ps(0.33262347f));
  r = _mm_add_ps(_mm_mul_ps(_mm_mul_ps(r, s), a), _mm_mul_ps(_mm_set1_ps(0.99997726f), a));
  r = selectPs(_mm_cmpgt_ps(ay, ax), _mm_sub_ps(_mm_set1_ps(1.57079637f), r), r);
  r = selectPs(_mm_cmplt_ps(x, zero), _mm_sub_ps(_mm_set1_ps(3.14159274f), r), r);
  r = _mm_xor_ps(r, _mm_and_ps(_mm_cmplt_ps(y, zero), sign));  // negate where y < 0
  return _mm_andnot_ps(_mm_cmpeq_ps(mx, zero), r);             // 0 where x = y = 0
}
#endif

#if defined(TERRAMRF_SIMD_DISPATCH)
// The per-point passes over angles (elevation and azimuth, then the azimuth steps and their
// unwrapping) are the largest part of the recovery; with AVX (eight lanes, no FMA, so the same
// IEEE operations in the same order) they take about half the time and give the same bits.
// Chosen at run time: the build targets plain x86-64.
TERRAMRF_TARGET_AVX inline __m256 select8(__m256 mask, __m256 if_true, __m256 if_false) {
  return _mm256_or_ps(_mm256_and_ps(mask, if_true), _mm256_andnot_ps(mask, if_false));
}

/// fastAtan2 on eight lanes.
TERRAMRF_TARGET_AVX inline __m256 fastAtan2x8(__m256 y, __m256 x) {
  const __m256 sign = _mm256_set1_ps(-0.f), zero = _mm256_setzero_ps();
  const __m256 ax = _mm256_andnot_ps(sign, x), ay = _mm256_andnot_ps(sign, y);
  const __m256 mx = _mm256_max_ps(ay, ax), mn = _mm256_min_ps(ay, ax);
  const __m256 a = _mm256_div_ps(mn, mx), s = _mm256_mul_ps(a, a);
  __m256 r =
      _mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(-0.0117212f), s), _mm256_set1_ps(0.05265332f));
  r = _mm256_sub_ps(_mm256_mul_ps(r, s), _mm256_set1_ps(0.11643287f));
  r = _mm256_add_ps(_mm256_mul_ps(r, s), _mm256_set1_ps(0.19354346f));
  r = _mm256_sub_ps(_mm256_mul_ps(r, s), _mm256_set1_ps(0.33262347f));
  r = _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(r, s), a),
                    _mm256_mul_ps(_mm256_set1_ps(0.99997726f), a));
  r = select8(_mm256_cmp_ps(ay, ax, _CMP_GT_OS), _mm256_sub_ps(_mm256_set1_ps(1.57079637f), r), r);
  r = select8(_mm256_cmp_ps(x, zero, _CMP_LT_OS), _mm256_sub_ps(_mm256_set1_ps(3.14159274f), r), r);
  r = _mm256_xor_ps(r, _mm256_and_ps(_mm256_cmp_ps(y, zero, _CMP_LT_OS), sign));
  return _mm256_andnot_ps(_mm256_cmp_ps(mx, zero, _CMP_EQ_OQ), r);
}

/// elevationsDeg's loop for points [0, n - n % 8): elevation [deg] into el, azimuth into az
/// unless null.
TERRAMRF_TARGET_AVX void anglesX8(const float* px, const float* py, const float* pz, std::size_t n,
                                  float dz, float to_deg, float* el, float* az) {
  const __m256 dz8 = _mm256_set1_ps(dz), to_deg8 = _mm256_set1_ps(to_deg);
  for (std::size_t i = 0; i + 8 <= n; i += 8) {
    const __m256 x = _mm256_loadu_ps(px + i), y = _mm256_loadu_ps(py + i);
    const __m256 r = _mm256_sqrt_ps(_mm256_add_ps(_mm256_mul_ps(x, x), _mm256_mul_ps(y, y)));
    const __m256 e = fastAtan2x8(_mm256_sub_ps(_mm256_loadu_ps(pz + i), dz8), r);
    _mm256_storeu_ps(el + i, _mm256_mul_ps(e, to_deg8));
    if (az) _mm256_storeu_ps(az + i, fastAtan2x8(y, x));
  }
}

/// countSmallSteps's loop from step 1 on, eight steps at a time; returns the first step left.
/// Counts are kept as floats (exact up to 2^24 per lane) since AVX has no 256-bit integer adds.
TERRAMRF_TARGET_AVX std::size_t smallStepsX8(const float* az, std::size_t n, std::size_t& fwd,
                                             std::size_t& bwd) {
  const float pi = float(kPi), two_pi = float(kTwoPi), small = float(5 * kDeg);
  const __m256 pi8 = _mm256_set1_ps(pi), neg_pi8 = _mm256_set1_ps(-pi);
  const __m256 two_pi8 = _mm256_set1_ps(two_pi), zero = _mm256_setzero_ps();
  const __m256 small8 = _mm256_set1_ps(small), neg_small8 = _mm256_set1_ps(-small);
  const __m256 one = _mm256_set1_ps(1.f);
  __m256 f8 = zero, b8 = zero;
  std::size_t i = 1;
  for (; i + 8 <= n && i < (std::size_t(1) << 24) * 8; i += 8) {
    __m256 d = _mm256_sub_ps(_mm256_loadu_ps(az + i), _mm256_loadu_ps(az + i - 1));
    d = _mm256_sub_ps(d, _mm256_and_ps(_mm256_cmp_ps(d, pi8, _CMP_GT_OS), two_pi8));
    d = _mm256_add_ps(d, _mm256_and_ps(_mm256_cmp_ps(d, neg_pi8, _CMP_LE_OS), two_pi8));
    f8 = _mm256_add_ps(f8, _mm256_and_ps(_mm256_and_ps(_mm256_cmp_ps(d, zero, _CMP_GT_OS),
                                                       _mm256_cmp_ps(d, small8, _CMP_LT_OS)),
                                         one));
    b8 = _mm256_add_ps(b8, _mm256_and_ps(_mm256_and_ps(_mm256_cmp_ps(d, zero, _CMP_LT_OS),
                                                       _mm256_cmp_ps(d, neg_small8, _CMP_GT_OS)),
                                         one));
  }
  alignas(32) float fc[8], bc[8];
  _mm256_store_ps(fc, f8);
  _mm256_store_ps(bc, b8);
  for (int k = 0; k < 8; ++k) fwd += std::size_t(fc[k]), bwd += std::size_t(bc[k]);
  return i;
}

/// unwrapAzimuths's loop, eight points at a time; returns the first point left.
TERRAMRF_TARGET_AVX std::size_t unwrapX8(const float* az, std::size_t n, float s, float d,
                                         float* a) {
  const __m256 two_pi8 = _mm256_set1_ps(float(kTwoPi)), zero = _mm256_setzero_ps();
  const __m256 s8 = _mm256_set1_ps(s), d8 = _mm256_set1_ps(d);
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    __m256 v = _mm256_mul_ps(d8, _mm256_sub_ps(_mm256_loadu_ps(az + i), s8));
    v = _mm256_add_ps(v, _mm256_and_ps(_mm256_cmp_ps(v, zero, _CMP_LT_OS), two_pi8));
    v = _mm256_add_ps(v, _mm256_and_ps(_mm256_cmp_ps(v, zero, _CMP_LT_OS), two_pi8));
    v = _mm256_sub_ps(v, _mm256_and_ps(_mm256_cmp_ps(v, two_pi8, _CMP_GE_OS), two_pi8));
    v = _mm256_sub_ps(v, _mm256_and_ps(_mm256_cmp_ps(v, two_pi8, _CMP_GE_OS), two_pi8));
    _mm256_storeu_ps(a + i, v);
  }
  return i;
}

/// coarseSumsX8's running sums of `sector` into sum/neg; starts `next`.
TERRAMRF_TARGET_AVX2 inline void flushSector(int& sector, int next, __m256d& sum4, __m256d& neg4,
                                             double* sum, double* neg) {
  if (sector >= 0) {
    alignas(32) double v[4], w[4];
    _mm256_store_pd(v, sum4);
    _mm256_store_pd(w, neg4);
    sum[sector] += (v[0] + v[1]) + (v[2] + v[3]);
    neg[sector] += (w[0] + w[1]) + (w[2] + w[3]);
  }
  sum4 = neg4 = _mm256_setzero_pd();
  sector = next;
}

/// The cut search's sums of points below the finely binned azimuths (see detail::bestRingCut),
/// eight points of one run at a time from i on while none is at azimuth >= fine_from; returns
/// the first point left. Adds each point's delta and its negative part to its 5° sector.
TERRAMRF_TARGET_AVX2 std::size_t coarseSumsX8(const float* a, const float* el, std::size_t i,
                                              std::size_t end, float m_now, float m_moved,
                                              float fine_from, float cap, float sectors_per_rad,
                                              int sectors, double* sum, double* neg) {
  const __m256 now8 = _mm256_set1_ps(m_now), moved8 = _mm256_set1_ps(m_moved);
  const __m256 cap8 = _mm256_set1_ps(cap),
               abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
  const __m256 fine8 = _mm256_set1_ps(fine_from), zero = _mm256_setzero_ps();
  const __m256 per_rad = _mm256_set1_ps(sectors_per_rad);
  int sector = -1;
  __m256d sum4 = _mm256_setzero_pd(), neg4 = _mm256_setzero_pd();
  for (; i + 8 <= end; i += 8) {
    const __m256 av = _mm256_loadu_ps(a + i);
    if (_mm256_movemask_ps(_mm256_cmp_ps(av, fine8, _CMP_GE_OS))) break;
    const __m256 e = _mm256_loadu_ps(el + i);
    const __m256 d =
        _mm256_sub_ps(_mm256_min_ps(_mm256_and_ps(_mm256_sub_ps(e, moved8), abs_mask), cap8),
                      _mm256_min_ps(_mm256_and_ps(_mm256_sub_ps(e, now8), abs_mask), cap8));
    const __m256i k = _mm256_min_epi32(_mm256_cvttps_epi32(_mm256_mul_ps(av, per_rad)),
                                       _mm256_set1_epi32(sectors - 1));
    const int k0 = _mm256_cvtsi256_si32(k);
    if (_mm256_movemask_epi8(_mm256_cmpeq_epi32(k, _mm256_set1_epi32(k0))) == -1) {
      if (k0 != sector) flushSector(sector, k0, sum4, neg4, sum, neg);
      const __m256 dn = _mm256_min_ps(d, zero);
      sum4 = _mm256_add_pd(sum4, _mm256_add_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(d)),
                                               _mm256_cvtps_pd(_mm256_extractf128_ps(d, 1))));
      neg4 = _mm256_add_pd(neg4, _mm256_add_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(dn)),
                                               _mm256_cvtps_pd(_mm256_extractf128_ps(dn, 1))));
      continue;
    }
    alignas(32) float dv[8];
    alignas(32) int32_t kv[8];
    _mm256_store_ps(dv, d);
    _mm256_store_si256(reinterpret_cast<__m256i*>(kv), k);
    for (int l = 0; l < 8; ++l) sum[kv[l]] += dv[l], neg[kv[l]] += std::min(0.f, dv[l]);
  }
  flushSector(sector, -1, sum4, neg4, sum, neg);
  return i;
}

#endif

/// Median of v[begin, end) (reorders that range).
float medianOf(std::vector<float>& v, std::size_t begin, std::size_t end) {
  if (begin >= end) return std::numeric_limits<float>::quiet_NaN();
  auto mid = v.begin() + begin + (end - begin) / 2;
  std::nth_element(v.begin() + begin, mid, v.begin() + end);
  return *mid;
}

// Scratch arrays are thread_local and keep their capacity: fresh multi-megabyte allocations per
// scan cost more in page faults than the whole computation. Loops reach them through pointers
// taken once: in a shared library every thread_local access calls __tls_get_addr, which GCC does
// not hoist out of a loop that calls a function (a fifth of scanOrderRings was that call).

/// Elevation [deg] of every point, seen from (0, 0, z_offset), and with an `az` array also its
/// azimuth [rad, in [-π, π]]: one pass over the coordinates for both.
const std::vector<float>& elevationsDeg(const PointCloud& c, double z_offset_m,
                                        std::vector<float>* az = nullptr) {
  thread_local std::vector<float> el;
  const std::size_t n = c.size();
  el.resize(n);
  if (az) az->resize(n);
  const float dz = static_cast<float>(z_offset_m), to_deg = static_cast<float>(1 / kDeg);
  std::size_t i = 0;
#if defined(__SSE2__)
  // Plain pointers: SSE stores may alias anything, so through the vectors every iteration would
  // reload their data pointers.
  const float *px = c.x.data(), *py = c.y.data(), *pz = c.z.data();
  float* out = el.data();
  const __m128 dz4 = _mm_set1_ps(dz), to_deg4 = _mm_set1_ps(to_deg);
#if defined(TERRAMRF_SIMD_DISPATCH)
  if (useAvx()) {
    anglesX8(px, py, pz, n, dz, to_deg, out, az ? az->data() : nullptr);
    i = n - n % 8;
  }
#endif
  auto elevation = [&](__m128 x, __m128 y) {
    const __m128 r = _mm_sqrt_ps(_mm_add_ps(_mm_mul_ps(x, x), _mm_mul_ps(y, y)));
    _mm_storeu_ps(out + i,
                  _mm_mul_ps(fastAtan2x4(_mm_sub_ps(_mm_loadu_ps(pz + i), dz4), r), to_deg4));
  };
  if (az) {
    float* out_az = az->data();
    for (; i + 4 <= n; i += 4) {
      const __m128 x = _mm_loadu_ps(px + i), y = _mm_loadu_ps(py + i);
      elevation(x, y);
      _mm_storeu_ps(out_az + i, fastAtan2x4(y, x));
    }
  } else {
    for (; i + 4 <= n; i += 4) elevation(_mm_loadu_ps(px + i), _mm_loadu_ps(py + i));
  }
#endif
  for (; i < n; ++i) {
    const float r = std::sqrt(c.x[i] * c.x[i] + c.y[i] * c.y[i]);
    el[i] = fastAtan2(c.z[i] - dz, r) * to_deg;
    if (az) (*az)[i] = fastAtan2(c.y[i], c.x[i]);
  }
  return el;
}

/// Per-ring median elevation (NaN for empty rings) via a counting sort of the elevations. Rings
/// with many points are subsampled evenly to ~256 (the median barely moves; nth_element over
/// every point was the largest cost of recoverRings). Id: uint16_t (rings) or int (runs); ids
/// are taken modulo 2^16 either way.
template <typename Id>
std::vector<float> ringMedians(const std::vector<Id>& ring, const std::vector<float>& el,
                               int nrings) {
  constexpr std::size_t kSamples = 256;
  // Ids come in long runs (a ring in scan order), so the points are handled run by run: a
  // per-point counter chained through memory was most of the cost.
  struct Run {
    std::size_t begin, end;
    uint16_t id;
  };
  thread_local std::vector<Run> runs;
  runs.clear();
  std::vector<std::size_t> count(nrings, 0);
  const std::size_t n = ring.size();
  const Id* const id_of = ring.data();
  for (std::size_t i = 0; i < n;) {
    const uint16_t r = static_cast<uint16_t>(id_of[i]);
    const std::size_t j = runEnd(id_of, i, n);
    if (r < nrings) runs.push_back({i, j, r}), count[r] += j - i;
    i = j;
  }
  std::vector<std::size_t> stride(nrings), offs(nrings + 1, 0);
  for (int k = 0; k < nrings; ++k) {
    stride[k] = std::max<std::size_t>(1, count[k] / kSamples);
    offs[k + 1] = offs[k] + (count[k] + stride[k] - 1) / stride[k];
  }
  thread_local std::vector<float> sorted;
  sorted.resize(offs.back());
  float* const out = sorted.data();  // see 'Scratch arrays' above
  // Every stride-th point of a ring, in index order; skip = its points to pass before the next.
  std::vector<std::size_t> pos(offs.begin(), offs.end() - 1), skip(nrings, 0);
  for (const Run& run : runs) {
    const uint16_t r = run.id;
    std::size_t i = run.begin + skip[r];
    for (; i < run.end; i += stride[r]) out[pos[r]++] = el[i];
    skip[r] = i - run.end;
  }
  std::vector<float> med(nrings);
  for (int k = 0; k < nrings; ++k) med[k] = medianOf(sorted, offs[k], pos[k]);
  return med;
}

/// Share of points whose elevation is nearest to their own ring's median.
double elevationConsistency(const std::vector<uint16_t>& ring, const std::vector<float>& el,
                            const std::vector<float>& med) {
  std::vector<std::pair<float, int>> sorted;
  for (int k = 0; k < int(med.size()); ++k)
    if (std::isfinite(med[k])) sorted.push_back({med[k], k});
  if (sorted.empty() || ring.empty()) return 0;
  std::sort(sorted.begin(), sorted.end());
  const int nsorted = int(sorted.size());
  constexpr float inf = std::numeric_limits<float>::infinity();
  // The nearest median to e is found as: j = first sorted median not below e (lower_bound), then
  // the one below j if it is strictly nearer (ties go up). Done per point that costs a binary
  // search with mispredicted branches. A point's own ring is known, so instead test whether that
  // search would end on it: j is the ring's position and the one below is not nearer, or j is
  // the position above and the ring is nearer. That needs only the ring's median and its two
  // sorted neighbours (±inf past the ends), with no branch.
  struct Neighbours {
    float below = inf, own = -inf, above = -inf;  // defaults: a ring without median never wins
  };
  std::vector<Neighbours> nb(med.size() + 1);  // last entry: ring ids past med.size()
  for (int j = 0; j < nsorted; ++j)
    nb[sorted[j].second] = {j > 0 ? sorted[j - 1].first : -inf, sorted[j].first,
                            j + 1 < nsorted ? sorted[j + 1].first : inf};
  // Non-finite elevations (non-finite points) take the search itself, as it treats them.
  auto nearest = [&](float e) {
    auto it = std::lower_bound(sorted.begin(), sorted.end(), std::make_pair(e, -1));
    int best = -1;
    float bd = inf;
    if (it != sorted.end()) bd = it->first - e, best = it->second;
    if (it != sorted.begin() && e - std::prev(it)->first < bd) best = std::prev(it)->second;
    return best;
  };
  auto isNearest = [&](const Neighbours& n, float e, uint16_t r) -> std::size_t {
    if (!std::isfinite(e)) return nearest(e) == r;
    const bool at_own = n.below < e && !(n.own < e);  // j = the ring's position
    const bool at_above = n.own < e && !(n.above < e);
    return (at_own & !(e - n.below < n.own - e)) | (at_above & (e - n.own < n.above - e));
  };
  std::size_t good = 0;
  const std::size_t npts = ring.size();
  // Run by run of equal ring ids (rings are contiguous in scan order), four points at a time.
  for (std::size_t i = 0; i < npts;) {
    const uint16_t r = ring[i];
    std::size_t end = i + 1;
    while (end < npts && ring[end] == r) ++end;
    const Neighbours& n = nb[std::min<std::size_t>(r, med.size())];
#if defined(__SSE2__)
    const __m128 below = _mm_set1_ps(n.below), own = _mm_set1_ps(n.own);
    const __m128 above = _mm_set1_ps(n.above), zero = _mm_setzero_ps();
    for (; i + 4 <= end; i += 4) {
      const __m128 e = _mm_loadu_ps(&el[i]);
      if (_mm_movemask_ps(_mm_cmpeq_ps(_mm_sub_ps(e, e), zero)) != 0xF) {  // not all finite
        for (std::size_t k = i; k < i + 4; ++k) good += isNearest(n, el[k], r);
        continue;
      }
      const __m128 own_below_e = _mm_cmplt_ps(own, e);
      const __m128 at_own = _mm_andnot_ps(own_below_e, _mm_cmplt_ps(below, e));
      const __m128 at_above = _mm_andnot_ps(_mm_cmplt_ps(above, e), own_below_e);
      const __m128 lower_at_own = _mm_cmplt_ps(_mm_sub_ps(e, below), _mm_sub_ps(own, e));
      const __m128 lower_at_above = _mm_cmplt_ps(_mm_sub_ps(e, own), _mm_sub_ps(above, e));
      const int hit = _mm_movemask_ps(
          _mm_or_ps(_mm_andnot_ps(lower_at_own, at_own), _mm_and_ps(at_above, lower_at_above)));
      good += (hit & 1) + ((hit >> 1) & 1) + ((hit >> 2) & 1) + ((hit >> 3) & 1);
    }
#endif
    for (; i < end; ++i) good += isNearest(n, el[i], r);
  }
  return double(good) / ring.size();
}

int countViolations(const std::vector<float>& med) {
  int v = 0;
  float last = std::numeric_limits<float>::quiet_NaN();
  for (float m : med) {
    if (!std::isfinite(m)) continue;
    if (std::isfinite(last) && !(m < last)) ++v;
    last = m;
  }
  return v;
}

/// Moves the head of each ring that the first-point cut put at the end of the previous run.
/// Runs are split where the azimuth (measured from the first point) steps back. If the first
/// point is not where the sweep starts (the first ring has no return there, or the file begins
/// mid-ring), every run ends with the first degrees of the next ring. The cut that fits the
/// elevations best is found over a 0.05° azimuth histogram (detail::bestRingCut): moving the
/// points at azimuth >= c of run s to run s+1 changes the summed elevation misfit by the sum of
/// their per-point deltas. Returns whether points were moved; med gets the runs' median
/// elevations from before the move (the caller reuses them if nothing moved).
///
/// The best cut lies within the last 20° of the runs (ringStartAzimuth() sees to that for larger
/// offsets), so only the points of the last 40° are binned at first (a seventh of the work of
/// binning all).
bool refineCut(const std::vector<float>& a, const std::vector<float>& el, std::vector<int>& seg,
               int nseg, std::vector<float>& med) {
  med = ringMedians(seg, el, nseg);
  if (nseg < 2) return false;
  constexpr int kLast40Deg = detail::kRingCutBins / 9 * 8;
  const detail::RingCut best = detail::bestRingCut(a, el, seg, med, kLast40Deg);
  // Only a clear gain (a ring spacing is 0.3-0.5°) moves points.
  if (best.bin == detail::kRingCutBins || best.gain > -0.1 * double(best.moved)) return false;
  const float cut = float(best.bin) / detail::kRingCutBins * float(kTwoPi);
  const std::size_t n = a.size();
  int* const seg_of = seg.data();
  std::size_t i = 0;
#if defined(__SSE2__)
  const __m128 cut4 = _mm_set1_ps(cut);
  const __m128i last = _mm_set1_epi32(nseg - 1);
  for (; i + 4 <= n; i += 4) {
    const __m128i s = _mm_loadu_si128(reinterpret_cast<const __m128i*>(seg_of + i));
    const __m128i move = _mm_and_si128(_mm_cmplt_epi32(s, last),
                                       _mm_castps_si128(_mm_cmpge_ps(_mm_loadu_ps(&a[i]), cut4)));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(seg_of + i), _mm_sub_epi32(s, move));
  }
#endif
  for (; i < n; ++i)
    if (seg_of[i] + 1 < nseg && a[i] >= cut) ++seg_of[i];
  return true;
}

/// Consecutive azimuth steps (wrapped to (-π, π]) that are small forward (fwd) or small
/// backward (bwd): below 5°. In float: a step lies within [-2π, 2π] (plus an ulp of fastAtan2's
/// π), so one wrap each way suffices.
void countSmallSteps(const float* az, std::size_t n, std::size_t& fwd, std::size_t& bwd) {
  const float pi = float(kPi), two_pi = float(kTwoPi), small = float(5 * kDeg);
  std::size_t i = 1;
#if defined(TERRAMRF_SIMD_DISPATCH)
  if (useAvx()) i = smallStepsX8(az, n, fwd, bwd);
#endif
#if defined(__SSE2__)
  const __m128 pi4 = _mm_set1_ps(pi), neg_pi4 = _mm_set1_ps(-pi), two_pi4 = _mm_set1_ps(two_pi);
  const __m128 zero = _mm_setzero_ps(), small4 = _mm_set1_ps(small),
               neg_small4 = _mm_set1_ps(-small);
  __m128i f4 = _mm_setzero_si128(), b4 = _mm_setzero_si128();
  for (; i + 4 <= n; i += 4) {
    __m128 d = _mm_sub_ps(_mm_loadu_ps(az + i), _mm_loadu_ps(az + i - 1));
    d = _mm_sub_ps(d, _mm_and_ps(_mm_cmpgt_ps(d, pi4), two_pi4));
    d = _mm_add_ps(d, _mm_and_ps(_mm_cmple_ps(d, neg_pi4), two_pi4));
    f4 = _mm_sub_epi32(
        f4, _mm_castps_si128(_mm_and_ps(_mm_cmpgt_ps(d, zero), _mm_cmplt_ps(d, small4))));
    b4 = _mm_sub_epi32(
        b4, _mm_castps_si128(_mm_and_ps(_mm_cmplt_ps(d, zero), _mm_cmpgt_ps(d, neg_small4))));
  }
  alignas(16) int32_t fc[4], bc[4];
  _mm_store_si128(reinterpret_cast<__m128i*>(fc), f4);
  _mm_store_si128(reinterpret_cast<__m128i*>(bc), b4);
  fwd += std::size_t(fc[0]) + fc[1] + fc[2] + fc[3];
  bwd += std::size_t(bc[0]) + bc[1] + bc[2] + bc[3];
#endif
  for (; i < n; ++i) {
    float d = az[i] - az[i - 1];
    if (d > pi) d -= two_pi;
    if (d <= -pi) d += two_pi;
    if (d > 0 && d < small)
      ++fwd;
    else if (d < 0 && d > -small)
      ++bwd;
  }
}

/// a[i] = azimuth [rad] in the sweep direction `dir` (±1) from `start`, in [0, 2π).
void unwrapAzimuths(const float* az, std::size_t n, double start, int dir, float* a) {
  const float s = float(start), d = float(dir), two_pi = float(kTwoPi);
  std::size_t i = 0;
#if defined(TERRAMRF_SIMD_DISPATCH)
  if (useAvx()) i = unwrapX8(az, n, s, d, a);
#endif
#if defined(__SSE2__)
  const __m128 two_pi4 = _mm_set1_ps(two_pi), zero = _mm_setzero_ps();
  const __m128 s4 = _mm_set1_ps(s), d4 = _mm_set1_ps(d);
  for (; i + 4 <= n; i += 4) {
    __m128 v = _mm_mul_ps(d4, _mm_sub_ps(_mm_loadu_ps(az + i), s4));  // within (-3π, 3π)
    v = _mm_add_ps(v, _mm_and_ps(_mm_cmplt_ps(v, zero), two_pi4));
    v = _mm_add_ps(v, _mm_and_ps(_mm_cmplt_ps(v, zero), two_pi4));
    v = _mm_sub_ps(v, _mm_and_ps(_mm_cmpge_ps(v, two_pi4), two_pi4));
    v = _mm_sub_ps(v, _mm_and_ps(_mm_cmpge_ps(v, two_pi4), two_pi4));
    _mm_storeu_ps(a + i, v);
  }
#endif
  for (; i < n; ++i) {
    float v = d * (az[i] - s);
    if (v < 0) v += two_pi;
    if (v < 0) v += two_pi;
    if (v >= two_pi) v -= two_pi;
    if (v >= two_pi) v -= two_pi;
    a[i] = v;
  }
}

/// Cuts the unwrapped azimuths a[0, n) into runs (seg[i] = run of point i) and returns how many.
/// A ring starts where the azimuth steps back by more than kBack below the recent level of the
/// current run and stays there: a lone point across the cut, or jitter of near points, does not.
int findRuns(const float* a, std::size_t n, int* seg) {
  constexpr float kBack = float(10 * kDeg);
  constexpr std::size_t kWindow = 9, kPersist = 2;
  int s = 0;
  std::size_t run_start = 0;
  float window[kWindow];
  auto segmentPoint = [&](std::size_t i) {
    if (a[i] < a[i - 1] - kBack) {
      const std::size_t from = std::max(run_start, i > kWindow ? i - kWindow : 0);
      const std::size_t m = i - from;
      std::copy(a + from, a + i, window);
      std::nth_element(window, window + m / 2, window + m);
      const float level = window[m / 2] - kBack;
      bool persists = a[i] < level;
      for (std::size_t j = 1; j < kPersist && i + j < n && persists; ++j)
        persists = a[i + j] < level;
      if (persists) ++s, run_start = i;
    }
    seg[i] = s;
  };
  if (n > 0) seg[0] = 0;
  std::size_t i = 1;
#if defined(__SSE2__)
  // Steps back are rare (one per ring and a few of jitter): four points at a time are tested
  // for one and, without, all get the current run.
  const __m128 back4 = _mm_set1_ps(kBack);
  for (; i + 4 <= n; i += 4) {
    const __m128 now = _mm_loadu_ps(a + i), before = _mm_loadu_ps(a + i - 1);
    if (_mm_movemask_ps(_mm_cmplt_ps(now, _mm_sub_ps(before, back4))) == 0) {
      _mm_storeu_si128(reinterpret_cast<__m128i*>(seg + i), _mm_set1_epi32(s));
      continue;
    }
    for (std::size_t k = i; k < i + 4; ++k) segmentPoint(k);
  }
#endif
  for (; i < n; ++i) segmentPoint(i);
  return s + 1;
}

/// 10° azimuth sectors: coarse enough for a median per ring (~55 points of an HDL-64E ring),
/// fine enough to place a ring start to within 20°, which refineCut() then resolves.
constexpr int kSectors = 36;

/// Sector of an unwrapped azimuth a [rad, in [0, 2π)].
inline int sectorOf(float a) { return std::min(kSectors - 1, int(a * float(kSectors / kTwoPi))); }

/// Median elevation of the first and of the last few points of each run, in file order (NaN for
/// runs too short to tell). seg is findRuns() output: non-decreasing, runs contiguous.
void runEndElevations(const std::vector<float>& el, const std::vector<int>& seg, int nseg,
                      std::vector<float>& first, std::vector<float>& last) {
  constexpr std::size_t kEnd = 16;  // points: a few degrees of a ring
  std::vector<std::size_t> begin(nseg + 1);
  for (int s = 0; s <= nseg; ++s)
    begin[s] = std::lower_bound(seg.begin(), seg.end(), s) - seg.begin();
  first.assign(nseg, std::numeric_limits<float>::quiet_NaN());
  last = first;
  std::vector<float> tmp;
  for (int s = 0; s < nseg; ++s) {
    const std::size_t lo = begin[s], hi = begin[s + 1];
    if (hi <= lo || hi - lo < 4 * kEnd) continue;
    tmp.assign(el.begin() + lo, el.begin() + lo + kEnd);
    first[s] = medianOf(tmp, 0, kEnd);
    tmp.assign(el.begin() + hi - kEnd, el.begin() + hi);
    last[s] = medianOf(tmp, 0, kEnd);
  }
}

/// Median of the finite values of v (NaN if none).
float finiteMedian(std::vector<float> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](float x) { return !std::isfinite(x); }), v.end());
  return medianOf(v, 0, v.size());
}

/// Where the rings really start when the file does not begin at a ring start (a cloud rotated
/// in memory, a recording cut mid-sweep): runs are cut at the first point's azimuth, so each run
/// holds the end of one ring and the start of the next, and the elevation steps by one ring
/// spacing at the same azimuth inside every run. refineCut() only mends a run whose end holds a
/// few degrees of the next ring (its medians then still belong to the run's own ring); with the
/// start mid-ring the medians are mixtures and it cannot. Returns the azimuth [rad, from the
/// first point, in the sweep direction] at which to cut instead, or a negative value when the
/// runs begin at ring starts (the usual case, told cheaply from the runs' ends).
double ringStartAzimuth(const std::vector<float>& a, const std::vector<float>& el,
                        const std::vector<int>& seg, int nseg) {
  // Runs that begin where their ring begins end on the same ring: first and last points agree
  // in elevation. Otherwise they differ by about one ring spacing, run after run.
  std::vector<float> first, last;
  runEndElevations(el, seg, nseg, first, last);
  std::vector<float> step(nseg, std::numeric_limits<float>::quiet_NaN()), gap(nseg, step[0]);
  for (int s = 0; s < nseg; ++s) {
    step[s] = first[s] - last[s];
    if (s + 1 < nseg) gap[s] = std::fabs(first[s] - first[s + 1]);
  }
  const float spacing = finiteMedian(gap), end_step = finiteMedian(step);
  if (!(spacing > 0) || !(std::fabs(end_step) > 0.5f * spacing)) return -1;
  // Elevation per run and azimuth sector (median of every 4th point), then the sector k in which
  // continuing each run with the previous run's points (rings starting in k) fits best: per run,
  // how much the elevation step across k shrinks. Sector k itself, which may hold both rings
  // (the lasers' starts spread over a few degrees), is left out.
  constexpr std::size_t kEvery = 4;
  const std::size_t cells = std::size_t(nseg) * kSectors;
  std::vector<std::vector<float>> sample(cells);
  for (std::size_t i = 0; i < a.size(); i += kEvery) {
    sample[std::size_t(seg[i]) * kSectors + sectorOf(a[i])].push_back(el[i]);
  }
  std::vector<float> level(cells, std::numeric_limits<float>::quiet_NaN());
  for (std::size_t c = 0; c < cells; ++c)
    if (sample[c].size() >= 3) level[c] = medianOf(sample[c], 0, sample[c].size());
  auto L = [&](int s, int j) { return level[std::size_t(s) * kSectors + j]; };
  int best_k = -1;
  float best = 0;
  for (int k = 1; k + 1 < kSectors; ++k) {
    std::vector<float> change;
    for (int s = 1; s < nseg; ++s) {
      const float before = L(s, k - 1), cut = L(s - 1, k + 1), kept = L(s, k + 1);
      if (std::isfinite(before) && std::isfinite(cut) && std::isfinite(kept))
        change.push_back(std::fabs(cut - before) - std::fabs(kept - before));
    }
    if (change.size() < std::size_t(nseg) / 2) continue;
    const float m = medianOf(change, 0, change.size());
    if (m < best) best = m, best_k = k;
  }
  // A clear ring start: the step vanishes in most runs. A start in the last two sectors is
  // left to refineCut().
  if (best_k < 0 || !(best < -0.5f * spacing) || best_k + 2 >= kSectors) return -1;
  // Cut at the end of the next sector, so the rings start within the last 20° of each run,
  // which refineCut() moves.
  return (best_k + 2) * (kTwoPi / kSectors);
}

/// Scan-order segmentation. Returns false (with a reason) when the order carries no rings.
/// ring_med gets each ring's median elevation (as ringMedians(ring, el, nrings) would) when every
/// ring is one run, whose median is already known; otherwise it is left empty.
bool scanOrderRings(const std::vector<float>& el, const std::vector<float>& az, int nrings,
                    std::vector<uint16_t>& ring, RingRecoveryStats& st,
                    std::vector<float>& ring_med) {
  const std::size_t n = el.size();
  thread_local std::vector<float> a;
  thread_local std::vector<int> seg;
  ring_med.clear();
  const float* const az_of = az.data();  // see 'Scratch arrays' above
  // Sweep direction and evidence of ring-major order: most steps are small and one-signed.
  std::size_t fwd = 0, bwd = 0;
  countSmallSteps(az_of, n, fwd, bwd);
  const int dir = fwd >= bwd ? 1 : -1;
  st.ordered_fraction = double(std::max(fwd, bwd)) / double(n - 1);
  if (st.ordered_fraction < 0.5) {
    st.fallback_reason = "points are not in scan order (" +
                         std::to_string(int(st.ordered_fraction * 100 + 0.5)) +
                         "% small forward azimuth steps)";
    return false;
  }
  // Azimuth in the sweep direction from the first point: every ring sweeps one turn from the
  // same cut (KITTI cuts facing forward); refineCut() corrects the guess, ringStartAzimuth()
  // a file that begins mid-ring.
  double start = az_of[0] - dir * 0.01 * kDeg;
  a.resize(n);
  seg.resize(n);
  unwrapAzimuths(az_of, n, start, dir, a.data());
  int nseg = findRuns(a.data(), n, seg.data());
  if (nseg >= (nrings + 1) / 2 && nseg <= 2 * nrings + 16) {
    const double cut = ringStartAzimuth(a, el, seg, nseg);
    if (cut > 0) {
      start = wrapPi(start + dir * cut);
      unwrapAzimuths(az_of, n, start, dir, a.data());
      nseg = findRuns(a.data(), n, seg.data());
    }
  }
  st.segments = nseg;
  if (nseg > 2 * nrings + 16) {
    st.fallback_reason = "scan order gives " + std::to_string(nseg) + " azimuth runs for " +
                         std::to_string(nrings) + " rings";
    return false;
  }
  if (nseg < (nrings + 1) / 2) {
    // Firing (column) order or a single sweep: the runs are not rings.
    st.fallback_reason = "scan order gives " + std::to_string(nseg) + " azimuth runs for " +
                         std::to_string(nrings) + " rings";
    return false;
  }
  std::vector<float> med;
  if (refineCut(a, el, seg, nseg, med)) med = ringMedians(seg, el, nseg);
  // Runs listed bottom ring first are reversed so that ring 0 is the top beam.
  const bool reversed = countViolations(med) > nseg / 2;
  if (reversed) std::reverse(med.begin(), med.end());
  // A file that begins mid-sweep lists its rings from some ring down to the bottom one, then
  // from the top one on: the elevation climbs back by most of the field of view once. The run
  // after that climb is the top ring (and a ring split by the file's start and end becomes two
  // neighbouring runs, merged below).
  int rotation = 0;
  {
    float lo = std::numeric_limits<float>::infinity(), hi = -lo, climb = 0;
    for (int k = 0; k < nseg; ++k) {
      if (!std::isfinite(med[k])) continue;
      lo = std::min(lo, med[k]), hi = std::max(hi, med[k]);
    }
    float prev = std::numeric_limits<float>::quiet_NaN();
    for (int k = 0; k < nseg; ++k) {
      if (!std::isfinite(med[k])) continue;
      if (std::isfinite(prev) && med[k] - prev > climb) climb = med[k] - prev, rotation = k;
      prev = med[k];
    }
    if (!(climb > 0.5f * (hi - lo))) rotation = 0;
    std::rotate(med.begin(), med.begin() + rotation, med.end());
  }
  // Top-first position of run s.
  auto position = [&](int s) {
    const int t = reversed ? nseg - 1 - s : s;
    return (t - rotation + nseg) % nseg;
  };
  // Runs to merge with the next one (top-first positions).
  std::vector<char> merge(std::max(0, nseg - 1), 0);
  int groups = nseg;
  // A file that begins mid-ring ends with the rest of that ring: its first and last runs, now
  // neighbours, are one ring, and between them they cover one turn, each its own part of it
  // (two different rings would each cover the whole turn). Their medians may differ by more
  // than the threshold below, being different stretches of the scene.
  if (rotation != 0) {
    const int p = std::min(position(0), position(nseg - 1));
    if (std::max(position(0), position(nseg - 1)) == p + 1) {
      int count[2][kSectors] = {};
      for (std::size_t i = 0; i < n; ++i)
        if (seg[i] == 0 || seg[i] == nseg - 1) ++count[seg[i] == 0 ? 0 : 1][sectorOf(a[i])];
      int both = 0, either = 0;
      for (int j = 0; j < kSectors; ++j) {
        both += count[0][j] >= 2 && count[1][j] >= 2;
        either += count[0][j] >= 2 || count[1][j] >= 2;
      }
      // The parts meet in one sector, and refineCut() moved up to two sectors of ring start.
      if (either > kSectors / 2 && both <= 4) merge[p] = 1, --groups;
    }
  }
  // Too many runs: merge neighbours with (nearly) the same elevation, i.e. one ring cut twice.
  if (groups > nrings) {
    std::vector<float> gaps;
    for (int k = 0; k + 1 < nseg; ++k) gaps.push_back(med[k] - med[k + 1]);
    std::vector<float> g2(gaps);
    const float typical = g2.empty() ? 0.f : medianOf(g2, 0, g2.size());
    std::vector<int> order(gaps.size());
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(),
              [&](int l, int r) { return std::fabs(gaps[l]) < std::fabs(gaps[r]); });
    for (int k : order) {
      if (groups <= nrings) break;
      if (merge[k]) continue;
      if (std::fabs(gaps[k]) > 0.3f * typical) break;
      merge[k] = 1;
      --groups;
    }
    if (groups > nrings) {
      st.fallback_reason = "scan order gives " + std::to_string(nseg) + " azimuth runs for " +
                           std::to_string(nrings) + " rings";
      return false;
    }
  }
  std::vector<int> id(nseg);
  for (int k = 0, cur = 0; k < nseg; ++k) {
    if (k > 0 && !merge[k - 1]) ++cur;
    id[k] = cur;
  }
  // Too few runs: rings with no return at all. Usually the top beams (open sky), so that is
  // where they go unless an elevation gap is clearly a hole: >= 2.5 times its neighbours' (a
  // single missing ring in a uniform block makes 2, but HDL-64E's gap between its two laser
  // blocks is already ~1.9 times the spacing next to it).
  if (groups < nrings) {
    int missing = nrings - groups;
    std::vector<float> gmed(groups, std::numeric_limits<float>::quiet_NaN());
    for (int k = 0; k < nseg; ++k)
      if (!std::isfinite(gmed[id[k]])) gmed[id[k]] = med[k];
    std::vector<int> extra(groups, 0);  // extra ids inserted before group g
    std::vector<std::pair<float, int>> ratios;
    for (int g = 0; g + 1 < groups; ++g) {
      std::vector<float> nb;
      for (int j = g - 2; j <= g + 2; ++j)
        if (j != g && j >= 0 && j + 1 < groups) nb.push_back(gmed[j] - gmed[j + 1]);
      if (nb.empty()) continue;
      const float local = medianOf(nb, 0, nb.size());
      if (local > 0) ratios.push_back({(gmed[g] - gmed[g + 1]) / local, g});
    }
    std::sort(ratios.rbegin(), ratios.rend());
    for (const auto& [ratio, g] : ratios) {
      if (missing == 0 || ratio < 2.5f) break;
      const int add = std::min(missing, std::max(1, int(std::lround(ratio)) - 1));
      extra[g + 1] += add;
      missing -= add;
    }
    std::vector<int> shift(groups, 0);
    int acc = missing;  // leftover: assumed above the top run
    for (int g = 0; g < groups; ++g) {
      acc += extra[g];
      shift[g] = acc;
    }
    for (int k = 0; k < nseg; ++k) id[k] += shift[id[k]];
    st.missing_rings = nrings - groups;
  }
  std::vector<uint16_t> ring_of_run(nseg);
  for (int s = 0; s < nseg; ++s) ring_of_run[s] = static_cast<uint16_t>(id[position(s)]);
  ring.resize(n);
  const int* const seg_of = seg.data();  // see 'Scratch arrays' above
  for (std::size_t i = 0, j; i < n; i = j) {
    j = runEnd(seg_of, i, n);
    std::fill(ring.begin() + i, ring.begin() + j, ring_of_run[seg_of[i]]);
  }
  // Without merges each ring holds exactly one run's points, in the same order, so ringMedians
  // would sample and select the same values: reuse the run's median.
  if (groups == nseg) {
    ring_med.assign(nrings, std::numeric_limits<float>::quiet_NaN());
    for (int k = 0; k < nseg; ++k) ring_med[id[k]] = med[k];
  }
  return true;
}

void elevationRings(const std::vector<float>& el, const RingRecoveryOptions& o,
                    std::vector<uint16_t>& ring) {
  std::vector<double> centres;  // descending elevation: ring 0 first
  if (!o.elevations_deg.empty()) {
    centres = o.elevations_deg;
  } else {
    float lo = std::numeric_limits<float>::infinity(), hi = -lo;
    for (float e : el) lo = std::min(lo, e), hi = std::max(hi, e);
    constexpr double kBin = 0.02;  // [deg]
    const int nb = std::min(20000, int((hi - lo) / kBin) + 1);
    const double bin = std::max(kBin, double(hi - lo) / std::max(1, nb - 1));
    std::vector<double> h(nb, 0.0), hs(nb, 0.0);
    for (float e : el) h[std::min(nb - 1, int((e - lo) / bin))] += 1;
    constexpr int kHalf = 6;
    double kern[2 * kHalf + 1];
    for (int j = -kHalf; j <= kHalf; ++j) kern[j + kHalf] = std::exp(-0.5 * (j / 2.0) * (j / 2.0));
    for (int i = 0; i < nb; ++i)
      for (int j = -kHalf; j <= kHalf; ++j)
        if (i + j >= 0 && i + j < nb) hs[i] += h[i + j] * kern[j + kHalf];
    std::vector<std::pair<double, int>> peaks;
    for (int i = 0; i < nb; ++i) {
      const double l = i > 0 ? hs[i - 1] : 0, r = i + 1 < nb ? hs[i + 1] : 0;
      if (hs[i] > 0 && hs[i] > l && hs[i] >= r) peaks.push_back({hs[i], i});
    }
    std::sort(peaks.rbegin(), peaks.rend());
    if (int(peaks.size()) > o.rings) peaks.resize(o.rings);
    for (const auto& p : peaks) centres.push_back(lo + (p.second + 0.5) * bin);
  }
  std::sort(centres.rbegin(), centres.rend());
  // Boundaries halfway between neighbouring centres (descending).
  std::vector<double> bounds;
  for (std::size_t k = 0; k + 1 < centres.size(); ++k)
    bounds.push_back(0.5 * (centres[k] + centres[k + 1]));
  ring.resize(el.size());
  for (std::size_t i = 0; i < el.size(); ++i) {
    // Number of boundaries above the point = its ring.
    auto it = std::upper_bound(bounds.begin(), bounds.end(), double(el[i]), std::greater<double>());
    ring[i] = static_cast<uint16_t>(it - bounds.begin());
  }
}

}  // namespace

namespace detail {

RingCut bestRingCut(const std::vector<float>& a, const std::vector<float>& el,
                    const std::vector<int>& seg, const std::vector<float>& med, int fine_from_bin) {
  const int nseg = static_cast<int>(med.size());
  constexpr int kBins = kRingCutBins;
  constexpr float kCap = 1.0f;   // [deg] misfit cap, so near-range points and edges do not dominate
  constexpr int kSectors5 = 72;  // 5° sectors of the bound
  // int(a / 2π · kBins) without the division, which took a third of refineCut: a · (kBins / 2π)
  // differs from it by a few ulp (< 1e-11), which can change the integer part only right next to
  // an integer; such points take the exact expression.
  auto bin = [](float a) {
    constexpr double kBinsPerRad = kBins / kTwoPi;
    const double q = double(a) * kBinsPerRad;
    const int b = int(q);
    const double frac = q - b;
    return frac > 1e-6 && frac < 1 - 1e-6 ? b : int(a / kTwoPi * kBins);
  };
  thread_local std::vector<double> gain;
  thread_local std::vector<std::size_t> count;
  // Runs whose points may move on: there is a next run and both medians are known.
  std::vector<char> movable(nseg, 0);
  for (int k = 0; k + 1 < nseg; ++k)
    movable[k] = std::isfinite(med[k]) && std::isfinite(med[k + 1]);
  // Points at azimuth >= fine_from_rad fall in bins >= fine_from - 1 (the half bin keeps the
  // float comparison clear of the boundary), points below it in bins <= fine_from - 1: the bins
  // from fine_from on hold all their points. The others add up per 5° sector.
  double sector_sum[kSectors5], sector_neg[kSectors5];
#if defined(TERRAMRF_SIMD_DISPATCH)
  const bool avx2 = useAvx2();
#endif
  auto histogram = [&](float fine_from_rad) {
    gain.assign(kBins, 0.0);
    count.assign(kBins, 0);
    std::fill(sector_sum, sector_sum + kSectors5, 0.0);
    std::fill(sector_neg, sector_neg + kSectors5, 0.0);
    double* const gain_of = gain.data();  // see 'Scratch arrays' in the namespace above
    std::size_t* const count_of = count.data();
    auto fine = [&](std::size_t i, float delta) {
      const int b = std::min(kBins - 1, bin(a[i]));
      gain_of[b] += delta;
      ++count_of[b];
    };
    auto coarse = [&](std::size_t i, float delta) {
      const int k = std::min(kSectors5 - 1, int(a[i] * float(kSectors5 / kTwoPi)));
      sector_sum[k] += delta;
      sector_neg[k] += std::min(0.f, delta);
    };
    const std::size_t n = a.size();
    // Run by run (each run is one stretch of the file here), the misfit deltas four at a time.
    for (std::size_t i = 0; i < n;) {
      const int s = seg[i];
      const std::size_t end = runEnd(seg.data(), i, n);
      if (!movable[s]) {
        i = end;
        continue;
      }
      const float m_now = med[s], m_moved = med[s + 1];
#if defined(__SSE2__)
      // minps(x, cap) and std::min(cap, x) both give cap unless x < cap (NaN included).
      const __m128 now4 = _mm_set1_ps(m_now), moved4 = _mm_set1_ps(m_moved);
      const __m128 cap = _mm_set1_ps(kCap), abs_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
      const __m128 fine_from4 = _mm_set1_ps(fine_from_rad), zero = _mm_setzero_ps();
      const __m128 sectors_per_rad = _mm_set1_ps(float(kSectors5 / kTwoPi));
      // bin() two lanes at a time in double, with the same products and tests; a lane whose
      // fraction is within 1e-6 of an integer takes bin() itself.
      const __m128d bins_per_rad = _mm_set1_pd(kBins / kTwoPi);
      const __m128d frac_lo = _mm_set1_pd(1e-6), frac_hi = _mm_set1_pd(1 - 1e-6);
      auto binsOf = [&](__m128d q, int* out) {
        const __m128i b = _mm_cvttpd_epi32(q);
        const __m128d frac = _mm_sub_pd(q, _mm_cvtepi32_pd(b));
        const int exact =
            _mm_movemask_pd(_mm_and_pd(_mm_cmpgt_pd(frac, frac_lo), _mm_cmplt_pd(frac, frac_hi)));
        out[0] = _mm_cvtsi128_si32(b);
        out[1] = _mm_cvtsi128_si32(_mm_shuffle_epi32(b, 1));
        return exact;
      };
#if defined(TERRAMRF_SIMD_DISPATCH)
      // The points below fine_from come first in a run (its azimuth rises): eight at a time.
      if (avx2)
        i = coarseSumsX8(a.data(), el.data(), i, end, m_now, m_moved, fine_from_rad, kCap,
                         float(kSectors5 / kTwoPi), kSectors5, sector_sum, sector_neg);
#endif
      // The coarse sums of the sector the last groups fell in, kept in registers.
      int sector = -1;
      __m128d sum2 = _mm_setzero_pd(), neg2 = _mm_setzero_pd();
      auto flush = [&] {
        if (sector < 0) return;
        alignas(16) double v[2], w[2];
        _mm_store_pd(v, sum2);
        _mm_store_pd(w, neg2);
        sector_sum[sector] += v[0] + v[1];
        sector_neg[sector] += w[0] + w[1];
        sum2 = neg2 = _mm_setzero_pd();
        sector = -1;
      };
      for (; i + 4 <= end; i += 4) {
        const __m128 e = _mm_loadu_ps(&el[i]);
        const __m128 now = _mm_min_ps(_mm_and_ps(_mm_sub_ps(e, now4), abs_mask), cap);
        const __m128 moved = _mm_min_ps(_mm_and_ps(_mm_sub_ps(e, moved4), abs_mask), cap);
        const __m128 d = _mm_sub_ps(moved, now);
        const __m128 av = _mm_loadu_ps(&a[i]);
        const int high = _mm_movemask_ps(_mm_cmpge_ps(av, fine_from4));
        if (high == 0) {
          const __m128i k = _mm_cvttps_epi32(_mm_mul_ps(av, sectors_per_rad));
          const int k0 = _mm_cvtsi128_si32(k);
          if (k0 < kSectors5 &&
              _mm_movemask_epi8(_mm_cmpeq_epi32(k, _mm_set1_epi32(k0))) == 0xFFFF) {
            if (k0 != sector) flush(), sector = k0;
            const __m128 dneg = _mm_min_ps(d, zero);
            sum2 = _mm_add_pd(sum2, _mm_add_pd(_mm_cvtps_pd(d), _mm_cvtps_pd(_mm_movehl_ps(d, d))));
            neg2 = _mm_add_pd(
                neg2, _mm_add_pd(_mm_cvtps_pd(dneg), _mm_cvtps_pd(_mm_movehl_ps(dneg, dneg))));
            continue;
          }
        }
        alignas(16) float delta[4];
        _mm_store_ps(delta, d);
        if (high == 0xF) {
          int b[4];
          const int exact =
              binsOf(_mm_mul_pd(_mm_cvtps_pd(av), bins_per_rad), b) |
              binsOf(_mm_mul_pd(_mm_cvtps_pd(_mm_movehl_ps(av, av)), bins_per_rad), b + 2) << 2;
          for (int k = 0; k < 4; ++k) {
            const int bk = std::min(kBins - 1, exact >> k & 1 ? b[k] : bin(a[i + k]));
            gain_of[bk] += delta[k];
            ++count_of[bk];
          }
          continue;
        }
        for (int k = 0; k < 4; ++k) {
          if (high >> k & 1)
            fine(i + k, delta[k]);
          else
            coarse(i + k, delta[k]);
        }
      }
      flush();
#endif
      for (; i < end; ++i) {
        const float now = std::min(kCap, std::fabs(el[i] - m_now));
        const float moved = std::min(kCap, std::fabs(el[i] - m_moved));
        if (a[i] >= fine_from_rad)
          fine(i, moved - now);
        else
          coarse(i, moved - now);
      }
    }
  };
  double sum = 0, best = 0;
  std::size_t moved = 0, best_moved = 0;
  int best_bin = kBins;
  auto search = [&](int down_to) {
    for (int b = kBins - 1; b >= down_to; --b) {
      sum += gain[b];
      moved += count[b];
      if (sum < best) best = sum, best_bin = b, best_moved = moved;
    }
  };
  const int fine_from = std::clamp(fine_from_bin, 1, kBins);
  histogram(float((fine_from - 0.5) / kBins * kTwoPi));
  search(fine_from);
  // A cut in bin b < fine_from gains sum + gain[fine_from - 1] (that bin's binned points) + the
  // deltas of the unbinned points in bins >= b: at least those of the sectors above b's sector
  // plus the negative ones of its own. The margin covers the rounding of the sums (< 1e-9 here).
  bool bounded = true;
  double above = sum + gain[fine_from - 1];
  for (int k = kSectors5 - 1; k >= 0 && bounded; --k) {
    bounded = above + sector_neg[k] >= best + 1e-3;
    above += sector_sum[k];
  }
  if (!bounded) {
    sum = 0, best = 0, moved = 0, best_moved = 0, best_bin = kBins;
    histogram(-std::numeric_limits<float>::infinity());
    search(1);
  }
  RingCut cut;
  cut.bin = best_bin, cut.gain = best, cut.moved = best_moved, cut.binned_all = !bounded;
  return cut;
}

}  // namespace detail

const char* toString(RingMethod m) {
  switch (m) {
    case RingMethod::kScanOrder:
      return "scan_order";
    case RingMethod::kElevation:
      return "elevation";
    case RingMethod::kNone:
      break;
  }
  return "none";
}

RingRecoveryStats recoverRings(PointCloud& cloud, const RingRecoveryOptions& o) {
  RingRecoveryStats st;
  st.points = cloud.size();
  cloud.ring.clear();
  const int nrings = std::max(1, o.rings);
  if (cloud.size() < std::size_t(nrings) * std::max(1, o.min_points_per_ring)) {
    st.fallback_reason = "too few points (" + std::to_string(cloud.size()) + ") for " +
                         std::to_string(nrings) + " rings";
    return st;
  }
  thread_local std::vector<float> az;  // filled for scan order only
  const std::vector<float>& el =
      elevationsDeg(cloud, o.z_offset_m, o.use_scan_order ? &az : nullptr);
  std::vector<uint16_t> ring;
  std::vector<float> med;  // per ring id
  bool done = false;
  if (o.use_scan_order) {
    done = scanOrderRings(el, az, nrings, ring, st, med);
    if (done) {
      if (med.empty()) med = ringMedians(ring, el, nrings);
      st.monotonic_violations = countViolations(med);
      // A few rings out of elevation order are tolerated (a sparse ring's median can sit off);
      // more means the runs are not rings.
      if (st.monotonic_violations > std::max(2, nrings / 16)) {
        st.fallback_reason = "scan-order runs are not ordered by elevation (" +
                             std::to_string(st.monotonic_violations) + " inversions)";
        done = false;
      } else {
        st.method = RingMethod::kScanOrder;
      }
    }
  } else {
    st.fallback_reason = "scan order disabled";
  }
  if (!done) {
    elevationRings(el, o, ring);
    st.method = RingMethod::kElevation;
    med = ringMedians(ring, el, nrings);
  }
  st.ring_median_elevation_deg = std::move(med);
  st.monotonic_violations = countViolations(st.ring_median_elevation_deg);
  st.rings_found = 0;
  for (float m : st.ring_median_elevation_deg) st.rings_found += std::isfinite(m);
  st.elevation_consistency = o.measure_consistency
                                 ? elevationConsistency(ring, el, st.ring_median_elevation_deg)
                                 : std::numeric_limits<double>::quiet_NaN();
  cloud.ring = std::move(ring);
  return st;
}

}  // namespace terramrf
