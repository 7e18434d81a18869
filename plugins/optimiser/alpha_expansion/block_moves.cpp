#include "block_moves.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>

#include "frame_graph.hpp"

namespace terramrf::expansion {

void BlockMoves::touch(int i, int R, int C) {
  const int r = i / C, c = i % C;
  for (int br = std::max(0, r - 2); br <= std::min(R - 2, r + 1); ++br)
    for (int bc = std::max(0, c - 2); bc <= std::min(C - 2, c + 1); ++bc) dirty_[br * C + bc] = 1;
}

double BlockMoves::pass(const EnergyModel& em, std::vector<uint8_t>& lab,
                        std::vector<int>& changed) {
  const int R = em.rows, C = em.cols, K = em.numLabels();
  const double wb = em.beta, wd = em.beta_diagonal;
  // Each cell's eq. 12 sums given all its current neighbours; a block's cells then need only
  // their three inner pairs taken back out, and a taken move updates the sums of its cells'
  // neighbours. Computed when a searched block first needs the cell (a pass after the first
  // searches only the blocks around what changed since).
  sums_.begin(em, lab);
  auto sums = [&](int i) { return sums_.at(em, i); };
  // A cell's margin: how far its second-best label's sum lies above its own label's.
  margin_.resize(em.cells());
  margin_valid_.assign(em.cells(), 0);
  auto margin = [&](int i) {
    if (margin_valid_[i]) return margin_[i];
    const double* s = sums(i);
    const int l = lab[i];
    double m = INFINITY;
    for (int k = 0; k < K; ++k)
      if (k != l) m = std::min(m, s[k]);
    margin_valid_[i] = 1;
    return margin_[i] = m - s[l];
  };
  auto relabel = [&](int i, int to) {
    const int from = lab[i];
    lab[i] = static_cast<uint8_t>(to);
    margin_valid_[i] = 0;  // a margin is from the cell's label
    changed.push_back(i);
    sums_.relabel(em, i, from, to, [&](int n) { margin_valid_[n] = 0; });
    touch(i, R, C);
  };
  // Inner neighbours of block cell j (cells 0 1 / 2 3): edge, edge, diagonal.
  static constexpr int kInner[4][3] = {{1, 2, 3}, {0, 3, 2}, {3, 0, 1}, {2, 1, 0}};
  const double w_inner[3] = {wb, wb, wd};
  const double inner_all = 2 * wb + wd;  // Σ w_inner: every cell has two inner edges, one diagonal
  // With non-negative weights, a block of four non-fixed cells whose labels are not all equal
  // pays at least the cheapest cut of its six pairs over their minimum: one cell against three
  // (2wb + wd), or top/bottom or left/right (2wb + 2wd), or the diagonals apart (4wb), each
  // pair 2w.
  const double split_extra = wb >= 0 && wd >= 0 ? 2 * std::min(2 * wb + wd, 4 * wb) : 0.0;
  auto dl = [](int a, int b) { return a == b ? -1.0 : 1.0; };
  double total = 0;
  double local[4][kMaxLabels], f2[kMaxLabels], f3[kMaxLabels];
  for (int r = 0; r + 1 < R; ++r)
    for (int c = 0; c + 1 < C; ++c) {
      if (!dirty_[r * C + c]) continue;
      dirty_[r * C + c] = 0;
      const int cell[4] = {r * C + c, r * C + c + 1, (r + 1) * C + c, (r + 1) * C + c + 1};
      // A fixed cell keeps its label and has no pairs; the block's other cells still move
      // together (two diagonal neighbours next to a cell without points, say). With one cell
      // or none left to move, an expansion already covers it.
      bool free[4];
      int n_free = 0;
      for (int j = 0; j < 4; ++j) n_free += free[j] = !em.fixed[cell[j]];
      if (n_free < 2) continue;
      const bool all_free = n_free == 4;
      int cur[4];
      for (int j = 0; j < 4; ++j) cur[j] = lab[cell[j]];
      // Most blocks are uniform and settled, and the bound below skips them. For a uniform
      // block it reduces to a test per cell: every other label at least 2·Σ w_inner above the
      // block's label in the cell's sums (then neither a uniform relabelling nor a split can
      // be lower), which costs a fraction of the bound's arithmetic.
      if (all_free && split_extra > 0 && cur[0] == cur[1] && cur[0] == cur[2] && cur[0] == cur[3] &&
          margin(cell[0]) >= 2 * inner_all && margin(cell[1]) >= 2 * inner_all &&
          margin(cell[2]) >= 2 * inner_all && margin(cell[3]) >= 2 * inner_all)
        continue;
      // The six inner pairs' weights, 0 where a cell is fixed: 0–1, 2–3, 0–2, 1–3 (edges),
      // 0–3, 1–2 (diagonals).
      auto pw = [&](int a, int b, double w) { return free[a] && free[b] ? w : 0.0; };
      const double w01 = pw(0, 1, wb), w23 = pw(2, 3, wb), w02 = pw(0, 2, wb), w13 = pw(1, 3, wb),
                   w03 = pw(0, 3, wd), w12 = pw(1, 2, wd);
      const double inner_min = -std::max(0.0, w01) - std::max(0.0, w23) - std::max(0.0, w02) -
                               std::max(0.0, w13) - std::max(0.0, w03) - std::max(0.0, w12);
      // local[j][k]: unary of cell j under k plus its pairs with non-fixed cells outside; a
      // fixed cell costs nothing at its label and cannot take another.
      double each_min = 0, now = 0;
      for (int j = 0; j < 4; ++j) {
        if (!free[j]) {
          for (int k = 0; k < K; ++k) local[j][k] = k == cur[j] ? 0.0 : INFINITY;
          continue;
        }
        const double* s = sums(cell[j]);
        double inner = 0;
        for (int m = 0; m < 3; ++m) inner += free[kInner[j][m]] ? w_inner[m] : 0.0;
        for (int k = 0; k < K; ++k) local[j][k] = s[k] - inner;
        for (int m = 0; m < 3; ++m)
          if (free[kInner[j][m]]) local[j][cur[kInner[j][m]]] += 2 * w_inner[m];
        each_min += *std::min_element(local[j], local[j] + K);
        now += local[j][cur[j]];
      }
      now += w01 * dl(cur[0], cur[1]) + w23 * dl(cur[2], cur[3]) + w02 * dl(cur[0], cur[2]) +
             w13 * dl(cur[1], cur[3]) + w03 * dl(cur[0], cur[3]) + w12 * dl(cur[1], cur[2]);
      const double eps = 1e-9 * (1.0 + std::abs(now));
      // A lower bound of the block's best energy: the best labelling with all four equal, or
      // one that splits the block and so pays split_extra, each cell at its best label.
      double uniform = INFINITY;
      for (int k = 0; k < K; ++k)
        uniform = std::min(uniform, local[0][k] + local[1][k] + local[2][k] + local[3][k]);
      const double bound = inner_min + std::min(uniform, each_min + (all_free ? split_extra : 0.0));
      if (now - bound <= eps) continue;
      double best_e = now - eps;
      int best[4] = {-1, -1, -1, -1};
      for (int x0 = 0; x0 < K; ++x0)
        for (int x1 = 0; x1 < K; ++x1) {
          const double top = local[0][x0] + local[1][x1] + w01 * dl(x0, x1);
          if (!(top < INFINITY)) continue;  // a fixed cell at another label
          // Bottom pair given the top: f2 = cell 2 with its pairs to 0 (edge) and 1 (diagonal),
          // f3 = cell 3 with its pairs to 1 (edge) and 0 (diagonal).
          int b2 = 0, s2 = -1, b3 = 0, s3 = -1, same = 0;
          double same_e = INFINITY;
          for (int k = 0; k < K; ++k) {
            f2[k] = local[2][k] + w02 * dl(x0, k) + w12 * dl(x1, k);
            f3[k] = local[3][k] + w13 * dl(x1, k) + w03 * dl(x0, k);
            if (f2[k] + f3[k] < same_e) {
              same_e = f2[k] + f3[k];
              same = k;
            }
          }
          for (int k = 1; k < K; ++k) {
            if (f2[k] < f2[b2]) {
              s2 = b2;
              b2 = k;
            } else if (s2 < 0 || f2[k] < f2[s2]) {
              s2 = k;
            }
            if (f3[k] < f3[b3]) {
              s3 = b3;
              b3 = k;
            } else if (s3 < 0 || f3[k] < f3[s3]) {
              s3 = k;
            }
          }
          // Equal bottom labels (δ = −1) or the best two different ones (δ = +1).
          double e = top + same_e - w23;
          int x2 = same, x3 = same;
          int d2 = b2, d3 = b3;
          if (b2 == b3) {
            if (f2[b2] + f3[s3] <= f2[s2] + f3[b3])
              d3 = s3;
            else
              d2 = s2;
          }
          if (top + f2[d2] + f3[d3] + w23 < e) {
            e = top + f2[d2] + f3[d3] + w23;
            x2 = d2;
            x3 = d3;
          }
          if (e < best_e) {
            best_e = e;
            best[0] = x0, best[1] = x1, best[2] = x2, best[3] = x3;
          }
        }
      if (best[0] < 0) continue;
      for (int j = 0; j < 4; ++j)
        if (lab[cell[j]] != best[j]) relabel(cell[j], best[j]);
      total += best_e - now;
      ++taken_;
    }
  return total;
}

}  // namespace terramrf::expansion
