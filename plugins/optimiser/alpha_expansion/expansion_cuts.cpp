#include "expansion_cuts.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <stdexcept>
#include <string>

// The library instantiates no graph with 64-bit capacities; its template implementation is
// shipped with the header for that.
#define MAXFLOW_INCLUDE_TEMPLATE_IMPLEMENTATION
#include <maxflow.h>

namespace terramrf::expansion {
namespace {

[[noreturn]] void maxflowError(const char* what) {
  throw std::runtime_error(std::string("alpha_expansion: max-flow: ") + what);
}

}  // namespace

ExpansionCuts::ExpansionCuts() = default;
ExpansionCuts::~ExpansionCuts() = default;

void ExpansionCuts::beginFrame(const EnergyModel& em) {
  const int K = em.numLabels();
  fg_.build(em);
  // A move's unary difference beyond what the node's pairs can outweigh decides the node alone,
  // and any other value beyond that bound decides it the same way: flipping x_p changes each of
  // its pair terms by at most V = 2w, so with |Δ| > Σ V the sign of Δ fixes x_p in every minimum
  // cut, and on those cuts the move energies differ by a constant. Clipping Δ to twice that sum
  // (plus one energy unit, for cells whose pairs weigh nothing) keeps every cut exact and lets
  // the capacity scale follow the Potts weights, not the largest unary: one cell with eq. 11's
  // cap of 1e20 used to round every pair capacity to 0.
  unary_clip_.assign(fg_.cells.size(), 1.0);
  for (std::size_t n = 0; n < fg_.cells.size(); ++n)
    for (int j = fg_.pairs_off[n]; j < fg_.pairs_off[n + 1]; ++j)
      unary_clip_[n] += 4.0 * std::abs(double(fg_.pair_w[fg_.pairs_of[j]]));
  // Integer capacities: saturated edges become exactly 0 (no floating-point residues sending the
  // max-flow after useless paths) and warm starts are exact. 2^36 units for the largest possible
  // capacity leave room for 2^26 nodes in int64; rounding is ~1e-11 of an energy unit.
  double range = 0;
  for (std::size_t n = 0; n < fg_.cells.size(); ++n) {
    const float* u = &em.unary[std::size_t(fg_.cells[n]) * K];
    const auto [lo, hi] = std::minmax_element(u, u + K);
    range = std::max(range, std::min(double(*hi) - *lo, unary_clip_[n]));
  }
  const double w_max = std::max({0.f, em.beta, em.beta_diagonal});
  scale_ = std::ldexp(1.0, 36) / (range + 32.0 * w_max + 1e-12);
  fg_.pair_v.resize(fg_.pair_w.size());
  for (std::size_t k = 0; k < fg_.pair_w.size(); ++k) fg_.pair_v[k] = toUnits(2.0 * fg_.pair_w[k]);
  shift_t_.assign(fg_.cells.size(), 0);
  local_of_.assign(fg_.cells.size(), -1);
  node_seen_.assign(fg_.cells.size(), 0);
  pair_seen_.assign(fg_.pair_p.size(), 0);
  warm_.resize(K);
  for (WarmStart& w : warm_) w.cold = true;  // built by each label's first cut
  changes_.clear();
  region_cuts_ = region_nodes_ = region_regrowths_ = 0;
}

int64_t ExpansionCuts::toUnits(double x) const {
  const double y = x * scale_;
  return static_cast<int64_t>(y >= 0 ? y + 0.5 : y - 0.5);
}

ExpansionCuts::PairTerm ExpansionCuts::pairTerm(int a, int b, int alpha, int64_t V) {
  PairTerm m;
  const int64_t H = V / 2;
  if (a == b) {
    if (a != alpha) m.c01 = m.c10 = V;
  } else if (a == alpha) {
    m.t = -V;
  } else if (b == alpha) {
    m.s = -V;
  } else {
    m.s = -H;
    m.t = H - V;
    m.c01 = V - H;
    m.c10 = H;
  }
  return m;
}

void ExpansionCuts::updatePair(WarmStart& w, std::size_t k, const PairTerm& m) {
  const int64_t d01 = m.c01 - w.model_n[2 * k], d10 = m.c10 - w.model_n[2 * k + 1];
  if (d01 == 0 && d10 == 0) return;
  w.model_n[2 * k] = m.c01;
  w.model_n[2 * k + 1] = m.c10;
  const int np = fg_.pair_np[k], nq = fg_.pair_nq[k];
  // p→q is cut when p keeps its label and q takes α; q→p the other way round.
  int64_t r01 = w.res_n[2 * k] + d01, r10 = w.res_n[2 * k + 1] + d10;
  // r01 + r10 = c01 + c10 ≥ 0, so at most one is negative; move its deficit to the t-links:
  // (1−x_p)·x_q = x_p·(1−x_q) + x_q − x_p.
  if (r01 < 0) {
    r10 += r01;
    shift_t_[np] -= r01;
    shift_t_[nq] += r01;
    r01 = 0;
  } else if (r10 < 0) {
    r01 += r10;
    shift_t_[np] += r10;
    shift_t_[nq] -= r10;
    r10 = 0;
  }
  w.res_n[2 * k] = r01;
  w.res_n[2 * k + 1] = r10;
}

void ExpansionCuts::updateNode(WarmStart& w, int n, int64_t model) {
  w.res_t[n] += model - w.model_t[n] + shift_t_[n];
  shift_t_[n] = 0;
  w.model_t[n] = model;
}

int64_t ExpansionCuts::unaryModel(const EnergyModel& em, const std::vector<uint8_t>& lab, int alpha,
                                  int n) {
  const int p = fg_.cells[n];
  const float* u = &em.unary[std::size_t(p) * em.numLabels()];
  const double clip = unary_clip_[n];
  return toUnits(std::clamp(double(u[alpha]) - u[lab[p]], -clip, clip));
}

int64_t ExpansionCuts::nodeModel(const EnergyModel& em, const std::vector<uint8_t>& lab, int alpha,
                                 int n) {
  const int p = fg_.cells[n];
  int64_t t = unaryModel(em, lab, alpha, n);
  for (int j = fg_.pairs_off[n]; j < fg_.pairs_off[n + 1]; ++j) {
    const int k = fg_.pairs_of[j];
    const PairTerm m = pairTerm(lab[fg_.pair_p[k]], lab[fg_.pair_q[k]], alpha, fg_.pair_v[k]);
    t += fg_.pair_p[k] == p ? m.s : m.t;
  }
  return t;
}

bool ExpansionCuts::expand(const EnergyModel& em, const std::vector<uint8_t>& lab, int alpha) {
  const int N = static_cast<int>(fg_.cells.size());
  const std::size_t P = fg_.pair_p.size();
  if (N == 0) return false;  // every cell fixed: nothing to cut
  WarmStart& w = warm_[alpha];
  if (w.cold) {
    w.cold = false;
    w.model_t.resize(N);
    w.model_n.resize(2 * P);
    w.lab_at.resize(N);
    for (int n = 0; n < N; ++n) {
      w.model_t[n] = unaryModel(em, lab, alpha, n);
      w.lab_at[n] = lab[fg_.cells[n]];
    }
    for (std::size_t k = 0; k < P; ++k) {
      const PairTerm m = pairTerm(lab[fg_.pair_p[k]], lab[fg_.pair_q[k]], alpha, fg_.pair_v[k]);
      w.model_n[2 * k] = m.c01;
      w.model_n[2 * k + 1] = m.c10;
      w.model_t[fg_.pair_np[k]] += m.s;
      w.model_t[fg_.pair_nq[k]] += m.t;
    }
    w.res_t = w.model_t;
    w.res_n = w.model_n;
    greedyFlow(w.res_t.data(), w.res_n.data());
    w.changes_at = changes_.size();
  } else {
    // The cells whose label changed since α's last cut, from the log of changes (a cell may be
    // logged more than once, or be back at its label). shift_t_ is 0 outside touched_ nodes
    // (updateNode clears what it writes).
    touched_.clear();
    for (std::size_t at = w.changes_at; at < changes_.size(); ++at) {
      const int n = changes_[at];
      const uint8_t l = lab[fg_.cells[n]];
      if (l == w.lab_at[n]) continue;
      w.lab_at[n] = l;
      for (int j = fg_.pairs_off[n]; j < fg_.pairs_off[n + 1]; ++j) {
        const int k = fg_.pairs_of[j];
        if (pair_seen_[k]) continue;
        pair_seen_[k] = 1;
        updatePair(w, k, pairTerm(lab[fg_.pair_p[k]], lab[fg_.pair_q[k]], alpha, fg_.pair_v[k]));
        for (const int m : {fg_.pair_np[k], fg_.pair_nq[k]})
          if (!node_seen_[m]) node_seen_[m] = 1, touched_.push_back(m);
      }
      if (!node_seen_[n]) node_seen_[n] = 1, touched_.push_back(n);
    }
    w.changes_at = changes_.size();
    if (touched_.empty()) return false;  // the problem of α's last cut, which did not improve
    for (const int n : touched_) {
      updateNode(w, n, nodeModel(em, lab, alpha, n));
      node_seen_[n] = 0;
      for (int j = fg_.pairs_off[n]; j < fg_.pairs_off[n + 1]; ++j) pair_seen_[fg_.pairs_of[j]] = 0;
    }
  }
  return cutResidual(w, lab, alpha);
}

bool ExpansionCuts::cutResidual(WarmStart& w, const std::vector<uint8_t>& lab, int alpha) {
  const int N = static_cast<int>(fg_.cells.size());
  int64_t* const res_t = w.res_t.data();
  int64_t* const res_n = w.res_n.data();
  const int* const pair_np = fg_.pair_np.data();
  const int* const pair_nq = fg_.pair_nq.data();
  const int* const pairs_off = fg_.pairs_off.data();
  const int* const pairs_of = fg_.pairs_of.data();
  move_.clear();
  region_.clear();
  // A cell labelled α has no n-link with capacity (pairTerm), so it cannot pass flow on; its
  // t-link is a constant of the move energy.
  for (int n = 0; n < N; ++n)
    if (res_t[n] < 0 && lab[fg_.cells[n]] != alpha) region_.push_back(n);
  if (region_.empty()) return false;  // nothing can reach the sink: no cell gains from α
  if (!region_graph_) region_graph_ = std::make_unique<CutGraph>(1024, 4096, &maxflowError);
  CutGraph& g = *region_graph_;
  g.reset();
  region_pairs_.clear();
  // Where much of the graph sends to the sink (the first cuts from a noisy start), the region
  // would be most of it anyway: the whole of what reaches the seeds is cut at once.
  int depth = region_.size() > std::size_t(N) / 8 ? INT_MAX : kRegionDepth;
  // The layer the next growth starts from, and the ring: region nodes that may have an arc in
  // from outside (every other node's arcs in are in the network).
  layer_.assign(region_.begin(), region_.end());
  ring_.clear();
  for (std::size_t i = 0; i < region_.size(); ++i) local_of_[region_[i]] = int(i);
  for (bool first = true;; first = false) {
    // Backwards breadth-first from the layer: the nodes `depth` arcs out are the new ring.
    const std::size_t old_size = first ? 0 : region_.size();
    for (int d = 0; d < depth && !layer_.empty(); ++d) {
      next_layer_.clear();
      for (const int y : layer_) {
        for (int j = pairs_off[y], j_end = pairs_off[y + 1]; j < j_end; ++j) {
          const int k = pairs_of[j];
          int x;
          const uint32_t xy = arcInto(pair_np, pair_nq, uint32_t(k), y, x);
          if (local_of_[x] >= 0 || res_n[xy] == 0) continue;
          local_of_[x] = int(region_.size());
          region_.push_back(x);
          next_layer_.push_back(x);
        }
      }
      layer_.swap(next_layer_);
    }
    // Without a last layer the search ran out: everything it reaches is inside.
    ring_.insert(ring_.end(), layer_.begin(), layer_.end());
    // The new nodes, then every pair between a new node and a node added before it (each pair
    // with both nodes in the region is in the network once), p→q arcs first.
    const int R = static_cast<int>(region_.size());
    // (A growth can add nothing: ring nodes whose arcs in all come from inside.)
    if (R > int(old_size)) g.add_node(R - int(old_size));
    for (int i = int(old_size); i < R; ++i) {
      const int n = region_[i];
      g.set_trcap(i, res_t[n]);
      for (int j = pairs_off[n], j_end = pairs_off[n + 1]; j < j_end; ++j) {
        const int k = pairs_of[j];
        const int x = pair_np[k] == n ? pair_nq[k] : pair_np[k];
        const int lx = local_of_[x];
        if (lx < 0 || lx >= i || (res_n[2 * k] == 0 && res_n[2 * k + 1] == 0)) continue;
        region_pairs_.push_back(k);
        g.add_edge(local_of_[pair_np[k]], local_of_[pair_nq[k]], res_n[2 * k], res_n[2 * k + 1]);
      }
    }
    g.maxflow(false);
    ++region_cuts_;
    region_nodes_ += R;
    // The ring nodes that can reach the sink are where the next growth starts; those that
    // cannot stay the ring (a later growth may let them reach it).
    layer_.clear();
    std::size_t kept = 0;
    for (const int n : ring_) {
      if (g.what_segment(local_of_[n], CutGraph::SOURCE) == CutGraph::SINK)
        layer_.push_back(n);
      else
        ring_[kept++] = n;
    }
    ring_.resize(kept);
    if (layer_.empty()) break;
    ++region_regrowths_;
    depth = std::size_t(R) > std::size_t(N) / 4 || depth > INT_MAX / 2 ? INT_MAX : 2 * depth;
  }
  // Back into α's residual network, and the cut.
  const int R = static_cast<int>(region_.size());
  for (int i = 0; i < R; ++i) res_t[region_[i]] = g.get_trcap(i);
  const CutGraph::arc_id arcs = g.get_first_arc();
  for (std::size_t j = 0; j < region_pairs_.size(); ++j) {
    const std::size_t k = std::size_t(region_pairs_[j]);
    res_n[2 * k] = g.get_rcap(arcs + 2 * j);
    res_n[2 * k + 1] = g.get_rcap(arcs + 2 * j + 1);
  }
  for (int i = 0; i < R; ++i) {
    const int p = fg_.cells[region_[i]];
    if (lab[p] != alpha && g.what_segment(i, CutGraph::SOURCE) == CutGraph::SINK)
      move_.push_back(p);
    local_of_[region_[i]] = -1;
  }
  return !move_.empty();
}

void ExpansionCuts::greedyFlow(int64_t* const res_t, int64_t* const res_n) {
  const std::size_t P = fg_.pair_np.size();
  for (std::size_t k = 0; k < P; ++k) {
    const int np = fg_.pair_np[k], nq = fg_.pair_nq[k];
    const int64_t tp = res_t[np], tq = res_t[nq];
    if (tp == 0 || tq == 0 || (tp > 0) == (tq > 0)) continue;
    // From the node with source capacity over its arc to the node with sink capacity; pair
    // k's arcs are 2k = p→q, 2k + 1 = q→p.
    const bool q_to_p = tq > 0;
    const int from = q_to_p ? nq : np, to = q_to_p ? np : nq;
    const std::size_t arc = 2 * k + (q_to_p ? 1 : 0);
    const int64_t f = std::min({res_t[from], -res_t[to], res_n[arc]});
    if (f <= 0) continue;
    res_t[from] -= f;
    res_t[to] += f;
    res_n[arc] -= f;
    res_n[arc ^ 1] += f;
  }
  const int N = static_cast<int>(fg_.cells.size());
  // What still sends to the sink is about 2 500 cells on the stress grid, most a few hops
  // from cells with source capacity left: shortest augmenting paths, found by a search
  // backwards from each such cell, carry most of what remains. One search per cell: each cell
  // with source capacity it meets sends along its search-tree path what the path still carries
  // (an earlier push may have saturated part of it), until the cell's deficit is met. (This
  // replaced passes over paths of two and three hops: as fast, and it also finds longer ones.)
  // Raw pointers and a local deficit: stores through the members' pointers would otherwise
  // make the compiler reload everything in the inner loop.
  constexpr int kMaxSearch = 64;
  if (bfs_seen_.size() != std::size_t(N)) bfs_seen_.assign(N, 0);
  bfs_from_.resize(N);
  // A search that ends with its cell still short marks the cells it queued dry: a cluster of
  // cells that all want α and no supply near them would otherwise have each of its cells repeat
  // the same fruitless search. Later searches neither start from nor pass through dry cells;
  // what they leave is the max-flow's.
  dry_.assign(N, 0);
  uint8_t* const dry = dry_.data();
  uint32_t* const seen = bfs_seen_.data();
  uint32_t* const from = bfs_from_.data();
  const int* const pair_np = fg_.pair_np.data();
  const int* const pair_nq = fg_.pair_nq.data();
  const int* const pairs_off = fg_.pairs_off.data();
  const int* const pairs_of = fg_.pairs_of.data();
  auto head = [&](uint32_t arc) { return (arc & 1) ? pair_np[arc >> 1] : pair_nq[arc >> 1]; };
  int queue[kMaxSearch];
  for (int r = 0; r < N; ++r) {
    if (res_t[r] >= 0 || dry[r]) continue;
    int64_t need = -res_t[r];
    if (++bfs_stamp_ == 0) {
      std::fill(bfs_seen_.begin(), bfs_seen_.end(), 0);
      bfs_stamp_ = 1;
    }
    const uint32_t stamp = bfs_stamp_;
    int queued = 1;
    queue[0] = r;
    seen[r] = stamp;
    // Backwards over arcs x → y with residual capacity. A cell cut off from the source would
    // have the search cover all it reaches; beyond kMaxSearch cells the max-flow takes over.
    for (int at = 0; at < queued && need > 0; ++at) {
      const int y = queue[at];
      for (int j = pairs_off[y], j_end = pairs_off[y + 1]; j < j_end; ++j) {
        // Pair k's other node x, and the arc x → y.
        const uint32_t k = uint32_t(pairs_of[j]);
        int x;
        const uint32_t xy = arcInto(pair_np, pair_nq, k, y, x);
        if (seen[x] == stamp || res_n[xy] == 0) continue;
        seen[x] = stamp;
        from[x] = xy;
        if (res_t[x] <= 0) {
          if (queued < kMaxSearch && !dry[x]) queue[queued++] = x;
          continue;
        }
        int64_t f = std::min(res_t[x], need);
        for (int z = x; z != r && f > 0;) {
          const uint32_t a = from[z];
          f = std::min(f, res_n[a]);
          z = head(a);
        }
        if (f == 0) continue;
        res_t[x] -= f;
        need -= f;
        for (int z = x; z != r;) {
          const uint32_t a = from[z];
          res_n[a] -= f;
          res_n[a ^ 1] += f;
          z = head(a);
        }
        if (need == 0) break;
      }
    }
    res_t[r] = -need;
    if (need > 0)
      for (int i = 0; i < queued; ++i) dry[queue[i]] = 1;
  }
}

}  // namespace terramrf::expansion
