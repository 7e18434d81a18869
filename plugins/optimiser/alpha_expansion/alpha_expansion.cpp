// α-expansion (Boykov, Veksler & Zabih 2001) with Boost's Boykov–Kolmogorov max-flow.
//
// The Potts term of EnergyModel, w·δ with δ(equal) = −1 and δ(different) = +1, equals the metric
// V(a, b) = 2w·[a ≠ b] minus the constant w per pair, so minimising one minimises the other and
// α-expansion applies, with its factor-2 bound on the shifted energy (docs/optimisers.md). Every
// expansion is one min-cut on a graph whose structure (cells, 8-neighbour pairs, terminal links) is
// built once per grid size; between expansions and frames only capacities change (fixed cells get
// none). Each label's cut is warm-started from the residual network of its previous cut. A move is
// kept only if the exact EnergyModel energy drops, so the result never lies above the start.
//
// Once no expansion improves, exact 2×2 block moves follow (`block_moves`): each 2×2 block of
// cells takes its best joint labelling given its neighbours. They contain the moves in which two
// labels enter a region at once (a rough patch that is part road, part obstacle), which no
// expansion (one label enters) and no swap (two labels trade cells) contains; after any accepted
// block move the expansions run again.
#include <algorithm>
#include <boost/graph/boykov_kolmogorov_max_flow.hpp>
#include <boost/graph/compressed_sparse_row_graph.hpp>
#include <boost/property_map/property_map.hpp>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "terramrf/padded_labels.hpp"
#include "terramrf/plugin.hpp"
#include "terramrf/roc.hpp"

namespace terramrf {
namespace {

// 32-bit vertex and edge indices halve the size of edge descriptors (reverse and predecessor
// maps) compared with the default std::size_t.
using Graph =
    boost::compressed_sparse_row_graph<boost::directedS, boost::no_property, boost::no_property,
                                       boost::no_property, uint32_t, uint32_t>;
using Vertex = boost::graph_traits<Graph>::vertex_descriptor;
using Edge = boost::graph_traits<Graph>::edge_descriptor;

// The 8 directions in a fixed order; kOpposite[d] points back.
constexpr int kDr[8] = {-1, -1, -1, 0, 0, 1, 1, 1};
constexpr int kDc[8] = {-1, 0, 1, -1, 1, -1, 0, 1};
constexpr int kOpposite[8] = {7, 6, 5, 4, 3, 2, 1, 0};
inline bool isDiagonal(int d) { return kDr[d] != 0 && kDc[d] != 0; }

/// The flow network: one node per cell plus source and sink, every 8-neighbour pair linked both
/// ways, every cell linked to both terminals. Its structure depends on the grid size only, so it
/// is built once and serves every frame: fixed cells are left out by giving their edges no
/// capacity. Edge ids are CSR positions, so capacities live in flat vectors indexed by id.
struct FlowNetwork {
  int rows = -1, cols = -1;
  int nodes = 0;                         ///< cells
  std::vector<int> src_edge, sink_edge;  ///< per cell: s→p and p→t
  std::vector<int> dir_edge;             ///< per cell and direction: edge id p→q, −1 if none
  std::vector<int> rev_id;               ///< reverse edge id per edge id
  std::vector<Edge> rev;                 ///< the same as descriptors, for Boost
  std::vector<int> target;               ///< target node per edge id
  Graph g;

  Vertex source() const { return Vertex(nodes); }
  Vertex sink() const { return Vertex(nodes + 1); }

  void build(int R, int C) {
    if (R == rows && C == cols) return;
    rows = R;
    cols = C;
    nodes = R * C;
    // Out-edges in CSR (source-sorted) order: per cell p→t, p→s, then its neighbours by
    // direction; then the source's s→p; then the sink's t→p.
    std::vector<std::pair<uint32_t, uint32_t>> edges;
    edges.reserve(std::size_t(nodes) * 12);
    dir_edge.assign(std::size_t(nodes) * 8, -1);
    std::vector<int> to_s(nodes), from_t(nodes);
    sink_edge.resize(nodes);
    src_edge.resize(nodes);
    for (int p = 0; p < nodes; ++p) {
      const int r = p / C, c = p % C;
      // p→t first: Boost's max-flow looks it up by a linear scan of p's out-edges.
      sink_edge[p] = static_cast<int>(edges.size());
      edges.emplace_back(p, nodes + 1);
      to_s[p] = static_cast<int>(edges.size());
      edges.emplace_back(p, nodes);
      for (int d = 0; d < 8; ++d) {
        const int rr = r + kDr[d], cc = c + kDc[d];
        if (rr < 0 || rr >= R || cc < 0 || cc >= C) continue;
        dir_edge[std::size_t(p) * 8 + d] = static_cast<int>(edges.size());
        edges.emplace_back(p, rr * C + cc);
      }
    }
    for (int p = 0; p < nodes; ++p) {
      src_edge[p] = static_cast<int>(edges.size());
      edges.emplace_back(nodes, p);
    }
    for (int p = 0; p < nodes; ++p) {
      from_t[p] = static_cast<int>(edges.size());
      edges.emplace_back(nodes + 1, p);
    }
    g = Graph(boost::edges_are_sorted, edges.begin(), edges.end(), Vertex(nodes + 2));
    // CSR keeps the given order, so edge id = position in `edges`; pair each edge with its reverse.
    rev_id.assign(edges.size(), -1);
    for (int p = 0; p < nodes; ++p) {
      for (int d = 0; d < 8; ++d) {
        const int e = dir_edge[std::size_t(p) * 8 + d];
        if (e >= 0) rev_id[e] = dir_edge[std::size_t(edges[e].second) * 8 + kOpposite[d]];
      }
      rev_id[sink_edge[p]] = from_t[p];
      rev_id[from_t[p]] = sink_edge[p];
      rev_id[src_edge[p]] = to_s[p];
      rev_id[to_s[p]] = src_edge[p];
    }
    rev.resize(edges.size());
    target.resize(edges.size());
    for (std::size_t e = 0; e < edges.size(); ++e) {
      rev[e] = Edge(Vertex(edges[rev_id[e]].first), uint32_t(rev_id[e]));
      target[e] = static_cast<int>(edges[e].second);
    }
  }
};

/// The part of the network a frame uses: its non-fixed cells and the pairs between them.
struct FrameGraph {
  std::vector<int> cells;                ///< non-fixed cells (= node ids)
  std::vector<int> pair_p, pair_q;       ///< unordered neighbour pairs, p before q in raster order
  std::vector<float> pair_w;             ///< their Potts weight w
  std::vector<int64_t> pair_v;           ///< V = 2w in capacity units (set once the scale is known)
  std::vector<int> pair_edge, pair_rev;  ///< edge ids p→q and q→p

  void build(const EnergyModel& em, const FlowNetwork& net) {
    const int R = em.rows, C = em.cols;
    cells.clear();
    pair_p.clear();
    pair_q.clear();
    pair_w.clear();
    pair_edge.clear();
    pair_rev.clear();
    for (int p = 0; p < R * C; ++p) {
      if (em.fixed[p]) continue;
      cells.push_back(p);
      for (int d = 4; d < 8; ++d) {  // forward directions: each unordered pair once
        const int e = net.dir_edge[std::size_t(p) * 8 + d];
        if (e < 0 || em.fixed[net.target[e]]) continue;
        pair_p.push_back(p);
        pair_q.push_back(net.target[e]);
        pair_w.push_back(isDiagonal(d) ? em.beta_diagonal : em.beta);
        pair_edge.push_back(e);
        pair_rev.push_back(net.rev_id[e]);
      }
    }
  }
};

}  // namespace

class AlphaExpansion final : public Stage {
 public:
  void declare(ParamDecl& d) override {
    d.add("max_cycles", max_cycles_,
          "upper bound on cycles (one expansion per label); stops earlier when a cycle improves "
          "nothing")
        .range(1, 1000);
    d.add("init", init_,
          "starting labelling: the energy stage's initial labelling, or the per-cell unary argmin")
        .choices({"initial", "unary_argmin"});
    d.add("pre_icm", pre_icm_,
          "run ICM on the starting labelling before the expansions: the first, most expensive "
          "cuts then only make the moves ICM cannot (2× faster on the noisy benchmark start)");
    d.add("block_moves", block_moves_,
          "when no expansion improves, give each 2×2 block of cells its best joint labelling "
          "(moves in which two labels enter at once), then expand again; up to 8 labels");
  }
  std::vector<std::string> reads() const override { return {artefacts::kEnergy}; }
  std::vector<std::string> writes() const override { return {artefacts::kLabels}; }

  void process(FrameContext& ctx) override {
    const EnergyModel& em = ctx.energy;
    const int K = em.numLabels();
    OptimiserReport& rep = ctx.optimiser;
    rep = {};
    if (K == 0 || em.cells() == 0) {  // nothing to label: every cell unknown
      ctx.grid->labels().assign(ctx.grid->cells(), labels::kUnknown);
      return;
    }
    const double e_initial = em.energy(em.initial);
    std::vector<uint8_t>& lab = lab_;
    lab = em.initial;
    if (init_ == "unary_argmin") {
      for (std::size_t i = 0; i < em.cells(); ++i) {
        if (em.fixed[i]) continue;
        const float* u = &em.unary[i * K];
        lab[i] = static_cast<uint8_t>(std::min_element(u, u + K) - u);
      }
    }
    int icm_sweeps = 0;
    if (pre_icm_) {
      bool icm_converged = false;
      pad_.assign(em, lab);
      icm_sweeps = icmSweeps(em, pad_, 100, dirty_, icm_converged);
      pad_.extract(em, lab);
    }

    net_.build(em.rows, em.cols);
    fg_.build(em, net_);
    const std::size_t n_edges = net_.rev.size();
    cap_.assign(n_edges, 0);
    res_.assign(n_edges, 0);
    // Integer capacities: saturated edges become exactly 0 (no floating-point residues sending the
    // max-flow after useless paths) and warm starts are exact. 2^36 units for the largest possible
    // capacity leave room for 2^26 nodes in int64; rounding is ~1e-11 of an energy unit.
    double range = 0;
    for (std::size_t i = 0; i < em.cells(); ++i) {
      if (em.fixed[i]) continue;
      const float* u = &em.unary[i * K];
      const auto [lo, hi] = std::minmax_element(u, u + K);
      range = std::max(range, double(*hi) - *lo);
    }
    const double w_max = std::max({0.f, em.beta, em.beta_diagonal});
    scale_ = std::ldexp(1.0, 36) / (range + 32.0 * w_max + 1e-12);
    fg_.pair_v.resize(fg_.pair_w.size());
    for (std::size_t k = 0; k < fg_.pair_w.size(); ++k)
      fg_.pair_v[k] = toUnits(2.0 * fg_.pair_w[k]);
    const std::size_t n_vert = std::size_t(net_.nodes) + 2;
    pred_.resize(n_vert);
    color_.resize(n_vert);
    dist_.resize(n_vert);
    in_move_.assign(em.cells(), 0);
    warm_.resize(K);
    for (WarmStart& w : warm_) {
      // Contents are written by the first (cold) expansion of each label before they are read.
      w.cold = true;
      w.model_t.resize(fg_.cells.size());
      w.res_t.resize(fg_.cells.size());
      w.model_n.resize(2 * fg_.pair_p.size());
      w.res_n.resize(2 * fg_.pair_p.size());
    }

    double e = em.energy(lab);
    block_dirty_.assign(em.cells(), 1);
    int cycle = 0, expansions = 0, accepted = 0, block_passes = 0;
    block_moves_taken_ = 0;
    // An expansion that changed nothing need not be repeated until another one changes the
    // labelling: `version` counts accepted moves, failed_at[α] remembers when α last failed.
    int version = 0;
    std::vector<int> failed_at(K, -1);
    bool converged = false;
    while (cycle < max_cycles_ && !converged) {
      ++cycle;
      bool improved = false;
      for (int alpha = 0; alpha < K; ++alpha) {
        if (failed_at[alpha] == version) continue;
        ++expansions;
        bool better = false;
        if (expand(em, lab, alpha)) {
          const double de = moveEnergyChange(em, lab, alpha);
          // Strict decrease beyond round-off, so equal-energy moves cannot cycle forever.
          if (de < -1e-9 * (1.0 + std::abs(e))) {
            for (int i : move_) {
              lab[i] = static_cast<uint8_t>(alpha);
              if (block_moves_) touchBlocks(i, em.rows, em.cols);
            }
            e += de;
            better = improved = true;
            ++accepted;
            ++version;
          }
        }
        if (!better) failed_at[alpha] = version;
      }
      // Expansions are exhausted: try the moves they do not contain, and expand again if any
      // was taken.
      if (!improved && block_moves_ && K >= 2 && K <= kMaxBlockLabels) {
        const double de = blockPass(em, lab);
        if (de < 0) {
          e += de;
          improved = true;
          ++block_passes;
          ++version;
        }
      }
      converged = !improved;
    }
    // The running energy is a sum of changes; the promise "never above the initial labelling"
    // is kept on exact totals (an argmin start can end above a good given initial labelling).
    e = em.energy(lab);
    if (e > e_initial) {
      lab = em.initial;
      e = e_initial;
    }
    rep.initial_energy = e_initial;
    rep.final_energy = e;
    rep.iterations = cycle;
    rep.converged = converged;
    writeOutputs(ctx, lab);
    ctx.metrics[name() + ".cycles"] = cycle;
    ctx.metrics[name() + ".expansions"] = expansions;
    ctx.metrics[name() + ".accepted_expansions"] = accepted;
    ctx.metrics[name() + ".icm_sweeps"] = icm_sweeps;
    ctx.metrics[name() + ".block_passes"] = block_passes;
    ctx.metrics[name() + ".block_moves"] = block_moves_taken_;
    ctx.metrics[name() + ".energy"] = e;
    ctx.metrics[name() + ".initial_energy"] = e_initial;
  }

 private:
  /// Per label α: the capacities of its last move problem and the residuals its max-flow left.
  struct WarmStart {
    bool cold = true;                     ///< no cut yet in this frame: model and residual are 0
    std::vector<int64_t> model_t, res_t;  ///< per node: cost(x=1) − cost(x=0)
    std::vector<int64_t> model_n, res_n;  ///< per pair: p→q, q→p
  };

  /// Labels up to which 2×2 block moves are searched.
  static constexpr int kMaxBlockLabels = 8;

  /// Marks the blocks whose best move may have changed because cell i changed label: those that
  /// hold i or have it among their twelve outside neighbours.
  void touchBlocks(int i, int R, int C) {
    const int r = i / C, c = i % C;
    for (int br = std::max(0, r - 2); br <= std::min(R - 2, r + 1); ++br)
      for (int bc = std::max(0, c - 2); bc <= std::min(C - 2, c + 1); ++bc)
        block_dirty_[br * C + bc] = 1;
  }

  /// One raster pass of exact 2×2 block moves over the blocks marked dirty: each block of four
  /// non-fixed cells takes the joint labelling of least energy given the current labels around it
  /// (the block's unaries, its six inner pairs and its pairs with the twelve cells around it).
  /// Returns the total energy change (≤ 0). A block is searched only if a bound says it could
  /// improve (every cell at its best label given the outside, every inner pair equal), which
  /// leaves uniform, settled regions alone; the search fixes the top two cells (K² cases) and
  /// solves the bottom pair of the Potts model exactly from each one's best and second-best label.
  double blockPass(const EnergyModel& em, std::vector<uint8_t>& lab) {
    const int R = em.rows, C = em.cols, K = em.numLabels();
    const double wb = em.beta, wd = em.beta_diagonal;
    // nsum_[i·K + k]: eq. 12 for cell i under k given all its current neighbours; a block's cells
    // then need only their three inner pairs taken back out, and a taken move updates the sums of
    // its cells' neighbours.
    nsum_.resize(em.cells() * std::size_t(K));
    for (int i = 0; i < R * C; ++i) {
      if (em.fixed[i]) continue;
      double* s = &nsum_[std::size_t(i) * K];
      const float* u = &em.unary[std::size_t(i) * K];
      for (int k = 0; k < K; ++k) s[k] = u[k];
      const int ri = i / C, ci = i % C;
      for (int d = 0; d < 8; ++d) {
        const int rr = ri + kDr[d], cc = ci + kDc[d];
        if (rr < 0 || rr >= R || cc < 0 || cc >= C || em.fixed[rr * C + cc]) continue;
        // w·δ(k, lab[n]) for every k: +w, and −2w for the neighbour's own label.
        const double w = isDiagonal(d) ? wd : wb;
        for (int k = 0; k < K; ++k) s[k] += w;
        s[lab[rr * C + cc]] -= 2 * w;
      }
    }
    auto relabel = [&](int i, int to) {
      const int from = lab[i], ri = i / C, ci = i % C;
      lab[i] = static_cast<uint8_t>(to);
      for (int d = 0; d < 8; ++d) {
        const int rr = ri + kDr[d], cc = ci + kDc[d];
        if (rr < 0 || rr >= R || cc < 0 || cc >= C || em.fixed[rr * C + cc]) continue;
        const double w = isDiagonal(d) ? wd : wb;
        double* s = &nsum_[std::size_t(rr * C + cc) * K];
        s[from] += 2 * w;
        s[to] -= 2 * w;
      }
      touchBlocks(i, R, C);
    };
    // Inner neighbours of block cell j (cells 0 1 / 2 3) and the pair weights.
    static constexpr int kInner[4][3] = {{1, 2, 3}, {0, 3, 2}, {3, 0, 1}, {2, 1, 0}};
    const double w_inner[3] = {wb, wb, wd};
    const double inner_all = 2 * wb + wd;  // Σ w_inner: every cell has two inner edges, one diagonal
    // Cells 0 1 / 2 3; inner pairs 0–1, 2–3, 0–2, 1–3 (edges) and 0–3, 1–2 (diagonals).
    const double inner_min = -4 * std::max(0.0, wb) - 2 * std::max(0.0, wd);
    auto dl = [](int a, int b) { return a == b ? -1.0 : 1.0; };
    double total = 0;
    double local[4][kMaxBlockLabels], f2[kMaxBlockLabels], f3[kMaxBlockLabels];
    for (int r = 0; r + 1 < R; ++r)
      for (int c = 0; c + 1 < C; ++c) {
        if (!block_dirty_[r * C + c]) continue;
        block_dirty_[r * C + c] = 0;
        const int cell[4] = {r * C + c, r * C + c + 1, (r + 1) * C + c, (r + 1) * C + c + 1};
        if (em.fixed[cell[0]] || em.fixed[cell[1]] || em.fixed[cell[2]] || em.fixed[cell[3]])
          continue;
        // local[j][k]: unary of cell j under k plus its pairs with non-fixed cells outside.
        double bound = inner_min, now = 0;
        int cur[4];
        for (int j = 0; j < 4; ++j) cur[j] = lab[cell[j]];
        for (int j = 0; j < 4; ++j) {
          const double* s = &nsum_[std::size_t(cell[j]) * K];
          for (int k = 0; k < K; ++k) local[j][k] = s[k] - inner_all;
          for (int m = 0; m < 3; ++m) local[j][cur[kInner[j][m]]] += 2 * w_inner[m];
          bound += *std::min_element(local[j], local[j] + K);
          now += local[j][cur[j]];
        }
        now += wb * (dl(cur[0], cur[1]) + dl(cur[2], cur[3]) + dl(cur[0], cur[2]) +
                     dl(cur[1], cur[3])) +
               wd * (dl(cur[0], cur[3]) + dl(cur[1], cur[2]));
        const double eps = 1e-9 * (1.0 + std::abs(now));
        if (now - bound <= eps) continue;
        double best_e = now - eps;
        int best[4] = {-1, -1, -1, -1};
        for (int x0 = 0; x0 < K; ++x0)
          for (int x1 = 0; x1 < K; ++x1) {
            const double top = local[0][x0] + local[1][x1] + wb * dl(x0, x1);
            // Bottom pair given the top: f2 = cell 2 with its pairs to 0 (edge) and 1 (diagonal),
            // f3 = cell 3 with its pairs to 1 (edge) and 0 (diagonal).
            int b2 = 0, s2 = -1, b3 = 0, s3 = -1, same = 0;
            double same_e = INFINITY;
            for (int k = 0; k < K; ++k) {
              f2[k] = local[2][k] + wb * dl(x0, k) + wd * dl(x1, k);
              f3[k] = local[3][k] + wb * dl(x1, k) + wd * dl(x0, k);
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
            double e = top + same_e - wb;
            int x2 = same, x3 = same;
            int d2 = b2, d3 = b3;
            if (b2 == b3) {
              if (f2[b2] + f3[s3] <= f2[s2] + f3[b3])
                d3 = s3;
              else
                d2 = s2;
            }
            if (top + f2[d2] + f3[d3] + wb < e) {
              e = top + f2[d2] + f3[d3] + wb;
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
        ++block_moves_taken_;
      }
    return total;
  }

  /// Energy → integer capacity units, rounded to nearest.
  int64_t toUnits(double x) const {
    const double y = x * scale_;
    return static_cast<int64_t>(y >= 0 ? y + 0.5 : y - 0.5);
  }

  /// Exact energy change if the cells in move_ take α (pairs inside the move counted once).
  double moveEnergyChange(const EnergyModel& em, const std::vector<uint8_t>& lab, int alpha) {
    const int R = em.rows, C = em.cols, K = em.numLabels();
    for (int i : move_) in_move_[i] = 1;
    double de = 0;
    for (int i : move_) {
      const int a = lab[i], r = i / C, c = i % C;
      de += double(em.unary[std::size_t(i) * K + alpha]) - em.unary[std::size_t(i) * K + a];
      for (int d = 0; d < 8; ++d) {
        const int rr = r + kDr[d], cc = c + kDc[d];
        if (rr < 0 || rr >= R || cc < 0 || cc >= C) continue;
        const int j = rr * C + cc;
        if (em.fixed[j] || (in_move_[j] && j < i)) continue;
        const int b_old = lab[j], b_new = in_move_[j] ? alpha : b_old;
        const double w = isDiagonal(d) ? em.beta_diagonal : em.beta;
        de += w * ((alpha == b_new ? -1.0 : 1.0) - (a == b_old ? -1.0 : 1.0));
      }
    }
    for (int i : move_) in_move_[i] = 0;
    return de;
  }

  /// Best α-expansion of `lab` by one min-cut: the cells that would take α go to move_. Returns
  /// false if there are none.
  ///
  /// Warm start (Kohli & Torr 2007): the residual network of α's previous cut represents that
  /// move energy up to a constant, so the new move energy is that residual plus the change of the
  /// capacities. Max-flow on it only pushes the flow the change made possible; an expansion that
  /// repeats an almost unchanged problem costs one tree growth instead of a full max-flow.
  bool expand(const EnergyModel& em, const std::vector<uint8_t>& lab, int alpha) {
    const int K = em.numLabels();
    const int N = static_cast<int>(fg_.cells.size());
    WarmStart& w = warm_[alpha];
    const bool cold = w.cold;
    w.cold = false;
    // Per cell, in capacity units of cost(x_p = 1) − cost(x_p = 0): acc_ = the warm offset
    // (residual − old model) plus deficits moved from n-links; model_acc_ = the pair part of the
    // new model, whose unary part goes straight to w.model_t. Fixed cells are never read.
    acc_.resize(net_.nodes);
    model_acc_.resize(net_.nodes);
    for (int n = 0; n < N; ++n) {
      const int p = fg_.cells[n];
      const float* u = &em.unary[std::size_t(p) * K];
      acc_[p] = cold ? 0 : w.res_t[n] - w.model_t[n];
      model_acc_[p] = 0;
      w.model_t[n] = toUnits(double(u[alpha]) - u[lab[p]]);
    }
    // Pair term with A = V(a,b), B = V(a,α), C = V(α,b), D = V(α,α) = 0 (Kolmogorov & Zabih 2004)
    // written as A + s·x_p + t·x_q + c01·(1−x_p)·x_q + c10·x_p·(1−x_q) with s + t = D − A,
    // c10 = C − A − s ≥ 0, c01 = B − A − t ≥ 0 (possible as V is a metric: B + C ≥ A + D), and s
    // as near −A/2 as allowed, which splits the term symmetrically: two equal labels give two
    // n-links of V and no t-link, instead of opposing t-links whose flow the max-flow would have
    // to push through every such pair. For Potts only five cases exist (V in capacity units):
    //   a = b ≠ α:      s = t = 0,            c01 = c10 = V
    //   a ≠ b, both ≠ α: s = −⌊V/2⌋, t = −⌈V/2⌉, c01 = ⌈V/2⌉, c10 = ⌊V/2⌋
    //   a = α ≠ b:      s = 0, t = −V          (p is α either way: q pays V unless it joins)
    //   b = α ≠ a:      s = −V, t = 0
    //   a = b = α:      nothing.
    for (std::size_t k = 0; k < fg_.pair_p.size(); ++k) {
      const int p = fg_.pair_p[k], q = fg_.pair_q[k];
      const int a = lab[p], b = lab[q];
      const int64_t V = fg_.pair_v[k], H = V / 2;
      int64_t tp = 0, tq = 0, c01 = 0, c10 = 0;
      if (a == b) {
        if (a != alpha) c01 = c10 = V;
      } else if (a == alpha) {
        tq = -V;
      } else if (b == alpha) {
        tp = -V;
      } else {
        tp = -H;
        tq = H - V;
        c01 = V - H;
        c10 = H;
      }
      model_acc_[p] += tp;
      model_acc_[q] += tq;
      int64_t r01 = c01, r10 = c10;
      if (!cold) {
        r01 += w.res_n[2 * k] - w.model_n[2 * k];
        r10 += w.res_n[2 * k + 1] - w.model_n[2 * k + 1];
      }
      w.model_n[2 * k] = c01;
      w.model_n[2 * k + 1] = c10;
      // r01 + r10 = c01 + c10 ≥ 0, so at most one is negative; move its deficit to the t-links:
      // (1−x_p)·x_q = x_p·(1−x_q) + x_q − x_p.
      if (r01 < 0) {
        r10 += r01;
        acc_[p] -= r01;
        acc_[q] += r01;
        r01 = 0;
      } else if (r10 < 0) {
        r01 += r10;
        acc_[p] += r10;
        acc_[q] -= r10;
        r10 = 0;
      }
      cap_[fg_.pair_edge[k]] = r01;  // cut when p keeps, q takes α
      cap_[fg_.pair_rev[k]] = r10;   // cut when p takes α, q keeps
    }
    for (int n = 0; n < N; ++n) {
      const int p = fg_.cells[n];
      w.model_t[n] += model_acc_[p];
      const int64_t t = acc_[p] + w.model_t[n];
      cap_[net_.src_edge[p]] = t > 0 ? t : 0;    // cut when p takes α (sink side)
      cap_[net_.sink_edge[p]] = t < 0 ? -t : 0;  // cut when p keeps its label (source side)
    }
    // Most of the flow runs s → q → p → t between neighbours. Pushing it greedily here, in one
    // pass without search trees, leaves the max-flow a residual network with less to do; the
    // cuts of the residual network are those of the original one less the pushed flow. Edges of
    // fixed cells have no capacity, so they carry nothing.
    for (int p : fg_.cells) {
      int64_t& to_sink = cap_[net_.sink_edge[p]];
      for (int d = 0; d < 8 && to_sink > 0; ++d) {
        const int e_pq = net_.dir_edge[std::size_t(p) * 8 + d];
        if (e_pq < 0) continue;
        const int e_qp = net_.rev_id[e_pq];
        int64_t& from_src = cap_[net_.src_edge[net_.target[e_pq]]];
        const int64_t f = std::min({from_src, cap_[e_qp], to_sink});
        if (f <= 0) continue;
        from_src -= f;
        cap_[e_qp] -= f;
        cap_[e_pq] += f;
        to_sink -= f;
      }
    }
    auto eidx = get(boost::edge_index, net_.g);
    auto vidx = get(boost::vertex_index, net_.g);
    boost::boykov_kolmogorov_max_flow(net_.g, boost::make_iterator_property_map(cap_.begin(), eidx),
                                      boost::make_iterator_property_map(res_.begin(), eidx),
                                      boost::make_iterator_property_map(net_.rev.begin(), eidx),
                                      boost::make_iterator_property_map(pred_.begin(), vidx),
                                      boost::make_iterator_property_map(color_.begin(), vidx),
                                      boost::make_iterator_property_map(dist_.begin(), vidx), vidx,
                                      net_.source(), net_.sink());
    for (int n = 0; n < N; ++n) {
      const int p = fg_.cells[n];
      w.res_t[n] = res_[net_.src_edge[p]] - res_[net_.sink_edge[p]];
    }
    for (std::size_t k = 0; k < fg_.pair_p.size(); ++k) {
      w.res_n[2 * k] = res_[fg_.pair_edge[k]];
      w.res_n[2 * k + 1] = res_[fg_.pair_rev[k]];
    }
    // Nodes left in the source tree are exactly those reachable from s in the residual network:
    // the source side of a minimum cut keeps its label, the rest takes α.
    move_.clear();
    for (int p : fg_.cells)
      if (color_[p] != boost::black_color && lab[p] != alpha) move_.push_back(p);
    return !move_.empty();
  }

  /// Grid labels (fixed → unknown) and score layers: the local energy margin
  /// min_{j≠k} E_c(j) − E_c(k) given the final neighbours, the score the ROC curves give an
  /// optimiser without score layers (ICM), so that deterministic optimisers are scored alike.
  void writeOutputs(FrameContext& ctx, const std::vector<uint8_t>& lab) {
    const EnergyModel& em = ctx.energy;
    auto& out = ctx.grid->labels();
    out.assign(ctx.grid->cells(), labels::kUnknown);
    if (out.size() != em.cells())
      throw std::logic_error(name() + ": energy model has " + std::to_string(em.cells()) +
                             " cells, the grid " + std::to_string(out.size()));
    for (std::size_t i = 0; i < em.cells(); ++i)
      if (!em.fixed[i]) out[i] = em.active[lab[i]];
    if (!ctx.labels) return;
    std::vector<Layer> scores = localEnergyScores(em, out, ctx.labels->size());
    for (LabelId id : em.active)
      if (id < scores.size() && !scores[id].empty())
        ctx.grid->add(layers::score(ctx.labels->name(id))) = std::move(scores[id]);
  }

  int max_cycles_ = 10;
  std::string init_ = "initial";
  bool pre_icm_ = true;
  bool block_moves_ = true;
  int block_moves_taken_ = 0;

  FlowNetwork net_;
  FrameGraph fg_;
  double scale_ = 1;  ///< capacity units per energy unit
  std::vector<WarmStart> warm_;
  std::vector<int64_t> cap_, res_, acc_, model_acc_;
  std::vector<Edge> pred_;
  std::vector<boost::default_color_type> color_;
  std::vector<std::size_t> dist_;
  std::vector<uint8_t> lab_, dirty_, in_move_;
  std::vector<uint8_t> block_dirty_;  ///< per block (top-left cell): its best move may have changed
  std::vector<double> nsum_;          ///< per cell and label: eq. 12 given the current neighbours
  PaddedLabels pad_;
  std::vector<int> move_;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::AlphaExpansion, terramrf::PluginKind::kOptimiser, "alpha_expansion",
                "α-expansion graph cuts (Boykov–Kolmogorov max-flow); scores = local energy margin")
