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
  for (int p : cells) {
    const int r = p / C, c = p % C;
    for (int d = 4; d < 8; ++d) {  // forward directions: each unordered pair once
      const int rr = r + kDr[d], cc = c + kDc[d];
      if (rr < 0 || rr >= R || cc < 0 || cc >= C || em.fixed[rr * C + cc]) continue;
      pair_p.push_back(p);
      pair_q.push_back(rr * C + cc);
      pair_w.push_back(isDiagonal(d) ? em.beta_diagonal : em.beta);
    }
  }
  pair_np.resize(pair_p.size());
  pair_nq.resize(pair_p.size());
  for (std::size_t k = 0; k < pair_p.size(); ++k) {
    pair_np[k] = node_of[pair_p[k]];
    pair_nq[k] = node_of[pair_q[k]];
  }
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
