// Relative height: a cell's lowest point minus the median lowest point of the cells around it.
//
// Why: height difference and eq. 1 only see inside a cell, so the flat floor of a ditch or a pit
// (a negative obstacle, a limitation paper 000 names) looks like road. Against its surroundings
// the floor sits clearly below the local ground; raised flat tops (a low wall, a car roof seen
// alone in a cell) sit above it. Units: metres, negative = below the surroundings.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "terramrf/plugin.hpp"

namespace terramrf {

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
    const float* Z = ctx.frame->points.z.data();
    Layer& out = g.add(layer_);
    const int R = g.rows(), C = g.cols();
    zmin_.assign(g.cells(), std::numeric_limits<float>::quiet_NaN());
    for (int c = 0; c < static_cast<int>(g.cells()); ++c) {
      if (!g.count(c)) continue;
      float lo = std::numeric_limits<float>::max();
      for (const uint32_t* it = g.pointsBegin(c); it != g.pointsEnd(c); ++it) lo = std::min(lo, Z[*it]);
      zmin_[c] = lo;
    }
    // The median of up to (2r+1)² − 1 values per cell by rank counting (rankSelect): counts of
    // smaller and not larger values vectorise, where a selection's comparisons are branches the
    // CPU cannot predict (nth_element 1.59 → 0.62 ms on KITTI object 000000, radius 3).
    const int side = 2 * radius_ + 1;
    const int cap = (side * side + 7) / 8 * 8;  // padded to whole vectors with +inf
    std::vector<float>& win = window_;
    win.resize(cap + 1);  // + 1: the gather writes one past the last valid value
    constexpr float kInf = std::numeric_limits<float>::infinity();
    for (int r = 0; r < R; ++r) {
      for (int c = 0; c < C; ++c) {
        const float z = zmin_[r * C + c];
        if (std::isnan(z)) continue;
        // Gathered without branches: every value is written, only valid ones advance n.
        int n = 0;
        const int c0 = std::max(0, c - radius_), c1 = std::min(C - 1, c + radius_);
        for (int rr = std::max(0, r - radius_); rr <= std::min(R - 1, r + radius_); ++rr) {
          const float* row = &zmin_[rr * C];
          for (int cc = c0; cc <= c1; ++cc) {
            const float v = row[cc];
            win[n] = v;
            n += (v == v) & (rr != r || cc != c);
          }
        }
        if (n < min_neighbours_) continue;
        const int padded = (n + 7) / 8 * 8;
        std::fill(win.begin() + n, win.begin() + padded, kInf);
        out[r * C + c] =
            z - rankSelect(win.data(), n, padded, std::min(n - 1, static_cast<int>(quantile_ * n)));
      }
    }
  }

 private:
  /// The value of rank k (0-based, ascending) among v[0..n); v[n..padded) hold +inf. A value
  /// whose count of smaller values is ≤ k and of not larger values is > k is it; any other value
  /// evaluated narrows the interval the answer lies in, and values outside that interval are not
  /// counted at all, so only a handful of the n are (as in a quickselect with random pivots).
  static float rankSelect(const float* v, int n, int padded, int k) {
    float lo = -std::numeric_limits<float>::infinity(), hi = std::numeric_limits<float>::infinity();
    for (int i = 0; i < n; ++i) {
      const float x = v[i];
      if (!(x > lo && x < hi)) continue;
      int less = 0, leq = 0;
      for (int j = 0; j < padded; ++j) {
        less += v[j] < x;
        leq += v[j] <= x;
      }
      if (less > k) {
        hi = x;
      } else if (leq <= k) {
        lo = x;
      } else {
        return x;
      }
    }
    return v[0];  // unreachable for n > k
  }

  std::string layer_ = "relative_height";
  int radius_ = 3;
  int min_neighbours_ = 4;
  double quantile_ = 0.5;
  std::vector<float> zmin_, window_;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::RelativeHeight, terramrf::PluginKind::kFeature, "relative_height",
                "lowest point of a cell relative to the median lowest point around it "
                "(negative obstacles such as ditches)")
