// Pre-classification by the eigenvalue along the surface normal (paper 000 §4.1, eq. 1):
// h = λ_k with k = argmax_i |e_iᵀ z| over the eigenvectors of the cell's point covariance.
// Drivable cells are locally planar, so the variance along the normal stays small even on slopes;
// anything vertical (walls, trunks, cars) has a large one.
#include <cmath>

#include "normal_eigenvalue.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {

/// Values of the `preclass` layer.
enum PreClass : int { kPreUnknown = 0, kPreFlat = 1, kPreObstacle = 2 };

class EigenPreclass final : public Stage {
 public:
  void declare(ParamDecl& d) override {
    d.add("threshold_m2", threshold_m2_,
          "cells whose variance along the surface normal (λ_k of eq. 1) exceeds this are obstacles")
        .unit("m^2").range(0, 100);
    d.add("min_points", min_points_,
          "cells with fewer points get λ = NaN and pre-class unknown (a covariance needs 3)")
        .unit("points").range(3, 1000);
    d.add("eigenvalue_layer", eigen_layer_, "name of the λ_k output layer [m²]");
    d.add("preclass_layer", preclass_layer_,
          "name of the pre-class output layer (0 unknown, 1 flat, 2 obstacle)");
  }
  std::vector<std::string> reads() const override { return {artefacts::kPoints}; }
  std::vector<std::string> writes() const override { return {eigen_layer_, preclass_layer_}; }

  void process(FrameContext& ctx) override {
    TerrainGrid& g = *ctx.grid;
    const PointCloud& pc = ctx.frame->points;
    Layer& lam = g.add(eigen_layer_);
    Layer& pre = g.add(preclass_layer_, kPreUnknown);
    const float* X = pc.x.data();
    const float* Y = pc.y.data();
    const float* Z = pc.z.data();
    int obstacles = 0;
    for (int c = 0, n = static_cast<int>(g.cells()); c < n; ++c) {
      const uint32_t cnt = g.count(c);
      if (cnt < static_cast<uint32_t>(min_points_)) continue;
      // Moments about the first point: exact enough in float-free double, and one pass.
      const uint32_t* it = g.pointsBegin(c);
      const uint32_t* end = g.pointsEnd(c);
      const double x0 = X[*it], y0 = Y[*it], z0 = Z[*it];
      double sx = 0, sy = 0, sz = 0, sxx = 0, sxy = 0, sxz = 0, syy = 0, syz = 0, szz = 0;
      for (; it != end; ++it) {
        const double x = X[*it] - x0, y = Y[*it] - y0, z = Z[*it] - z0;
        sx += x; sy += y; sz += z;
        sxx += x * x; sxy += x * y; sxz += x * z;
        syy += y * y; syz += y * z; szz += z * z;
      }
      const double inv = 1.0 / cnt;
      const double mx = sx * inv, my = sy * inv, mz = sz * inv;
      Eigen::Matrix3d C;
      C(0, 0) = sxx * inv - mx * mx;
      C(0, 1) = C(1, 0) = sxy * inv - mx * my;
      C(0, 2) = C(2, 0) = sxz * inv - mx * mz;
      C(1, 1) = syy * inv - my * my;
      C(1, 2) = C(2, 1) = syz * inv - my * mz;
      C(2, 2) = szz * inv - mz * mz;
      const double h = std::max(0.0, normalEigenvalue(C));
      lam[c] = static_cast<float>(h);
      const bool obstacle = h > threshold_m2_;
      pre[c] = obstacle ? kPreObstacle : kPreFlat;
      obstacles += obstacle;
    }
    ctx.metrics[name() + ".obstacle_cells"] = obstacles;
  }

 private:
  double threshold_m2_ = 0.01;
  int min_points_ = 3;
  std::string eigen_layer_ = "normal_eigenvalue";
  std::string preclass_layer_ = "preclass";
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::EigenPreclass, terramrf::PluginKind::kFeature, "eigen_preclass",
                "pre-classification flat/obstacle by the eigenvalue along the surface normal "
                "(paper 000 eq. 1); writes λ_k and the pre-class")
