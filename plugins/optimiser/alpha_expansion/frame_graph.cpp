#include "frame_graph.hpp"

namespace terramrf::expansion {

void FrameGraph::build(const EnergyModel& em) {
  const int R = em.rows, C = em.cols;
  cells.clear();
  pair_p.clear();
  pair_q.clear();
  pair_w.clear();
  node_of.assign(std::size_t(R) * C, -1);
  for (int p = 0; p < R * C; ++p)
    if (!em.fixed[p]) {
      node_of[p] = static_cast<int>(cells.size());
      cells.push_back(p);
    }
  // At most four forward pairs per node, written by index (no growth checks in the loop).
  pair_p.resize(4 * cells.size());
  pair_q.resize(4 * cells.size());
  pair_w.resize(4 * cells.size());
  pair_np.resize(4 * cells.size());
  pair_nq.resize(4 * cells.size());
  const uint8_t* fixed = em.fixed.data();
  const int* node = node_of.data();
  std::size_t k = 0;
  for (std::size_t n = 0; n < cells.size(); ++n) {
    const int p = cells[n], r = p / C, c = p % C;
    for (int d = 4; d < 8; ++d) {  // forward directions: each unordered pair once
      const int rr = r + kDr[d], cc = c + kDc[d], q = rr * C + cc;
      if (rr >= R || cc < 0 || cc >= C || fixed[q]) continue;
      pair_p[k] = p;
      pair_q[k] = q;
      pair_w[k] = isDiagonal(d) ? em.beta_diagonal : em.beta;
      pair_np[k] = static_cast<int>(n);
      pair_nq[k] = node[q];
      ++k;
    }
  }
  for (auto* v : {&pair_p, &pair_q, &pair_np, &pair_nq}) v->resize(k);
  pair_w.resize(k);
  pairs_off.assign(cells.size() + 1, 0);
  for (std::size_t k = 0; k < pair_p.size(); ++k) {
    ++pairs_off[pair_np[k] + 1];
    ++pairs_off[pair_nq[k] + 1];
  }
  for (std::size_t n = 0; n < cells.size(); ++n) pairs_off[n + 1] += pairs_off[n];
  pairs_of.resize(2 * pair_p.size());
  std::vector<int> fill(pairs_off.begin(), pairs_off.end() - 1);
  for (std::size_t k = 0; k < pair_p.size(); ++k) {
    pairs_of[fill[pair_np[k]]++] = static_cast<int>(k);
    pairs_of[fill[pair_nq[k]]++] = static_cast<int>(k);
  }
}

}  // namespace terramrf::expansion
