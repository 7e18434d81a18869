// Roughness f_r (paper 000 §4.3, after Neuhaus et al.): along each laser ring the measured ranges
// are high-pass filtered; what remains is assigned to the cells the points fall in.
//
// Why it works: at grazing incidence a small height change δz moves the range by about
// δz / sin(incidence), so a few centimetres of grass or gravel show up as decimetres of range
// jitter along a ring, while asphalt only shows the sensor's range noise.
//
// Filter: residual_i = r_i − mean(r_{i−w..i+w} \ r_i) over the ring's neighbours in scan order
// (azimuth order for rings the cloud stores shuffled, see sortRings);
// a neighbour beyond `max_jump_m` or missing ends the window (object edges are not roughness);
// a neighbour whose beam elevation differs by more than `max_elevation_step_deg` belongs to
// another laser and is passed over. Rings recovered by elevation binning from voxel-thinned
// clouds (the Open3D-ML scans) interleave two lasers near the sensor, whose ground ranges differ
// by decimetres there: without the check their asphalt read as grass (road recall 0.79 → 0.92).
// Cell value: RMS of its points' residuals [m].
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "terramrf/plugin.hpp"

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
    int rings = 0;
    for (uint16_t r : pc.ring)
      if (r != kUnknownRing) rings = std::max(rings, r + 1);
    offsets_.assign(rings + 1, 0);
    for (uint16_t r : pc.ring)
      if (r != kUnknownRing) ++offsets_[r + 1];
    for (int r = 0; r < rings; ++r) offsets_[r + 1] += offsets_[r];
    order_.resize(offsets_[rings]);
    cursor_.assign(offsets_.begin(), offsets_.end() - 1);
    for (std::size_t i = 0; i < n; ++i)
      if (pc.ring[i] != kUnknownRing) order_[cursor_[pc.ring[i]]++] = static_cast<uint32_t>(i);
    sorted_rings_ = 0;
    if (azimuth_order_ != "scan") sortRings(pc, rings);
    ctx.metrics[name() + ".sorted_rings"] = sorted_rings_;
    range_.resize(order_.size());
    const bool elev = max_elev_step_deg_ > 0;
    const bool vertical = residual_ == "vertical";
    if (elev || vertical) sin_el_.resize(order_.size());
    const float max_dsin = static_cast<float>(std::sin(max_elev_step_deg_ * M_PI / 180));
    // Passed-over neighbours widen the search, up to 4 windows along the ring.
    const int span = elev ? 4 * window_ : window_;
    for (std::size_t k = 0; k < order_.size(); ++k) {
      const uint32_t i = order_[k];
      range_[k] = std::sqrt(pc.x[i] * pc.x[i] + pc.y[i] * pc.y[i] + pc.z[i] * pc.z[i]);
      if (elev || vertical) sin_el_[k] = pc.z[i] / std::max(range_[k], 1e-3f);
    }
    sum_.assign(g.cells(), 0.f);
    cnt_.assign(g.cells(), 0);
    const auto& cell_of = g.cellOfPoint();
    const float jump = static_cast<float>(max_jump_m_);
    std::size_t passed_over = 0, residuals = 0;
    for (int r = 0; r < rings; ++r) {
      const int b = static_cast<int>(offsets_[r]), e = static_cast<int>(offsets_[r + 1]);
      for (int k = b; k < e; ++k) {
        const int cell = cell_of[order_[k]];
        if (cell < 0) continue;
        const float rk = range_[k];
        float s = 0;
        int m = 0;
        const float sk = elev ? sin_el_[k] : 0.f;
        for (int j = k - 1, got = 0; j >= b && j >= k - span && got < window_; --j) {
          if (elev && std::abs(sin_el_[j] - sk) > max_dsin) {
            ++passed_over;
            continue;
          }
          if (std::abs(range_[j] - rk) > jump) break;
          s += range_[j], ++m, ++got;
        }
        const int left = m;
        for (int j = k + 1, got = 0; j < e && j <= k + span && got < window_; ++j) {
          if (elev && std::abs(sin_el_[j] - sk) > max_dsin) {
            ++passed_over;
            continue;
          }
          if (std::abs(range_[j] - rk) > jump) break;
          s += range_[j], ++m, ++got;
        }
        if (left == 0 || m == left) continue;  // need neighbours on both sides
        const float res = vertical ? (rk - s / m) * std::abs(sin_el_[k]) : rk - s / m;
        sum_[cell] += res * res;
        ++cnt_[cell];
        ++residuals;
      }
    }
    // Neighbours passed over per residual: 2.6–3.0 on the Open3D-ML scans, whose recovered rings
    // interleave lasers; about 0.2 on KITTI's own ring order, from points beyond object edges
    // (their z/r differs through the laser's offset from the point origin).
    ctx.metrics[name() + ".passed_over_per_point"] =
        residuals ? static_cast<double>(passed_over) / residuals : 0.0;
    for (std::size_t c = 0; c < g.cells(); ++c)
      if (cnt_[c] >= static_cast<uint32_t>(min_points_)) out[c] = std::sqrt(sum_[c] / cnt_[c]);
  }

 private:
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
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::Roughness, terramrf::PluginKind::kFeature, "roughness",
                "roughness f_r: RMS of high-pass filtered ranges along each laser ring "
                "(paper 000 §4.3, Neuhaus et al.)")
