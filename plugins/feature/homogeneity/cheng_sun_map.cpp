#include "cheng_sun_map.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <string>

#include "terramrf/simd.hpp"

namespace terramrf {

namespace {

inline int reflect101(int i, int n) { return cv::borderInterpolate(i, n, cv::BORDER_REFLECT_101); }

/// Raw pointers of the scratch rows: stores through them do not make the compiler reload the
/// vectors' data pointers, so the loops below vectorise.
struct Rows {
  uint16_t* col_s;  // centre at [R]
  uint32_t* col_q;
  uint8_t* sobel;  // three rows of cols + 2
  uint32_t* e2;
  uint32_t* v2;
};

/// e² and N²v² of row r into s.e2 and s.v2. The column sums are those of row r − 1 updated by
/// one row in and one out (`running`), else summed afresh. One body, inlined into a plain (SSE2)
/// and an AVX2 copy, each for every window (R = d/2, a constant, so that the window sums along
/// the row are unrolled into one pass); integer arithmetic only, so every copy gives the same
/// values.
template <int R>
__attribute__((always_inline)) inline void rowBody(const uint8_t* grey, int rows, int cols, int r,
                                                   bool running, const Rows& s) {
  constexpr uint32_t area = uint32_t(2 * R + 1) * uint32_t(2 * R + 1);
  const std::size_t W = std::size_t(cols);
  // Column sums of I and I² over rows r − R .. r + R (≤ 15 · 255 and 15 · 255², no overflow;
  // the running update wraps and unwraps modulo 2^16 and 2^32, exactly).
  uint16_t* cs = s.col_s + R;
  uint32_t* cq = s.col_q + R;
  if (running) {
    const uint8_t* out = grey + std::size_t(reflect101(r - 1 - R, rows)) * W;
    const uint8_t* in = grey + std::size_t(reflect101(r + R, rows)) * W;
    for (int x = 0; x < cols; ++x) {
      cs[x] = uint16_t(cs[x] + in[x] - out[x]);
      cq[x] += uint32_t(uint16_t(in[x] * in[x])) - uint32_t(uint16_t(out[x] * out[x]));
    }
  } else {
    const uint8_t* p = grey + std::size_t(reflect101(r - R, rows)) * W;
    for (int x = 0; x < cols; ++x) {
      cs[x] = p[x];
      cq[x] = uint16_t(p[x] * p[x]);
    }
    for (int dy = -R + 1; dy <= R; ++dy) {
      p = grey + std::size_t(reflect101(r + dy, rows)) * W;
      for (int x = 0; x < cols; ++x) {
        cs[x] = uint16_t(cs[x] + p[x]);
        cq[x] += uint16_t(p[x] * p[x]);
      }
    }
  }
  // Reflected columns: a column sum of a reflected column is the reflected column sum.
  for (int k = 1; k <= R; ++k) {
    const int lo = reflect101(-k, cols), hi = reflect101(cols - 1 + k, cols);
    cs[-k] = cs[lo], cq[-k] = cq[lo];
    cs[cols - 1 + k] = cs[hi], cq[cols - 1 + k] = cq[hi];
  }
  // Window sums along the row, then N·ΣI² − (ΣI)² (never negative; exact in uint32 up to 15 × 15).
  uint32_t* v2 = s.v2;
  for (int x = 0; x < cols; ++x) {
    uint16_t t1 = 0;
    uint32_t t2 = 0;
    for (int j = -R; j <= R; ++j) t1 = uint16_t(t1 + cs[x + j]), t2 += cq[x + j];
    v2[x] = area * t2 - uint32_t(t1) * uint32_t(t1);
  }
  // 3 × 3 Sobel on rows r − 1, r, r + 1, each padded by its reflected neighbour column.
  const std::size_t P = W + 2;
  for (int k = 0; k < 3; ++k) {
    const uint8_t* p = grey + std::size_t(reflect101(r - 1 + k, rows)) * W;
    uint8_t* q = s.sobel + k * P;
    std::copy(p, p + cols, q + 1);
    q[0] = p[reflect101(-1, cols)];
    q[cols + 1] = p[reflect101(cols, cols)];
  }
  const uint8_t* a = s.sobel;  // row r − 1, at [x] the pixel x − 1
  const uint8_t* b = a + P;
  const uint8_t* c = b + P;
  uint32_t* e2 = s.e2;
  for (int x = 0; x < cols; ++x) {
    // |Gx|, |Gy| ≤ 1020: 16-bit lanes, twice as many per vector as 32-bit ones.
    const int16_t gx = int16_t((int16_t(a[x + 2]) - a[x]) + 2 * (int16_t(b[x + 2]) - b[x]) +
                               (int16_t(c[x + 2]) - c[x]));
    const int16_t gy = int16_t((int16_t(c[x]) + 2 * c[x + 1] + c[x + 2]) -
                               (int16_t(a[x]) + 2 * a[x + 1] + a[x + 2]));
    e2[x] = uint32_t(int32_t(gx) * gx + int32_t(gy) * gy);
  }
}

/// One row function per window (3–15, odd; the plugin's declared range) and instruction set,
/// chosen once per call of the public functions: [R] runs rowBody<R>, [0] is unused.
using RowFn = void (*)(const uint8_t*, int, int, int, bool, const Rows&);
template <int R>
void rowSse2(const uint8_t* grey, int rows, int cols, int r, bool running, const Rows& s) {
  rowBody<R>(grey, rows, cols, r, running, s);
}
constexpr RowFn kRowSse2[8] = {nullptr,    rowSse2<1>, rowSse2<2>, rowSse2<3>,
                               rowSse2<4>, rowSse2<5>, rowSse2<6>, rowSse2<7>};

/// e² · N²v² as a float, formed the same way everywhere. Both are below 2^31 (e² ≤ 2 · 1020²;
/// N²v² = N² · variance ≤ 225² · 127.5²), so they convert as signed integers: one instruction
/// per vector, and the same floats as an unsigned conversion would give.
__attribute__((always_inline)) inline float product(uint32_t e2, uint32_t v2) {
  return float(int32_t(e2)) * float(int32_t(v2));
}

/// H from the products; the same IEEE operations in every copy (no FMA), so the same bits.
__attribute__((always_inline)) inline void fixedBody(const uint32_t* e2, const uint32_t* v2, int n,
                                                     float k, float* h) {
  for (int x = 0; x < n; ++x) h[x] = 1.0f - std::sqrt(product(e2[x], v2[x])) * k;
}
void fixedSse2(const uint32_t* e2, const uint32_t* v2, int n, float k, float* h) {
  fixedBody(e2, v2, n, k, h);
}

#if defined(TERRAMRF_SIMD_DISPATCH)
template <int R>
TERRAMRF_TARGET_AVX2 void rowAvx2(const uint8_t* grey, int rows, int cols, int r, bool running,
                                  const Rows& s) {
  rowBody<R>(grey, rows, cols, r, running, s);
}
constexpr RowFn kRowAvx2[8] = {nullptr,    rowAvx2<1>, rowAvx2<2>, rowAvx2<3>,
                               rowAvx2<4>, rowAvx2<5>, rowAvx2<6>, rowAvx2<7>};
TERRAMRF_TARGET_AVX2 void fixedAvx2(const uint32_t* e2, const uint32_t* v2, int n, float k,
                                    float* h) {
  fixedBody(e2, v2, n, k, h);
}
#endif

}  // namespace

void ChengSunMap::reserve(int cols, int window) {
  if (window < 3 || window > 15 || window % 2 == 0)
    throw std::invalid_argument("ChengSunMap: window " + std::to_string(window) +
                                " px; expected an odd size from 3 to 15");
  half_ = window / 2;
#if defined(TERRAMRF_SIMD_DISPATCH)
  avx2_ = useAvx2();
#endif
  const std::size_t W = std::size_t(cols), pad = std::size_t(window / 2);
  col_s_.resize(W + 2 * pad);
  col_q_.resize(W + 2 * pad);
  sobel_rows_.resize(3 * (W + 2));
  e2_.resize(W);
  v2_.resize(W);
}

void ChengSunMap::row(const uint8_t* grey, int rows, int cols, int r, bool running) {
  const Rows s{col_s_.data(), col_q_.data(), sobel_rows_.data(), e2_.data(), v2_.data()};
#if defined(TERRAMRF_SIMD_DISPATCH)
  if (avx2_) return kRowAvx2[half_](grey, rows, cols, r, running, s);
#endif
  kRowSse2[half_](grey, rows, cols, r, running, s);
}

void ChengSunMap::rowProducts(const uint8_t* grey, int rows, int cols, int window, int r,
                              const uint32_t** e2, const uint32_t** v2) {
  reserve(cols, window);
  row(grey, rows, cols, r, false);
  *e2 = e2_.data();
  *v2 = v2_.data();
}

void ChengSunMap::fixed(const uint8_t* grey, int rows, int cols, int window, int r0, int r1,
                        float k, float* h) {
  reserve(cols, window);
  for (int r = r0; r < r1; ++r, h += cols) {
    row(grey, rows, cols, r, r > r0);
#if defined(TERRAMRF_SIMD_DISPATCH)
    if (avx2_) {
      fixedAvx2(e2_.data(), v2_.data(), cols, k, h);
      continue;
    }
#endif
    fixedSse2(e2_.data(), v2_.data(), cols, k, h);
  }
}

void ChengSunMap::maxima(const uint8_t* grey, int rows, int cols, int window, int r0, int r1,
                         uint32_t* e2_max, uint32_t* v2_max) {
  reserve(cols, window);
  uint32_t e = 0, v = 0;
  for (int r = r0; r < r1; ++r) {
    row(grey, rows, cols, r, r > r0);
    for (int x = 0; x < cols; ++x) e = std::max(e, e2_[x]), v = std::max(v, v2_[x]);
  }
  *e2_max = e;
  *v2_max = v;
}

void ChengSunMap::image(const uint8_t* grey, int rows, int cols, int window, int r0, int r1,
                        float ev_max, float* h) {
  reserve(cols, window);
  for (int r = r0; r < r1; ++r, h += cols) {
    row(grey, rows, cols, r, r > r0);
    for (int x = 0; x < cols; ++x) h[x] = 1.0f - std::sqrt(product(e2_[x], v2_[x])) / ev_max;
  }
}

void ChengSunMap::spread(const uint8_t* grey, int rows, int cols, int window, int r0, int r1,
                         double nv_max, float* h) {
  reserve(cols, window);
  for (int r = r0; r < r1; ++r, h += cols) {
    row(grey, rows, cols, r, r > r0);
    for (int x = 0; x < cols; ++x) h[x] = float(1.0 - std::sqrt(double(v2_[x])) / nv_max);
  }
}

}  // namespace terramrf
