#include "terramrf/meshing/building_mask.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <vector>

namespace terramrf::meshing {

void classifyGroundObject(TerrainMesh& mesh) {
  for (auto& [key, tp] : mesh.tiles()) {
    Tile& t = *tp;
    for (std::size_t k = 0; k < t.vertices(); ++k) {
      if (!t.count[k] || (!t.ground_votes[k] && !t.object_votes[k])) {
        t.cls[k] = VertexClass::kUnknown;
      } else if (t.ground_votes[k] >= t.object_votes[k]) {
        t.cls[k] = VertexClass::kGround;
      } else if (t.cls[k] != VertexClass::kTree && t.cls[k] != VertexClass::kBuilding) {
        t.cls[k] = VertexClass::kObject;
      }
    }
  }
}

MaskStats classifyVertices(TerrainMesh& mesh, const MaskParams& p) {
  MaskStats st;
  for (auto& [key, tp] : mesh.tiles()) {
    Tile& t = *tp;
    for (std::size_t k = 0; k < t.vertices(); ++k)
      if (t.cls[k] == VertexClass::kTree || t.cls[k] == VertexClass::kBuilding) t.cls[k] = VertexClass::kObject;
  }
  classifyGroundObject(mesh);
  if (mesh.tiles().empty()) return st;
  const int span = mesh.tileSpan();
  int ti0 = INT_MAX, tj0 = INT_MAX, ti1 = INT_MIN, tj1 = INT_MIN;
  for (const auto& [key, tp] : mesh.tiles()) {
    ti0 = std::min(ti0, key.first);
    ti1 = std::max(ti1, key.first);
    tj0 = std::min(tj0, key.second);
    tj1 = std::max(tj1, key.second);
  }
  const int R = (ti1 - ti0 + 1) * span + 1, Cn = (tj1 - tj0 + 1) * span + 1;
  const int64_t gi0 = int64_t(ti0) * span, gj0 = int64_t(tj0) * span;
  const std::size_t NC = std::size_t(R) * Cn;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<float> elev(NC, nan), zmin(NC, nan);
  std::vector<uint8_t> cls(NC, 0);
  mesh.forEachVertex([&](const Tile& t, int k, const VertexKey& key) {
    const std::size_t c = std::size_t(key.first - gi0) * Cn + std::size_t(key.second - gj0);
    elev[c] = mesh.displayHeight(t, k);
    zmin[c] = t.z_min[k];
    cls[c] = uint8_t(t.cls[k]);
  });

  // Local ground height: mean of the ground vertices in a square window (integral images).
  const int w = std::max(1, int(std::lround(p.ground_window_m / mesh.params().cell_m)));
  std::vector<double> S((R + 1) * std::size_t(Cn + 1), 0.0), Ncnt(S.size(), 0.0);
  auto at = [&](int r, int c) { return std::size_t(r) * (Cn + 1) + c; };
  for (int r = 0; r < R; ++r)
    for (int c = 0; c < Cn; ++c) {
      const std::size_t q = std::size_t(r) * Cn + c;
      const bool g = cls[q] == uint8_t(VertexClass::kGround);
      S[at(r + 1, c + 1)] = S[at(r, c + 1)] + S[at(r + 1, c)] - S[at(r, c)] + (g ? elev[q] : 0.0);
      Ncnt[at(r + 1, c + 1)] = Ncnt[at(r, c + 1)] + Ncnt[at(r + 1, c)] - Ncnt[at(r, c)] + (g ? 1 : 0);
    }
  std::vector<float> hrel(NC, 0.f);
  for (int r = 0; r < R; ++r)
    for (int c = 0; c < Cn; ++c) {
      const std::size_t q = std::size_t(r) * Cn + c;
      if (cls[q] != uint8_t(VertexClass::kObject)) continue;
      const int r0 = std::max(0, r - w), r1 = std::min(R, r + w + 1);
      const int c0 = std::max(0, c - w), c1 = std::min(Cn, c + w + 1);
      const double n = Ncnt[at(r1, c1)] - Ncnt[at(r0, c1)] - Ncnt[at(r1, c0)] + Ncnt[at(r0, c0)];
      double g;
      if (n > 0) g = (S[at(r1, c1)] - S[at(r0, c1)] - S[at(r1, c0)] + S[at(r0, c0)]) / n;
      else g = zmin[q];
      hrel[q] = std::max(0.f, float(elev[q] - g));
    }

  // Line masks: offsets on the line and off it, per orientation.
  struct Mask {
    std::vector<std::pair<int, int>> on, off;
  };
  std::vector<Mask> masks(std::max(1, p.orientations));
  const double pi = 3.14159265358979323846;
  for (std::size_t o = 0; o < masks.size(); ++o) {
    const double th = pi * double(o) / double(masks.size());
    const double cs = std::cos(th), sn = std::sin(th);
    for (int m = -p.size; m <= p.size; ++m)
      for (int n = -p.size; n <= p.size; ++n) {
        const double dist = std::abs(-sn * m + cs * n);
        (dist <= 0.5 + 1e-9 ? masks[o].on : masks[o].off).push_back({m, n});
      }
  }
  std::vector<float> resp(NC, nan);
  std::vector<uint8_t> out(NC, 0);
  for (int r = 0; r < R; ++r)
    for (int c = 0; c < Cn; ++c) {
      const std::size_t q = std::size_t(r) * Cn + c;
      if (cls[q] != uint8_t(VertexClass::kObject)) continue;
      ++st.object_vertices;
      float best = -1e30f;
      for (const Mask& mk : masks) {
        double on = 0, off = 0;
        for (const auto& [m, n] : mk.on) {
          const int rr = r + m, cc = c + n;
          if (rr >= 0 && cc >= 0 && rr < R && cc < Cn) on += hrel[std::size_t(rr) * Cn + cc];
        }
        for (const auto& [m, n] : mk.off) {
          const int rr = r + m, cc = c + n;
          if (rr >= 0 && cc >= 0 && rr < R && cc < Cn) off += hrel[std::size_t(rr) * Cn + cc];
        }
        on /= double(mk.on.size());
        off /= double(std::max<std::size_t>(1, mk.off.size()));
        double u = on - off;  // eq. 13 with the zero-sum mask
        if (p.normalise) u = on > 1e-6 ? u / on : 0.0;
        best = std::max(best, float(u));
      }
      resp[q] = best;
      const bool building = best >= p.threshold && hrel[q] >= p.min_height_m;
      out[q] = uint8_t(building ? VertexClass::kBuilding : VertexClass::kTree);
      ++(building ? st.buildings : st.trees);
    }
  // Write back to every copy of each vertex.
  for (int r = 0; r < R; ++r)
    for (int c = 0; c < Cn; ++c) {
      const std::size_t q = std::size_t(r) * Cn + c;
      if (!out[q]) continue;
      mesh.forEachCopy({gi0 + r, gj0 + c}, [&](Tile& t, int k) {
        t.cls[k] = VertexClass(out[q]);
        t.mask_response[k] = resp[q];
      });
    }
  return st;
}

}  // namespace terramrf::meshing
