// Roughness f_r (paper 000 §4.3, after Neuhaus et al.): along each laser ring the measured ranges
// are high-pass filtered; what remains is assigned to the cells the points fall in.
//
// Why it works: at grazing incidence a small height change δz moves the range by about
// δz / sin(incidence), so a few centimetres of grass or gravel show up as decimetres of range
// jitter along a ring, while asphalt only shows the sensor's range noise.
//
// Filter: residual_i = r_i − mean(r_{i−w..i+w} \ r_i) over the ring's neighbours in scan order
// (azimuth order for rings the cloud stores shuffled, see sortRings);
// a neighbour beyond `max_jump_m`, or the ring's end, ends the window (object edges are not
// roughness); a gap of missing returns between ring neighbours does not (ending the window there
// changed the real-data sweeps by a few cells either way: docs/benchmarks.md, session 33);
// a neighbour whose beam elevation differs by more than `max_elevation_step_deg` belongs to
// another laser and is passed over. Rings recovered by elevation binning from voxel-thinned
// clouds (the Open3D-ML scans) interleave two lasers near the sensor, whose ground ranges differ
// by decimetres there: without the check their asphalt read as grass (road recall 0.79 → 0.92).
// The ring is not closed at its seam: its first and last points are one revolution (0.1 s)
// apart, and on a moving car their ranges differ by decimetres (seq 00: median 0.6 m, ahead of
// the car), which would read as roughness (docs/plugins/features.md).
// Cell value: RMS of its points' residuals [m].
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <utility>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "terramrf/plugin.hpp"
#include "terramrf/run_end.hpp"
#include "terramrf/simd.hpp"

namespace terramrf {
#if defined(__SSE2__)
#define TERRAMRF_RING_RESIDUALS_NS sse2
#define TERRAMRF_RING_RESIDUALS_LANES 4
#include "ring_residuals.inc"
#undef TERRAMRF_RING_RESIDUALS_NS
#undef TERRAMRF_RING_RESIDUALS_LANES
#endif
#if defined(TERRAMRF_SIMD_DISPATCH)
#pragma GCC push_options
#pragma GCC target("avx2")
#define TERRAMRF_RING_RESIDUALS_NS avx2
#define TERRAMRF_RING_RESIDUALS_LANES 8
#include "ring_residuals.inc"
#undef TERRAMRF_RING_RESIDUALS_NS
#undef TERRAMRF_RING_RESIDUALS_LANES
#pragma GCC pop_options
#endif
}  // namespace terramrf

namespace terramrf {

class Roughness final : public Stage {
 public:
  void declare(ParamDecl& d) override {
    d.add("layer", layer_, "name of the output layer: RMS of high-pass filtered ranges [m]");
    d.add("window", window_, "neighbours on each side along the ring in the low-pass mean")
        .unit("points").range(1, 50);
    d.add("max_jump_m", max_jump_m_,
          "a neighbour whose range differs more than this is an edge, not roughness")
        .unit("m").range(0.01, 100);
    d.add("azimuth_order", azimuth_order_,
          "order of the points along a ring: 'scan' trusts the cloud's order, 'sort' sorts every "
          "ring by azimuth, 'auto' sorts the rings whose order is not the scan's (more than 2 % "
          "of consecutive points over 5° apart: shuffled or resampled clouds)")
        .choices({"auto", "scan", "sort"});
    d.add("max_elevation_step_deg", max_elev_step_deg_,
          "a neighbour whose beam elevation differs more than this is from another laser and is "
          "passed over (rings recovered from thinned or merged clouds mix lasers near the "
          "sensor; 64-beam sensors space lasers >= 0.33 deg apart); 0 = off")
        .unit("deg")
        .range(0, 90);
    d.add("residual", residual_,
          "range: the range residual itself (paper 000); vertical: the residual times |sin "
          "elevation|, the height change that moves a ground return's range by that much, so a "
          "surface reads alike at every range (a ground ring's range jitter grows as "
          "1 / sin elevation)")
        .choices({"range", "vertical"});
    d.add("min_points", min_points_, "cells with fewer filtered points get NaN")
        .unit("points").range(1, 1000);
  }
  std::vector<std::string> reads() const override { return {artefacts::kPoints}; }
  std::vector<std::string> writes() const override { return {layer_}; }

  void process(FrameContext& ctx) override {
    const PointCloud& pc = ctx.frame->points;
    TerrainGrid& g = *ctx.grid;
    Layer& out = g.add(layer_);
    const std::size_t n = pc.size();
    if (n == 0) return;
    if (!pc.hasRing())
      throw InputError(ctx.frame->source_path,
                       "roughness needs the laser ring of every point; this scan has none (use a "
                       "source that reads or recovers rings)");
    // Stable counting sort by ring keeps each ring in scan order, whatever the file's layout.
    // The counts grow with the largest ring seen, so one pass over the rings counts and sizes.
    // Clouds stored ring after ring (KITTI) are walked run by run of equal rings: a counter
    // incremented per point in memory was a store-to-load chain. Clouds in firing order (column
    // after column, as drivers deliver them) change ring at nearly every point; there the runs
    // cost more than they save, and a counter per point has no chain (the next point's ring is
    // another one), so those are walked point by point.
    const uint16_t* ring = pc.ring.data();
    const std::size_t probe = std::min<std::size_t>(n, 256);
    std::size_t changes = 0;
    for (std::size_t i = 1; i < probe; ++i) changes += ring[i] != ring[i - 1];
    const bool by_point = changes * 2 > probe;
    offsets_.assign(1, 0);
    if (by_point) {
      for (std::size_t i = 0; i < n; ++i) {
        const uint16_t r = ring[i];
        if (r == kUnknownRing) continue;
        if (r + 2u > offsets_.size()) offsets_.resize(r + 2u, 0);
        ++offsets_[r + 1];
      }
    } else {
      for (std::size_t i = 0, j; i < n; i = j) {
        const uint16_t r = ring[i];
        j = runEnd(ring, i, n);
        if (r == kUnknownRing) continue;
        if (r + 2u > offsets_.size()) offsets_.resize(r + 2u, 0);
        offsets_[r + 1] += static_cast<uint32_t>(j - i);
      }
    }
    const int rings = static_cast<int>(offsets_.size()) - 1;
    for (int r = 0; r < rings; ++r) offsets_[r + 1] += offsets_[r];
    order_.resize(offsets_[rings]);
    cursor_.assign(offsets_.begin(), offsets_.end() - 1);
    if (by_point) {
      uint32_t* order = order_.data();
      uint32_t* cursor = cursor_.data();
      for (std::size_t i = 0; i < n; ++i) {
        const uint16_t r = ring[i];
        if (r != kUnknownRing) order[cursor[r]++] = static_cast<uint32_t>(i);
      }
    } else {
      for (std::size_t i = 0, j; i < n; i = j) {
        const uint16_t r = ring[i];
        j = runEnd(ring, i, n);
        if (r == kUnknownRing) continue;
        uint32_t* dst = order_.data() + cursor_[r];
        for (std::size_t t = i; t < j; ++t) *dst++ = static_cast<uint32_t>(t);
        cursor_[r] += static_cast<uint32_t>(j - i);
      }
    }
    // Points whose ring is unknown (a driver's -1, a ring field that is not one) add nothing
    // here; counted, so a run says how much of the cloud its roughness saw.
    ctx.metrics[name() + ".points_without_ring"] = static_cast<double>(n - order_.size());
    sorted_rings_ = 0;
    if (azimuth_order_ != "scan") sortRings(pc, rings);
    ctx.metrics[name() + ".sorted_rings"] = sorted_rings_;
    const bool elev = max_elev_step_deg_ > 0;
    const bool vertical = residual_ == "vertical";
    // Passed-over neighbours widen the search, up to 4 windows along the ring.
    const int span = elev ? 4 * window_ : window_;
    // range_ and sin_el_ carry `pad` slots before and after the ring-ordered values, so the
    // four- and eight-point groups of the vector paths may load past either end (those lanes are
    // masked).
    const std::size_t pad = static_cast<std::size_t>(span) + 8;
    range_.resize(order_.size() + 2 * pad);
    if (elev || vertical) sin_el_.resize(order_.size() + 2 * pad);
    cell_.resize(order_.size() + 8);
    rangesInRingOrder(pc, g.cellOfPoint().data(), pad, elev || vertical);
    Filter f;
    f.range = range_.data() + pad;
    f.sin_el = elev || vertical ? sin_el_.data() + pad : nullptr;
    f.cell = cell_.data();
    f.max_dsin = static_cast<float>(std::sin(max_elev_step_deg_ * M_PI / 180));
    f.jump = static_cast<float>(max_jump_m_);
    f.window = window_;
    f.span = span;
    f.elev = elev;
    f.vertical = vertical;
    sum_.assign(g.cells(), 0.f);
    cnt_.assign(g.cells(), 0);
    CellSums acc{sum_.data(), cnt_.data()};
#if defined(TERRAMRF_SIMD_DISPATCH)
    const bool avx2 = useAvx2();
#endif
    for (int r = 0; r < rings; ++r) {
      const int b = static_cast<int>(offsets_[r]), e = static_cast<int>(offsets_[r + 1]);
#if defined(TERRAMRF_SIMD_DISPATCH)
      if (avx2) {
        if (elev)
          avx2::ringResiduals<true>(b, e, f, acc);
        else
          avx2::ringResiduals<false>(b, e, f, acc);
        continue;
      }
#endif
#if defined(__SSE2__)
      if (elev)
        sse2::ringResiduals<true>(b, e, f, acc);
      else
        sse2::ringResiduals<false>(b, e, f, acc);
#else
      ringResiduals(b, e, f, acc);
#endif
    }
    acc.flush();
    std::size_t residuals = 0;  // counted here, not per point (a counter in memory was 10 %)
    for (std::size_t c = 0; c < g.cells(); ++c) residuals += cnt_[c];
    const std::size_t passed_over = acc.passed_over;
    // Neighbours passed over per residual: 2.6–3.0 on the Open3D-ML scans, whose recovered rings
    // interleave lasers; about 0.2 on KITTI's own ring order, from points beyond object edges
    // (their z/r differs through the laser's offset from the point origin).
    ctx.metrics[name() + ".passed_over_per_point"] =
        residuals ? static_cast<double>(passed_over) / residuals : 0.0;
    for (std::size_t c = 0; c < g.cells(); ++c)
      if (cnt_[c] >= static_cast<uint32_t>(min_points_)) out[c] = std::sqrt(sum_[c] / cnt_[c]);
  }

 private:
  /// What the high-pass of one ring reads: ranges and sin elevations in ring order.
  struct Filter {
    const float* range = nullptr;
    const float* sin_el = nullptr;  ///< null unless elev or vertical
    const int32_t* cell = nullptr;  ///< grid cell of each point, −1 outside
    float max_dsin = 0, jump = 0;
    int window = 0, span = 0;
    bool elev = false, vertical = false;
  };

  /// Per-cell sums of squared residuals, fed in ring order. Consecutive points of a ring mostly
  /// fall in the same cell; its sum and count are carried in registers while they do (the same
  /// additions in the same order as sum[cell] += ...), which takes the store-to-load round trip
  /// through memory out of the per-point dependency chain.
  struct CellSums {
    float* sum;
    uint32_t* cnt;
    int cell = -1;
    float s = 0;
    uint32_t n = 0;
    std::size_t passed_over = 0;
    void add(int c, float sq) {
      if (c != cell) {
        flush();
        cell = c, s = sum[c], n = cnt[c];
      }
      s += sq;
      ++n;
    }
    void flush() {
      if (cell >= 0) sum[cell] = s, cnt[cell] = n;
    }
  };

  /// The filter as defined (file comment), one point after the other: residuals of the points
  /// k in [b, e) of one ring that lie in the grid.
  void ringResiduals(int b, int e, const Filter& filter, CellSums& sums) const {
    const Filter f = filter;  // local copies stay in registers
    CellSums acc = sums;
    const float* range = f.range;
    for (int k = b; k < e; ++k) {
      const int cell = f.cell[k];
      if (cell < 0) continue;
      const float rk = range[k];
      float s = 0;
      int m = 0;
      const float sk = f.elev ? f.sin_el[k] : 0.f;
      for (int j = k - 1, got = 0; j >= b && j >= k - f.span && got < f.window; --j) {
        if (f.elev && std::abs(f.sin_el[j] - sk) > f.max_dsin) {
          ++acc.passed_over;
          continue;
        }
        if (std::abs(range[j] - rk) > f.jump) break;
        s += range[j], ++m, ++got;
      }
      const int left = m;
      for (int j = k + 1, got = 0; j < e && j <= k + f.span && got < f.window; ++j) {
        if (f.elev && std::abs(f.sin_el[j] - sk) > f.max_dsin) {
          ++acc.passed_over;
          continue;
        }
        if (std::abs(range[j] - rk) > f.jump) break;
        s += range[j], ++m, ++got;
      }
      if (left == 0 || m == left) continue;  // need neighbours on both sides
      const float res = f.vertical ? (rk - s / m) * std::abs(f.sin_el[k]) : rk - s / m;
      acc.add(cell, res * res);
    }
    sums = acc;
  }

  /// range_[pad + k] (and sin_el_[pad + k] = z / range when `with_sin`) and cell_[k] of the
  /// point order_[k].
  void rangesInRingOrder(const PointCloud& pc, const int32_t* cell_of, std::size_t pad,
                         bool with_sin) {
    const float *X = pc.x.data(), *Y = pc.y.data(), *Z = pc.z.data();
    const uint32_t* o = order_.data();
    const std::size_t m = order_.size();
    float* range = range_.data() + pad;
    float* sin_el = with_sin ? sin_el_.data() + pad : nullptr;
    std::size_t k = 0;
#if defined(__SSE2__)
    // GCC keeps sqrt and the division scalar here (sqrt may set errno); four lanes with the same
    // IEEE operations in the same order (no FMA without -march) give bit-identical values.
    // maxps(1e-3, r) picks what std::max(r, 1e-3f) picks, NaN included.
    const __m128 floor = _mm_set1_ps(1e-3f);
    for (; k + 4 <= m; k += 4) {
      const uint32_t i0 = o[k], i1 = o[k + 1], i2 = o[k + 2], i3 = o[k + 3];
      cell_[k] = cell_of[i0], cell_[k + 1] = cell_of[i1], cell_[k + 2] = cell_of[i2],
      cell_[k + 3] = cell_of[i3];
      const __m128 x = _mm_setr_ps(X[i0], X[i1], X[i2], X[i3]);
      const __m128 y = _mm_setr_ps(Y[i0], Y[i1], Y[i2], Y[i3]);
      const __m128 z = _mm_setr_ps(Z[i0], Z[i1], Z[i2], Z[i3]);
      const __m128 r =
          _mm_sqrt_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(x, x), _mm_mul_ps(y, y)), _mm_mul_ps(z, z)));
      _mm_storeu_ps(range + k, r);
      if (with_sin) _mm_storeu_ps(sin_el + k, _mm_div_ps(z, _mm_max_ps(floor, r)));
    }
#endif
    for (; k < m; ++k) {
      const uint32_t i = o[k];
      cell_[k] = cell_of[i];
      range[k] = std::sqrt(X[i] * X[i] + Y[i] * Y[i] + Z[i] * Z[i]);
      if (with_sin) sin_el[k] = Z[i] / std::max(range[k], 1e-3f);
    }
  }

  /// Puts the points of each ring in azimuth order where the cloud's order is not the scan
  /// order. The high-pass compares each point with its neighbours along the ring; in a shuffled
  /// cloud consecutive points of a ring are anywhere on it, and asphalt reads as rough.
  /// Detection costs a few multiply-adds per point (no trigonometry), so ordered scans pay little.
  void sortRings(const PointCloud& pc, int rings) {
    const float *X = pc.x.data(), *Y = pc.y.data();
    const float cos2 = 0.99240388f;  // cos²(5°)
    for (int r = 0; r < rings; ++r) {
      uint32_t* b = order_.data() + offsets_[r];
      uint32_t* e = order_.data() + offsets_[r + 1];
      if (e - b < 3) continue;
      bool sort = azimuth_order_ == "sort";
      if (!sort) {
        // Every 4th consecutive pair is enough to tell a sweep from a shuffle.
        std::size_t apart = 0, pairs = 0;
        for (uint32_t* it = b + 1; it < e; it += 4, ++pairs) {
          const float x0 = X[it[-1]], y0 = Y[it[-1]], x1 = X[*it], y1 = Y[*it];
          const float dot = x0 * x1 + y0 * y1;
          const float n2 = (x0 * x0 + y0 * y0) * (x1 * x1 + y1 * y1);
          apart += !(dot > 0 && dot * dot >= cos2 * n2);
        }
        sort = apart * 50 > pairs;  // > 2 %
      }
      if (!sort) continue;
      ++sorted_rings_;
      keyed_.clear();
      for (uint32_t* it = b; it != e; ++it) keyed_.emplace_back(std::atan2(Y[*it], X[*it]), *it);
      std::sort(keyed_.begin(), keyed_.end());
      for (std::size_t k = 0; k < keyed_.size(); ++k) b[k] = keyed_[k].second;
    }
  }

  std::string layer_ = "roughness";
  int window_ = 2;
  double max_jump_m_ = 0.5;
  int min_points_ = 1;
  std::string azimuth_order_ = "auto";
  std::string residual_ = "range";
  int sorted_rings_ = 0;
  std::vector<std::pair<float, uint32_t>> keyed_;
  std::vector<uint32_t> offsets_, cursor_, order_, cnt_;
  double max_elev_step_deg_ = 0.15;
  std::vector<float> range_, sin_el_, sum_;
  std::vector<int32_t> cell_;  // in ring order, + 8 for the vector paths' last group
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::Roughness, terramrf::PluginKind::kFeature, "roughness",
                "roughness f_r: RMS of high-pass filtered ranges along each laser ring "
                "(paper 000 §4.3, Neuhaus et al.)")
