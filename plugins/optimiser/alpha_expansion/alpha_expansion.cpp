// α-expansion (Boykov, Veksler & Zabih 2001) with Kolmogorov's Boykov–Kolmogorov max-flow
// (Debian's libmaxflow), run only where a cut can still change.
//
// The Potts term of EnergyModel, w·δ with δ(equal) = −1 and δ(different) = +1, equals the metric
// V(a, b) = 2w·[a ≠ b] minus the constant w per pair, so minimising one minimises the other and
// α-expansion applies, with its factor-2 bound on the shifted energy (docs/optimisers.md). Every
// expansion is one min-cut; each label keeps the residual network of its last cut (cells,
// 8-neighbour pairs) for the frame, and its next cut starts from it (Kohli & Torr 2007): only the
// capacities that changed are written. The max-flow then runs on a region around the nodes still
// sending to the sink, grown until it provably holds the whole cut (cutResidual), so a cut after a
// few cells changed label costs little more than those cells. A move is kept only if the exact
// EnergyModel energy drops, so the result never lies above the start.
//
// Once no expansion improves, exact 2×2 block moves follow (`block_moves`): each 2×2 block of
// cells takes its best joint labelling given its neighbours. They contain the moves in which two
// labels enter a region at once (a rough patch that is part road, part obstacle), which no
// expansion (one label enters) and no swap (two labels trade cells) contains; after any accepted
// block move the expansions run again.
#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

// The library instantiates no graph with 64-bit capacities; its template implementation is
// shipped with the header for that.
#define MAXFLOW_INCLUDE_TEMPLATE_IMPLEMENTATION
#include <maxflow.h>

#include "terramrf/padded_labels.hpp"
#include "terramrf/plugin.hpp"
#include "terramrf/roc.hpp"

namespace terramrf {
namespace {

// 32-bit vertex and edge indices halve the size of edge descriptors (reverse and predecessor
// maps) compared with the default std::size_t.
constexpr int kDr[8] = {-1, -1, -1, 0, 0, 1, 1, 1};
constexpr int kDc[8] = {-1, 0, 1, -1, 1, -1, 0, 1};
inline bool isDiagonal(int d) { return kDr[d] != 0 && kDc[d] != 0; }

/// Pair k's arc into its node y (arcs 2k = p→q, 2k + 1 = q→p); its tail, the other node, goes to
/// x. Raw pointers, as the searches that call it keep theirs in registers.
inline uint32_t arcInto(const int* pair_np, const int* pair_nq, uint32_t k, int y, int& x) {
  const bool y_is_p = pair_np[k] == y;
  x = y_is_p ? pair_nq[k] : pair_np[k];
  return 2 * k + (y_is_p ? 1 : 0);
}

/// 64-bit capacities: 2^36 units for the largest capacity leave room for 2^26 nodes.
using CutGraph = maxflow::Graph<int64_t, int64_t, int64_t>;

[[noreturn]] void maxflowError(const char* what) {
  throw std::runtime_error(std::string("alpha_expansion: max-flow: ") + what);
}

/// The non-fixed cells (graph nodes) and their unordered 8-neighbour pairs (graph edges).
struct FrameGraph {
  std::vector<int> cells;    ///< non-fixed cells; node id n = position here
  std::vector<int> node_of;  ///< per cell: node id, −1 if fixed
  std::vector<int> pair_p,
      pair_q;                   ///< unordered neighbour pairs (cells), p before q in raster order
  std::vector<int> pair_np, pair_nq;  ///< their node ids
  std::vector<float> pair_w;    ///< their Potts weight w
  std::vector<int64_t> pair_v;  ///< V = 2w in capacity units (set once the scale is known)
  std::vector<int> pairs_off, pairs_of;  ///< per node n: its pairs pairs_of[pairs_off[n] …)

  void build(const EnergyModel& em) {
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

    fg_.build(em);
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
    in_move_.assign(em.cells(), 0);
    shift_t_.assign(fg_.cells.size(), 0);
    local_of_.assign(fg_.cells.size(), -1);
    node_seen_.assign(fg_.cells.size(), 0);
    pair_seen_.assign(fg_.pair_p.size(), 0);
    warm_.resize(K);
    for (WarmStart& w : warm_) w.cold = true;  // built by each label's first cut

    double e = em.energy(lab);
    block_dirty_.assign(em.cells(), 1);
    changes_.clear();
    int cycle = 0, expansions = 0, accepted = 0, block_passes = 0;
    block_moves_taken_ = 0;
    region_cuts_ = region_nodes_ = region_regrowths_ = 0;
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
              changes_.push_back(fg_.node_of[i]);
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
    ctx.metrics[name() + ".max_flows"] = region_cuts_;
    ctx.metrics[name() + ".max_flow_nodes_per_cut"] =
        region_cuts_ ? double(region_nodes_) / region_cuts_ : 0.0;
    ctx.metrics[name() + ".max_flow_regrowths"] = region_regrowths_;
    ctx.metrics[name() + ".energy"] = e;
    ctx.metrics[name() + ".initial_energy"] = e_initial;
  }

 private:
  /// One label's move energy for the frame: the residual network of a maximum flow after its
  /// last cut, and the move energy that cut was for (to write only what changed since).
  struct WarmStart {
    bool cold = true;                 ///< no cut yet in this frame
    std::vector<int64_t> res_t;       ///< per node: residual t-link (> 0 source, < 0 sink)
    std::vector<int64_t> res_n;       ///< per pair: residual n-links, p→q then q→p
    std::vector<int64_t> model_t;     ///< per node: cost(x=1) − cost(x=0)
    std::vector<int64_t> model_n;     ///< per pair: c01 (p→q), c10 (q→p)
    std::vector<uint8_t> lab_at;      ///< per node: its label at that cut
    std::size_t changes_at = 0;       ///< changes_ up to here are in that cut's capacities
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

  /// One raster pass of exact 2×2 block moves over the blocks marked dirty: the non-fixed cells
  /// of each block (at least two) take the joint labelling of least energy given the current
  /// labels around them (their unaries, the inner pairs between them and their pairs with the
  /// cells around).
  /// Returns the total energy change (≤ 0). A block is searched only if a bound says it could
  /// improve (every cell at its best label given the outside, every inner pair equal), which
  /// leaves uniform, settled regions alone; the search fixes the top two cells (K² cases) and
  /// solves the bottom pair of the Potts model exactly from each one's best and second-best label.
  double blockPass(const EnergyModel& em, std::vector<uint8_t>& lab) {
    const int R = em.rows, C = em.cols, K = em.numLabels();
    const double wb = em.beta, wd = em.beta_diagonal;
    // nsum_[i·K + k]: eq. 12 for cell i under k given all its current neighbours; a block's cells
    // then need only their three inner pairs taken back out, and a taken move updates the sums of
    // its cells' neighbours. Computed when a searched block first needs the cell (a pass after
    // the first searches only the blocks around what changed since).
    nsum_.resize(em.cells() * std::size_t(K));
    nsum_valid_.assign(em.cells(), 0);
    pad_.assign(em, lab);
    const int W = pad_.stride();
    const std::ptrdiff_t off[8] = {-W - 1, -W, -W + 1, -1, 1, W - 1, W, W + 1};
    auto sums = [&](int i) -> const double* {
      double* s = &nsum_[std::size_t(i) * K];
      if (nsum_valid_[i]) return s;
      nsum_valid_[i] = 1;
      // w·δ(k, l_n) summed over the neighbours: +w for every k, −2w more for the neighbour's
      // own label. The pad and fixed cells hold K, whose slot t[K] is scratch.
      const uint8_t* p = pad_.at(i / C, i % C);
      double t[kMaxBlockLabels + 1] = {}, all = 0;
      for (int d = 0; d < 8; ++d) {
        const double w = isDiagonal(d) ? wd : wb;
        all += p[off[d]] < K ? w : 0.0;
        t[p[off[d]]] -= 2 * w;
      }
      const float* u = &em.unary[std::size_t(i) * K];
      for (int k = 0; k < K; ++k) s[k] = u[k] + all + t[k];
      return s;
    };
    // A cell's margin: how far its second-best label's sum lies above its own label's.
    margin_.resize(em.cells());
    auto margin = [&](int i) {
      if (nsum_valid_[i] == 2) return margin_[i];
      const double* s = sums(i);
      const int l = lab[i];
      double m = INFINITY;
      for (int k = 0; k < K; ++k)
        if (k != l) m = std::min(m, s[k]);
      nsum_valid_[i] = 2;
      return margin_[i] = m - s[l];
    };
    auto relabel = [&](int i, int to) {
      const int from = lab[i], ri = i / C, ci = i % C;
      lab[i] = static_cast<uint8_t>(to);
      *pad_.at(ri, ci) = static_cast<uint8_t>(to);  // the sums computed later read it
      if (nsum_valid_[i]) nsum_valid_[i] = 1;       // a margin is from the cell's label
      changes_.push_back(fg_.node_of[i]);
      for (int d = 0; d < 8; ++d) {
        const int rr = ri + kDr[d], cc = ci + kDc[d];
        if (rr < 0 || rr >= R || cc < 0 || cc >= C || em.fixed[rr * C + cc]) continue;
        if (!nsum_valid_[rr * C + cc]) continue;  // computed from the new labels when needed
        nsum_valid_[rr * C + cc] = 1;             // its margin is not
        const double w = isDiagonal(d) ? wd : wb;
        double* s = &nsum_[std::size_t(rr * C + cc) * K];
        s[from] += 2 * w;
        s[to] -= 2 * w;
      }
      touchBlocks(i, R, C);
    };
    // Inner neighbours of block cell j (cells 0 1 / 2 3): edge, edge, diagonal.
    static constexpr int kInner[4][3] = {{1, 2, 3}, {0, 3, 2}, {3, 0, 1}, {2, 1, 0}};
    const double w_inner[3] = {wb, wb, wd};
    const double inner_all =
        2 * wb + wd;  // Σ w_inner: every cell has two inner edges, one diagonal
    // With non-negative weights, a block of four non-fixed cells whose labels are not all equal
    // pays at least the cheapest cut of its six pairs over their minimum: one cell against three
    // (2wb + wd), or top/bottom or left/right (2wb + 2wd), or the diagonals apart (4wb), each
    // pair 2w.
    const double split_extra = wb >= 0 && wd >= 0 ? 2 * std::min(2 * wb + wd, 4 * wb) : 0.0;
    auto dl = [](int a, int b) { return a == b ? -1.0 : 1.0; };
    double total = 0;
    double local[4][kMaxBlockLabels], f2[kMaxBlockLabels], f3[kMaxBlockLabels];
    for (int r = 0; r + 1 < R; ++r)
      for (int c = 0; c + 1 < C; ++c) {
        if (!block_dirty_[r * C + c]) continue;
        block_dirty_[r * C + c] = 0;
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
        if (all_free && split_extra > 0 && cur[0] == cur[1] && cur[0] == cur[2] &&
            cur[0] == cur[3] && margin(cell[0]) >= 2 * inner_all &&
            margin(cell[1]) >= 2 * inner_all && margin(cell[2]) >= 2 * inner_all &&
            margin(cell[3]) >= 2 * inner_all)
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
        const double bound =
            inner_min + std::min(uniform, each_min + (all_free ? split_extra : 0.0));
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

  /// Potts pair term of an expansion, with A = V(a,b), B = V(a,α), C = V(α,b), D = V(α,α) = 0
  /// (Kolmogorov & Zabih 2004), written as A + s·x_p + t·x_q + c01·(1−x_p)·x_q + c10·x_p·(1−x_q)
  /// with s + t = D − A, c10 = C − A − s ≥ 0, c01 = B − A − t ≥ 0 (possible as V is a metric:
  /// B + C ≥ A + D), and s as near −A/2 as allowed, which splits the term symmetrically: two
  /// equal labels give two n-links of V and no t-link, instead of opposing t-links whose flow the
  /// max-flow would have to push through every such pair. For Potts only five cases exist:
  ///   a = b ≠ α:      s = t = 0,            c01 = c10 = V
  ///   a ≠ b, both ≠ α: s = −⌊V/2⌋, t = −⌈V/2⌉, c01 = ⌈V/2⌉, c10 = ⌊V/2⌋
  ///   a = α ≠ b:      s = 0, t = −V          (p is α either way: q pays V unless it joins)
  ///   b = α ≠ a:      s = −V, t = 0
  ///   a = b = α:      nothing.
  struct PairTerm {
    int64_t s = 0, t = 0, c01 = 0, c10 = 0;
  };
  static PairTerm pairTerm(int a, int b, int alpha, int64_t V) {
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

  /// Writes pair k's new n-link capacities into α's residual network (the previous residual plus
  /// the change of the model); a deficit goes to the t-links via shift_t_.
  void updatePair(WarmStart& w, std::size_t k, const PairTerm& m) {
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

  /// Writes node n's new t-link (signed: > 0 from the source, cut when the cell takes α; < 0 to
  /// the sink) into α's residual network.
  void updateNode(WarmStart& w, int n, int64_t model) {
    w.res_t[n] += model - w.model_t[n] + shift_t_[n];
    shift_t_[n] = 0;
    w.model_t[n] = model;
  }

  /// Node n's unary difference cost(α) − cost(its label), in capacity units.
  int64_t unaryModel(const EnergyModel& em, const std::vector<uint8_t>& lab, int alpha, int n) {
    const int p = fg_.cells[n];
    const float* u = &em.unary[std::size_t(p) * em.numLabels()];
    return toUnits(double(u[alpha]) - u[lab[p]]);
  }

  /// Node n's model t-link: its unary difference plus its share of its pairs' terms.
  int64_t nodeModel(const EnergyModel& em, const std::vector<uint8_t>& lab, int alpha, int n) {
    const int p = fg_.cells[n];
    int64_t t = unaryModel(em, lab, alpha, n);
    for (int j = fg_.pairs_off[n]; j < fg_.pairs_off[n + 1]; ++j) {
      const int k = fg_.pairs_of[j];
      const PairTerm m = pairTerm(lab[fg_.pair_p[k]], lab[fg_.pair_q[k]], alpha, fg_.pair_v[k]);
      t += fg_.pair_p[k] == p ? m.s : m.t;
    }
    return t;
  }

  /// Best α-expansion of `lab` by one min-cut: the cells that would take α go to move_. Returns
  /// false if there are none.
  ///
  /// Each label keeps the residual network of its last cut for the frame (Kohli & Torr 2007): it
  /// represents that move energy up to a constant, so the new move energy is that residual plus
  /// the change of the capacities, which only the cells whose label changed since (their pairs,
  /// and their and their neighbours' t-links) have. Those are written, and the max-flow runs
  /// only around the nodes left sending to the sink (cutResidual): an expansion after a few
  /// changed cells costs about as much as those cells.
  bool expand(const EnergyModel& em, const std::vector<uint8_t>& lab, int alpha) {
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
        for (int j = fg_.pairs_off[n]; j < fg_.pairs_off[n + 1]; ++j)
          pair_seen_[fg_.pairs_of[j]] = 0;
      }
    }
    return cutResidual(w, lab, alpha);
  }

  /// Completes the flow in α's residual network to a maximum flow and puts the cells on the sink
  /// side of the minimum cut into move_: those that can still send to the sink, the least set of
  /// cells a best move needs (of equally good moves, the smallest).
  ///
  /// Only the neighbourhood of the nodes still sending to the sink needs the max-flow. Every
  /// other node has source capacity left, so it is on the source side, and whatever reaches the
  /// sink enters that neighbourhood from outside over an arc with residual capacity. So the
  /// region is the nodes within `depth` such arcs backwards of those sending to the sink; its
  /// last layer, the ring, holds its own t-links but not its arcs further out. After a max-flow on
  /// that subnetwork, if no ring node can reach the sink, no path from the source can either: it
  /// would have to enter through a ring node, which has source capacity or a path to the source
  /// within the region. Then the region's sink side is the whole graph's. Otherwise the region
  /// grows outwards from the ring nodes that can reach the sink, twice as deep each time: the
  /// new nodes and their pairs are added to the library's network, which keeps the flow found so
  /// far, and its max-flow runs again with fresh search trees. (Reusing its trees, with the new
  /// nodes and arc ends marked, took 6 % more instructions on the stress grid; rebuilding the
  /// network from scratch, 4 % more.)
  bool cutResidual(WarmStart& w, const std::vector<uint8_t>& lab, int alpha) {
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

  /// Before a cold cut, on its residual network (res_t per node, res_n per pair): most of the flow
  /// runs s → q → p → t between neighbours, and much of the rest through a few cells between them.
  /// Pushing it greedily, in a pass over the pairs, then along shortest paths found by short
  /// searches back from each cell still sending to the sink, leaves the max-flow much less to
  /// augment and far fewer nodes to start its region from (cutResidual). The cut is the same: the
  /// nodes that can reach t in the residual network are the same for every maximum flow.
  void greedyFlow(int64_t* const res_t, int64_t* const res_n) {
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

  FrameGraph fg_;
  double scale_ = 1;  ///< capacity units per energy unit
  std::vector<WarmStart> warm_;
  std::vector<int64_t> shift_t_;  ///< per node: deficits moved off n-links, not yet written
  /// Depth of a cut's region, in arcs back from the nodes sending to the sink (cutResidual).
  static constexpr int kRegionDepth = 2;
  std::unique_ptr<CutGraph> region_graph_;  ///< the region's max-flow network, reset per cut
  std::vector<int> region_;              ///< a cut's region: nodes in the order added, seeds first
  std::vector<int> layer_, next_layer_;  ///< a cut's region: the layer a growth starts from
  std::vector<int> ring_;                ///< a cut's region: nodes with arcs in from outside
  std::vector<int> local_of_;               ///< per node: its place in region_, −1 outside
  std::vector<int> region_pairs_;           ///< pairs with arcs in the region network, in arc order
  long region_cuts_ = 0, region_nodes_ = 0, region_regrowths_ = 0;
  std::vector<int> touched_;      ///< nodes whose t-link is rewritten in this cut
  std::vector<uint32_t> bfs_from_;     ///< per node: the arc the search reached it by
  std::vector<uint32_t> bfs_seen_;     ///< per node: the stamp of the search that reached it
  std::vector<uint8_t> dry_;           ///< per node: a search through it came up short
  uint32_t bfs_stamp_ = 0;
  std::vector<int> changes_;      ///< nodes, each time its cell's label changed in this frame
  std::vector<uint8_t> node_seen_, pair_seen_;
  std::vector<uint8_t> lab_, dirty_, in_move_;
  std::vector<uint8_t> block_dirty_;  ///< per block (top-left cell): its best move may have changed
  std::vector<double> nsum_;          ///< per cell and label: eq. 12 given the current neighbours
  std::vector<uint8_t> nsum_valid_;   ///< per cell: 1 nsum_ computed in this pass, 2 and margin_
  std::vector<double> margin_;        ///< per cell: second-best label's nsum_ minus its label's
  PaddedLabels pad_;
  std::vector<int> move_;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(
    terramrf::AlphaExpansion, terramrf::PluginKind::kOptimiser, "alpha_expansion",
    "α-expansion graph cuts (Boykov–Kolmogorov max-flow on the regions a cut can change); scores = "
    "local energy margin")
