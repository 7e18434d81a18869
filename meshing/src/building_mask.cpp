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

  // A wall is sampled as a 1–2 vertex thick staircase with missing vertices (beam spacing), so a
  // straight digital line through a wall vertex leaves the wall after a few cells. Grey-level
  // dilation by a (2t+1)² window closes those gaps and steps; an isolated foliage return only
  // grows into a (2t+1)² blob, which still fills a small part of a (2s+1) long line.
  std::vector<float> hl = hrel;
  if (p.line_tolerance > 0) {
    const int t = p.line_tolerance;
    std::vector<float> tmp(NC, 0.f);
    for (int r = 0; r < R; ++r)
      for (int c = 0; c < Cn; ++c) {
        float m = 0;
        for (int cc = std::max(0, c - t); cc <= std::min(Cn - 1, c + t); ++cc)
          m = std::max(m, hrel[std::size_t(r) * Cn + cc]);
        tmp[std::size_t(r) * Cn + c] = m;
      }
    for (int r = 0; r < R; ++r)
      for (int c = 0; c < Cn; ++c) {
        float m = 0;
        for (int rr = std::max(0, r - t); rr <= std::min(R - 1, r + t); ++rr)
          m = std::max(m, tmp[std::size_t(rr) * Cn + c]);
        hl[std::size_t(r) * Cn + c] = m;
      }
  }
  // Window sums of hl (integral image): the off-line sum is the window's minus the line's.
  std::vector<double> I((R + 1) * std::size_t(Cn + 1), 0.0);
  for (int r = 0; r < R; ++r)
    for (int c = 0; c < Cn; ++c)
      I[at(r + 1, c + 1)] = I[at(r, c + 1)] + I[at(r + 1, c)] - I[at(r, c)] + hl[std::size_t(r) * Cn + c];

  // Line masks (Fig. 10): the cells within half a cell of a line through the centre, per
  // orientation; f = +1/|line| there and −1/|rest| on the rest of the (2s+1)² window.
  std::vector<std::vector<std::pair<int, int>>> lines(std::max(1, p.orientations));
  const double pi = 3.14159265358979323846;
  for (std::size_t o = 0; o < lines.size(); ++o) {
    const double th = pi * double(o) / double(lines.size());
    const double cs = std::cos(th), sn = std::sin(th);
    for (int m = -p.size; m <= p.size; ++m)
      for (int n = -p.size; n <= p.size; ++n)
        if (std::abs(-sn * m + cs * n) <= 0.5 + 1e-9) lines[o].push_back({m, n});
  }
  const double n_window = double(2 * p.size + 1) * double(2 * p.size + 1);
  std::vector<float> resp(NC, nan);
  std::vector<uint8_t> out(NC, 0);
  for (int r = 0; r < R; ++r)
    for (int c = 0; c < Cn; ++c) {
      const std::size_t q = std::size_t(r) * Cn + c;
      if (cls[q] != uint8_t(VertexClass::kObject)) continue;
      ++st.object_vertices;
      const int r0 = std::max(0, r - p.size), r1 = std::min(R, r + p.size + 1);
      const int c0 = std::max(0, c - p.size), c1 = std::min(Cn, c + p.size + 1);
      const double window = I[at(r1, c1)] - I[at(r0, c1)] - I[at(r1, c0)] + I[at(r0, c0)];
      float best = -1e30f;
      for (const auto& line : lines) {
        double on = 0, on_raised = 0;
        int n_raised = 0;
        for (const auto& [m, n] : line) {
          const int rr = r + m, cc = c + n;
          if (rr < 0 || cc < 0 || rr >= R || cc >= Cn) continue;
          const float h = hl[std::size_t(rr) * Cn + cc];
          on += h;
          if (h > 0) {
            on_raised += h;
            ++n_raised;
          }
        }
        const double off = (window - on) / std::max(1.0, n_window - double(line.size()));
        double u = on / double(line.size()) - off;  // eq. 13 with the zero-sum mask
        if (p.normalise) {
          // Divide by the height a complete wall along this line would give: the mean of the
          // raised cells on it (at least this vertex's own).
          const double wall = std::max(double(hl[q]), n_raised ? on_raised / n_raised : 0.0);
          u = wall > 1e-6 ? u / wall : 0.0;
        }
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
