#include "terramrf/meshing/building_mask.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
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
  // Tile by tile, each over its own vertices plus the margin the masking reads around them: the
  // ground window (w), the dilation (t) and the line masks (s). One array over the whole drive's
  // bounding box took ~50 bytes per cell, most of it empty: a 2 km diagonal drive at 0.125 m
  // needed ~13 GB at the end of the run. Cells beyond the drive read as no data, as the edge of
  // that box did (every window is normalised by its full size, so an empty cell and a missing one
  // weigh the same).
  const int w = std::max(1, int(std::lround(p.ground_window_m / mesh.params().cell_m)));
  const int tol = std::max(0, p.line_tolerance);
  const int margin = w + tol + p.size;
  const int R = span + 1 + 2 * margin, Cn = R;
  const std::size_t NC = std::size_t(R) * Cn;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<float> elev(NC), zmin(NC), hrel(NC), hl(NC), tmp(NC), resp(NC);
  std::vector<uint8_t> cls(NC), out(NC);
  std::vector<double> S((R + 1) * std::size_t(Cn + 1)), Ncnt(S.size()), I(S.size());
  auto at = [&](int r, int c) { return std::size_t(r) * (Cn + 1) + c; };
  struct Decided {
    VertexKey key;
    uint8_t cls;
    float response;
  };
  std::vector<Decided> decided;  // object vertices only: a small part of the mesh

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

  for (auto& [tkey, tp] : mesh.tiles()) {
    const Tile& tile = *tp;
    const int64_t gi0 = int64_t(tile.ti) * span - margin, gj0 = int64_t(tile.tj) * span - margin;
    std::fill(elev.begin(), elev.end(), nan);
    std::fill(zmin.begin(), zmin.end(), nan);
    std::fill(cls.begin(), cls.end(), uint8_t(0));
    // The window reaches at most one tile beyond this one (margin < span).
    for (int di = -1; di <= 1; ++di)
      for (int dj = -1; dj <= 1; ++dj) {
        const Tile* nb = mesh.tile(tile.ti + di, tile.tj + dj);
        if (!nb) continue;
        for (int i = 0; i < nb->n; ++i)
          for (int j = 0; j < nb->n; ++j) {
            const int k = i * nb->n + j;
            if (!nb->hasData(k) || !mesh.owns(*nb, i, j)) continue;
            const int64_t r = int64_t(nb->ti) * span + i - gi0,
                          c = int64_t(nb->tj) * span + j - gj0;
            if (r < 0 || c < 0 || r >= R || c >= Cn) continue;
            const std::size_t q = std::size_t(r) * Cn + std::size_t(c);
            elev[q] = mesh.displayHeight(*nb, k);
            zmin[q] = nb->z_min[k];
            cls[q] = uint8_t(nb->cls[k]);
          }
      }

    // Local ground height: mean of the ground vertices in a square window (integral images).
    for (int r = 0; r < R; ++r)
      for (int c = 0; c < Cn; ++c) {
        const std::size_t q = std::size_t(r) * Cn + c;
        const bool g = cls[q] == uint8_t(VertexClass::kGround);
        S[at(r + 1, c + 1)] = S[at(r, c + 1)] + S[at(r + 1, c)] - S[at(r, c)] + (g ? elev[q] : 0.0);
        Ncnt[at(r + 1, c + 1)] =
            Ncnt[at(r, c + 1)] + Ncnt[at(r + 1, c)] - Ncnt[at(r, c)] + (g ? 1 : 0);
      }
    std::fill(hrel.begin(), hrel.end(), 0.f);
    for (int r = 0; r < R; ++r)
      for (int c = 0; c < Cn; ++c) {
        const std::size_t q = std::size_t(r) * Cn + c;
        if (cls[q] != uint8_t(VertexClass::kObject)) continue;
        const int r0 = std::max(0, r - w), r1 = std::min(R, r + w + 1);
        const int c0 = std::max(0, c - w), c1 = std::min(Cn, c + w + 1);
        const double n = Ncnt[at(r1, c1)] - Ncnt[at(r0, c1)] - Ncnt[at(r1, c0)] + Ncnt[at(r0, c0)];
        double g;
        if (n > 0)
          g = (S[at(r1, c1)] - S[at(r0, c1)] - S[at(r1, c0)] + S[at(r0, c0)]) / n;
        else
          g = zmin[q];
        hrel[q] = std::max(0.f, float(elev[q] - g));
      }

    // A wall is sampled as a 1–2 vertex thick staircase with missing vertices (beam spacing), so
    // a straight digital line through a wall vertex leaves the wall after a few cells. Grey-level
    // dilation by a (2t+1)² window closes those gaps and steps; an isolated foliage return only
    // grows into a (2t+1)² blob, which still fills a small part of a (2s+1) long line.
    hl = hrel;
    if (tol > 0) {
      for (int r = 0; r < R; ++r)
        for (int c = 0; c < Cn; ++c) {
          float m = 0;
          for (int cc = std::max(0, c - tol); cc <= std::min(Cn - 1, c + tol); ++cc)
            m = std::max(m, hrel[std::size_t(r) * Cn + cc]);
          tmp[std::size_t(r) * Cn + c] = m;
        }
      for (int r = 0; r < R; ++r)
        for (int c = 0; c < Cn; ++c) {
          float m = 0;
          for (int rr = std::max(0, r - tol); rr <= std::min(R - 1, r + tol); ++rr)
            m = std::max(m, tmp[std::size_t(rr) * Cn + c]);
          hl[std::size_t(r) * Cn + c] = m;
        }
    }
    // Window sums of hl (integral image): the off-line sum is the window's minus the line's.
    for (int r = 0; r < R; ++r)
      for (int c = 0; c < Cn; ++c)
        I[at(r + 1, c + 1)] =
            I[at(r, c + 1)] + I[at(r + 1, c)] - I[at(r, c)] + hl[std::size_t(r) * Cn + c];

    // This tile's own vertices (each global vertex is decided by the one tile that owns it).
    std::fill(out.begin(), out.end(), uint8_t(0));
    for (int i = 0; i < tile.n; ++i)
      for (int j = 0; j < tile.n; ++j) {
        if (!mesh.owns(tile, i, j)) continue;
        const int r = i + margin, c = j + margin;
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
    // Decided from the classes before any tile's write-back (those are read as kObject by the
    // tiles after this one): kept aside, written after the loop.
    for (int i = 0; i < tile.n; ++i)
      for (int j = 0; j < tile.n; ++j) {
        const std::size_t q = std::size_t(i + margin) * Cn + (j + margin);
        if (out[q])
          decided.push_back({VertexKey{int64_t(tile.ti) * span + i, int64_t(tile.tj) * span + j},
                             out[q], resp[q]});
      }
  }
  // Write back to every copy of each vertex.
  for (const auto& d : decided)
    mesh.forEachCopy(d.key, [&](Tile& t, int k) {
      t.cls[k] = VertexClass(d.cls);
      t.mask_response[k] = d.response;
    });
  return st;
}

}  // namespace terramrf::meshing
