// The "alpha_expansion" optimiser: known answers (no smoothing → unary argmin; strong smoothing →
// the best constant labelling), single-cell stability, score layers (the local energy margin),
// fixed cells, init choices.
#include <gtest/gtest.h>

#include <algorithm>
#include <boost/graph/adjacency_list.hpp>
#include <boost/graph/boykov_kolmogorov_max_flow.hpp>
#include <cmath>
#include <random>

#include "optimiser_test_support.hpp"
#include "terramrf/roc.hpp"

namespace terramrf {
namespace {

using test::OptimiserHarness;
using test::RandomModelSpec;

const char* kClasses[] = {"road", "rough", "obstacle", "vegetation"};

TEST(AlphaExpansion, WithoutSmoothingEveryCellTakesItsUnaryArgmin) {
  RandomModelSpec s;
  s.size = 15;
  s.labels = 4;
  EnergyModel em = test::randomModel(21, s);
  em.beta = em.beta_diagonal = 0.f;
  OptimiserHarness h;
  const auto r = h.run("alpha_expansion", "{}", em);
  test::expectValidResult(r, em, "beta 0");
  for (std::size_t i = 0; i < em.cells(); ++i) {
    if (em.fixed[i]) continue;
    const float* u = &em.unary[i * 4];
    EXPECT_EQ(r.indices[i], std::min_element(u, u + 4) - u) << "cell " << i;
  }
  EXPECT_TRUE(r.report.converged);
}

TEST(AlphaExpansion, StrongSmoothingGivesTheBestConstantLabelling) {
  // With β ≫ unaries the optimum is one label everywhere (the one with the least unary sum), and
  // that labelling is one expansion move away from any start, so α-expansion must find it.
  RandomModelSpec s;
  s.size = 12;
  s.labels = 4;
  s.fixed_fraction = 0;
  s.unary_lo = 0;
  s.unary_hi = 1;
  EnergyModel em = test::randomModel(22, s);
  em.beta = em.beta_diagonal = 50.f;
  std::vector<double> sum(4, 0.0);
  for (std::size_t i = 0; i < em.cells(); ++i)
    for (int k = 0; k < 4; ++k) sum[k] += em.unary[i * 4 + k];
  const int k_star = static_cast<int>(std::min_element(sum.begin(), sum.end()) - sum.begin());
  OptimiserHarness h;
  const auto r = h.run("alpha_expansion", "{}", em);
  test::expectValidResult(r, em, "beta 50");
  for (std::size_t i = 0; i < em.cells(); ++i) ASSERT_EQ(r.indices[i], k_star) << "cell " << i;
}

TEST(AlphaExpansion, ResultIsStableUnderSingleCellChangesAndScoresAgree) {
  // Changing one cell to α is an α-expansion move, so at convergence no single-cell change lowers
  // the energy: each cell's own label has a margin ≥ 0 and every other label one ≤ 0.
  RandomModelSpec s;
  s.size = 25;
  s.labels = 4;
  s.fixed_fraction = 0.2;
  const EnergyModel em = test::randomModel(23, s);
  OptimiserHarness h;
  const auto r = h.run("alpha_expansion", "{max_cycles: 50}", em);
  test::expectValidResult(r, em, "stability");
  ASSERT_TRUE(r.report.converged);
  const auto lab = OptimiserHarness::labelling(r, em);
  for (int i = 0; i < static_cast<int>(em.cells()); ++i) {
    const float v0 = r.scores.at("road")[i];
    if (em.fixed[i]) {
      EXPECT_EQ(r.grid_labels[i], labels::kUnknown);
      EXPECT_TRUE(std::isnan(v0));
      continue;
    }
    const double own = em.localEnergy(lab, i, lab[i]);
    for (int k = 0; k < 4; ++k) {
      EXPECT_GE(em.localEnergy(lab, i, k), own - 1e-6) << "cell " << i << " label " << k;
      const double v = r.scores.at(kClasses[k])[i];
      if (k == lab[i]) {
        EXPECT_GE(v, -1e-6) << "cell " << i;
      } else {
        EXPECT_LE(v, 1e-6) << "cell " << i << " label " << k;
      }
    }
  }
}

TEST(AlphaExpansion, ResultIsALocalMinimumOfEveryExpansionMove) {
  // The defining property (and the premise of the factor-2 bound): at convergence no α-expansion
  // move, checked by enumerating all of them on 4×4 grids, lowers the energy. Without the ICM
  // start the cuts do all the work, several per label, so warm-started cuts are exercised too.
  OptimiserHarness h;
  for (int n = 0; n < 12; ++n) {
    RandomModelSpec s;
    s.size = 4;
    s.labels = 3 + n % 2;
    s.fixed_fraction = n % 3 == 0 ? 0.15 : 0.0;
    s.beta_lo = 0.1;
    s.beta_hi = 0.9;
    const EnergyModel em = test::randomModel(60 + n, s);
    for (const char* params : {"{pre_icm: false, max_cycles: 50}", "{max_cycles: 50}"}) {
      const auto r = h.run("alpha_expansion", params, em);
      test::expectValidResult(r, em, params);
      ASSERT_TRUE(r.report.converged) << params;
      const auto lab = OptimiserHarness::labelling(r, em);
      for (int alpha = 0; alpha < s.labels; ++alpha)
        EXPECT_GE(test::bestExpansionEnergy(em, lab, alpha), r.report.final_energy - 1e-6)
            << params << " grid " << n << " alpha " << alpha;
    }
  }
}

TEST(AlphaExpansion, EveryCutIsTheBestExpansionMoveAlongTheWholeRun) {
  // Same start, same label order, same acceptance: the plugin (warm-started integer cuts with a
  // greedy pre-push) must retrace the enumerating reference move for move, including the
  // repeated expansions of a label after others changed the labelling.
  OptimiserHarness h;
  int repeats_total = 0;
  for (int n = 0; n < 12; ++n) {
    RandomModelSpec s;
    s.size = 4;
    s.labels = 3 + n % 2;
    s.fixed_fraction = n % 3 == 0 ? 0.15 : 0.0;
    s.beta_lo = 0.1;
    s.beta_hi = 0.9;
    const EnergyModel em = test::randomModel(100 + n, s);
    int ref_cycles = 0, repeats = 0;
    const auto ref = test::referenceExpansion(em, &ref_cycles, &repeats);
    repeats_total += repeats;
    const auto r =
        h.run("alpha_expansion", "{pre_icm: false, max_cycles: 50, block_moves: false}", em);
    EXPECT_EQ(OptimiserHarness::labelling(r, em), ref) << "grid " << n;
    EXPECT_EQ(r.report.iterations, ref_cycles) << "grid " << n;
  }
  EXPECT_GE(repeats_total, 10) << "too few repeated expansions: warm starts go untested";
  RecordProperty("warm_started_expansions", repeats_total);
}

// Textbook α-expansion as an independent reference for grids too large to enumerate: every cut
// from scratch on a fresh Boost adjacency_list with double capacities, the pair term in the
// asymmetric form of Kolmogorov & Zabih (2004), no warm start, no pre-push.
using RefTraits = boost::adjacency_list_traits<boost::vecS, boost::vecS, boost::directedS>;
using RefGraph = boost::adjacency_list<
    boost::vecS, boost::vecS, boost::directedS,
    boost::property<
        boost::vertex_color_t, boost::default_color_type,
        boost::property<boost::vertex_distance_t, long,
                        boost::property<boost::vertex_predecessor_t, RefTraits::edge_descriptor>>>,
    boost::property<
        boost::edge_capacity_t, double,
        boost::property<boost::edge_residual_capacity_t, double,
                        boost::property<boost::edge_reverse_t, RefTraits::edge_descriptor>>>>;

void addEdge(RefGraph& g, int u, int v, double cap) {
  auto e = boost::add_edge(u, v, g).first, r = boost::add_edge(v, u, g).first;
  boost::put(boost::edge_capacity, g, e, cap);
  boost::put(boost::edge_capacity, g, r, 0.0);
  boost::put(boost::edge_reverse, g, e, r);
  boost::put(boost::edge_reverse, g, r, e);
}

/// The energy terms of a 2×2 block of cells (0 1 / 2 3): the unaries of its non-fixed cells and
/// their pairs with non-fixed neighbours, pairs inside the block once.
double blockEnergy(const EnergyModel& em, const std::vector<uint8_t>& lab, const int* cells) {
  const int R = em.rows, C = em.cols, K = em.numLabels();
  double e = 0;
  for (int j = 0; j < 4; ++j) {
    const int i = cells[j], r = i / C, c = i % C;
    if (em.fixed[i]) continue;
    e += em.unary[std::size_t(i) * K + lab[i]];
    for (int dr = -1; dr <= 1; ++dr)
      for (int dc = -1; dc <= 1; ++dc) {
        const int rr = r + dr, cc = c + dc, n = rr * C + cc;
        if ((dr == 0 && dc == 0) || rr < 0 || rr >= R || cc < 0 || cc >= C || em.fixed[n]) continue;
        if (std::find(cells, cells + 4, n) != cells + 4 && n < i) continue;  // counted from n
        const double w = dr != 0 && dc != 0 ? em.beta_diagonal : em.beta;
        e += lab[n] == lab[i] ? -w : w;
      }
  }
  return e;
}

/// The non-fixed cells of the 2×2 block at (r, c) (0 1 / 2 3), in that order.
std::vector<int> freeBlockCells(const EnergyModel& em, int r, int c) {
  const int C = em.cols;
  std::vector<int> out;
  for (int i : {r * C + c, r * C + c + 1, (r + 1) * C + c, (r + 1) * C + c + 1})
    if (!em.fixed[i]) out.push_back(i);
  return out;
}

/// Writes labelling number `code` (base K) of `cells` into `lab`.
void setCode(std::vector<uint8_t>& lab, const std::vector<int>& cells, int code, int K) {
  for (std::size_t j = 0; j < cells.size(); ++j, code /= K)
    lab[cells[j]] = static_cast<uint8_t>(code % K);
}

/// One raster pass of 2×2 block moves by enumeration: the non-fixed cells of each block (at
/// least two) take their best joint labelling given the current labels around them, if that is
/// better by more than the plugin's tolerance. Returns the moves taken.
int textbookBlockPass(const EnergyModel& em, std::vector<uint8_t>& lab) {
  const int R = em.rows, C = em.cols, K = em.numLabels();
  int moves = 0;
  for (int r = 0; r + 1 < R; ++r)
    for (int c = 0; c + 1 < C; ++c) {
      const int cells[4] = {r * C + c, r * C + c + 1, (r + 1) * C + c, (r + 1) * C + c + 1};
      const std::vector<int> movable = freeBlockCells(em, r, c);
      if (movable.size() < 2) continue;
      const double now = blockEnergy(em, lab, cells);
      double best = now - 1e-9 * (1.0 + std::abs(now));
      int best_code = -1, codes = 1;
      for (std::size_t j = 0; j < movable.size(); ++j) codes *= K;
      std::vector<uint8_t> probe = lab;
      for (int code = 0; code < codes; ++code) {
        setCode(probe, movable, code, K);
        const double e = blockEnergy(em, probe, cells);
        if (e < best) best = e, best_code = code;
      }
      if (best_code < 0) continue;
      setCode(lab, movable, best_code, K);
      ++moves;
    }
  return moves;
}

/// Textbook α-expansion from the initial labelling, cycle by cycle; with `block_moves`, a cycle
/// in which no expansion improves ends with a block pass, and another cycle follows if it moved.
std::vector<uint8_t> textbookExpansion(const EnergyModel& em, int* cycles, bool block_moves = false,
                                       int* moves_taken = nullptr) {
  const int R = em.rows, C = em.cols, K = em.numLabels(), n = R * C;
  std::vector<uint8_t> lab = em.initial;
  double e = em.energy(lab);
  *cycles = 0;
  if (moves_taken) *moves_taken = 0;
  for (bool improved = true; improved;) {
    improved = false;
    ++*cycles;
    for (int alpha = 0; alpha < K; ++alpha) {
      RefGraph g(n + 2);
      const int src = n, snk = n + 1;
      std::vector<double> t(n, 0.0);  // cost(x=1) − cost(x=0)
      for (int i = 0; i < n; ++i)
        if (!em.fixed[i]) t[i] = em.unary[i * K + alpha] - em.unary[i * K + lab[i]];
      static const int dr[4] = {0, 1, 1, 1}, dc[4] = {1, 0, 1, -1};
      for (int r = 0; r < R; ++r)
        for (int c = 0; c < C; ++c)
          for (int d = 0; d < 4; ++d) {
            const int p = r * C + c, rr = r + dr[d], cc = c + dc[d], q = rr * C + cc;
            if (rr >= R || cc < 0 || cc >= C || em.fixed[p] || em.fixed[q]) continue;
            const double v = 2.0 * (dr[d] && dc[d] ? em.beta_diagonal : em.beta);
            const double A = lab[p] != lab[q] ? v : 0, B = lab[p] != alpha ? v : 0,
                         Cc = alpha != lab[q] ? v : 0;
            t[p] += Cc - A;
            t[q] -= Cc;
            addEdge(g, p, q, B + Cc - A);
          }
      for (int i = 0; i < n; ++i) {
        if (em.fixed[i]) continue;
        if (t[i] > 0) addEdge(g, src, i, t[i]);
        if (t[i] < 0) addEdge(g, i, snk, -t[i]);
      }
      boost::boykov_kolmogorov_max_flow(g, src, snk);
      std::vector<uint8_t> move = lab;
      for (int i = 0; i < n; ++i)
        if (!em.fixed[i] && boost::get(boost::vertex_color, g, i) != boost::black_color)
          move[i] = static_cast<uint8_t>(alpha);
      const double en = em.energy(move);
      if (en < e - 1e-9 * (1.0 + std::abs(e))) {
        lab = move;
        e = en;
        improved = true;
      }
    }
    if (!improved && block_moves) {
      const int moves = textbookBlockPass(em, lab);
      if (moves_taken) *moves_taken += moves;
      e = em.energy(lab);
      improved = moves > 0;
    }
  }
  return lab;
}

/// Blocks of `block`² cells with random true labels; unary_k = −[k = truth] + σ·N(0,1); the
/// unary argmin as initial labelling.
EnergyModel blockyModel(uint32_t seed, int size, int labels, int block, double sigma,
                        double fixed_fraction) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> label(0, labels - 1);
  std::normal_distribution<double> noise(0, sigma);
  std::uniform_real_distribution<double> coin(0, 1);
  const int nb = (size + block - 1) / block;
  std::vector<int> truth(nb * nb);
  for (int& t : truth) t = label(rng);
  EnergyModel em;
  em.resize(size, size, labels);
  for (int k = 0; k < labels; ++k) em.active[k] = static_cast<LabelId>(k + 1);
  for (int r = 0; r < size; ++r)
    for (int c = 0; c < size; ++c) {
      const int i = r * size + c, t = truth[(r / block) * nb + c / block];
      float* u = &em.unary[std::size_t(i) * labels];
      for (int k = 0; k < labels; ++k)
        u[k] = static_cast<float>((k == t ? -1.0 : 0.0) + noise(rng));
      em.initial[i] = static_cast<uint8_t>(std::min_element(u, u + labels) - u);
      em.fixed[i] = coin(rng) < fixed_fraction;
    }
  em.beta = em.beta_diagonal = 0.6f;
  return em;
}

TEST(AlphaExpansion, MatchesATextbookImplementationOnLargerGrids) {
  // Warm-started cuts that must move cells (the ones whose errors the energy check cannot hide)
  // happen in third and later cycles, which these 40×40 blocky grids need; the trajectory must
  // still be the textbook one, cut for cut.
  OptimiserHarness h;
  int long_runs = 0;
  double regrowths = 0;
  for (int n = 0; n < 12; ++n) {
    // Like the benchmark: blocky truth, noisy unaries, the unary argmin as start.
    const EnergyModel em = blockyModel(300 + n, 40, 3 + n % 2, 10, 0.6, n % 3 ? 0.1 : 0.0);
    int ref_cycles = 0;
    const auto ref = textbookExpansion(em, &ref_cycles);
    const auto r =
        h.run("alpha_expansion",
              "{pre_icm: false, max_cycles: 50, block_moves: false, strip_moves: false}", em);
    EXPECT_EQ(OptimiserHarness::labelling(r, em), ref) << "grid " << n;
    EXPECT_EQ(r.report.iterations, ref_cycles) << "grid " << n;
    EXPECT_NEAR(r.report.final_energy, em.energy(ref), 1e-6) << "grid " << n;
    long_runs += ref_cycles >= 3;
    regrowths += r.metrics.at("alpha_expansion.max_flow_regrowths");
  }
  EXPECT_GE(long_runs, 6) << "too few runs with improving warm-started cuts";
  // A cut's max-flow runs on a region around the cells still sending to the sink, grown when
  // its ring could reach the sink; the growing must be exercised for the comparison to test it.
  EXPECT_GE(regrowths, 5) << "the max-flow regions never had to grow";
}

// The block moves too, move for move: the bound that skips blocks, the sums kept up to date as
// moves are taken, and the exact search inside a block must together give what enumerating
// the labellings of every block's non-fixed cells in raster order gives.
TEST(AlphaExpansion, BlockMovesMatchEnumeratingEveryBlock) {
  OptimiserHarness h;
  int total_moves = 0;
  for (int n = 0; n < 10; ++n) {
    // Block moves are rare on noisy grids alone (3 on the 200 × 200 benchmark); planted pairs
    // (see plantedPairs) in a noisy grid make them common, with noisy cells around them.
    EnergyModel em = blockyModel(900 + n, 32, 3 + n % 2, 8, 0.5, n % 3 ? 0.05 : 0.0);
    // Equal weights, and diagonals weaker or stronger (then splitting the block along its
    // diagonals is the cheapest cut).
    em.beta = n % 3 == 2 ? 0.4f : 1.f;
    em.beta_diagonal = n % 3 == 0 ? 1.f : n % 3 == 1 ? 0.5f : 1.2f;
    const int K = em.numLabels();
    std::mt19937 rng(1900 + n);
    std::uniform_int_distribution<int> pos(1, 32 - 3), dir(0, 2), other(0, K - 1);
    // As in plantedPairs: alone, a cell cannot pay its eight boundaries, a pair can.
    const double wb = em.beta, wd = em.beta_diagonal;
    std::uniform_real_distribution<double> frac(0.2, 0.9);
    for (int p = 0; p < 80; ++p) {
      const int a = pos(rng) * 32 + pos(rng), d = dir(rng);
      const int b = a + (d == 0 ? 1 : d == 1 ? 32 : 33);
      const int la = other(rng), lb = (la + 1 + rng() % (K - 1)) % K;
      for (const auto& [cell, l] : {std::pair<int, int>{a, la}, {b, lb}}) {
        const double gain = d == 2 ? 8 * wb + 7 * wd + frac(rng) * wd  // diagonal pair
                                   : 7 * wb + 8 * wd + frac(rng) * wb;
        em.fixed[cell] = 0;
        float* u = &em.unary[std::size_t(cell) * K];
        if (l != em.initial[cell]) u[l] = u[em.initial[cell]] - static_cast<float>(gain);
      }
      // A follower left of a horizontal pair's A: it prefers A's label by just less than it
      // pays alone or together with A (an expansion), and by more than it pays once the pair
      // has moved. Expansions that must see the block moves' changes follow.
      if (d == 0 && a % 32 >= 1) {
        const int f = a - 1;
        em.fixed[f] = 0;
        float* u = &em.unary[std::size_t(f) * K];
        if (la != em.initial[f]) u[la] = u[em.initial[f]] - static_cast<float>(4.05 * wb + 8 * wd);
      }
    }
    int ref_cycles = 0, ref_moves = 0;
    const auto ref = textbookExpansion(em, &ref_cycles, true, &ref_moves);
    const auto r =
        h.run("alpha_expansion", "{pre_icm: false, max_cycles: 50, strip_moves: false}", em);
    EXPECT_EQ(OptimiserHarness::labelling(r, em), ref) << "grid " << n;
    EXPECT_EQ(r.report.iterations, ref_cycles) << "grid " << n;
    EXPECT_EQ(r.metrics.at("alpha_expansion.block_moves"), ref_moves) << "grid " << n;
    total_moves += ref_moves;
  }
  EXPECT_GE(total_moves, 25) << "too few block moves to compare";
}

/// A 4 × 4 grid with 3 labels, all at label 0, which costs 0; labels 1 and 2 cost `other`.
EnergyModel labelZeroGrid(float other) {
  EnergyModel em;
  em.resize(4, 4, 3);
  for (int k = 0; k < 3; ++k) em.active[k] = static_cast<LabelId>(k + 1);
  for (std::size_t i = 0; i < em.cells(); ++i) {
    em.unary[i * 3] = 0.f;
    em.unary[i * 3 + 1] = em.unary[i * 3 + 2] = other;
    em.initial[i] = 0;
  }
  return em;
}

/// Runs α-expansion on `em` without the moves `on` switches on, which must stay at the initial
/// labelling, and with them, which must reach `want` and lower the energy by `gain`; returns the
/// second run. Block moves by default (strips, which contain them, off in both runs).
test::OptimiserRun expectOnlyBlockMovesReach(
    const EnergyModel& em, const std::vector<uint8_t>& want, double gain, const std::string& what,
    const std::string& off = "{block_moves: false, strip_moves: false}",
    const std::string& on = "{strip_moves: false}") {
  const double e0 = em.energy(em.initial);
  OptimiserHarness h;
  const auto stuck = h.run("alpha_expansion", off, em);
  EXPECT_NEAR(stuck.report.final_energy, e0, 1e-9) << what;
  const auto r = h.run("alpha_expansion", on, em);
  test::expectValidResult(r, em, what);
  EXPECT_EQ(OptimiserHarness::labelling(r, em), want) << what;
  EXPECT_NEAR(r.report.final_energy, e0 - gain, 1e-5) << what;
  return r;
}

// Two labels that must enter together: a 4×4 grid of label 0 (strong Potts, w = 1) in which cell
// A = (1, 1) prefers label 1 and its neighbour B = (1, 2) label 2 by 15.5 each. Alone, either
// change pays its eight boundaries (+16) and loses 0.5; together they share the A–B boundary,
// paid once, and gain 1. No expansion (one label enters) and no swap (cells trade two labels)
// contains that move: only the 2×2 block moves find it.
/// labelZeroGrid(1) with w = 1, in which cell a prefers label 1 and cell b label 2 by `gain`
/// (and the other of the two labels costs them 5); sets `want` to that labelling.
EnergyModel twoCellsWantingTwoLabels(int a, int b, float gain, std::vector<uint8_t>& want) {
  EnergyModel em = labelZeroGrid(1.f);
  em.unary[a * 3 + 1] = -gain;
  em.unary[a * 3 + 2] = 5.f;
  em.unary[b * 3 + 1] = 5.f;
  em.unary[b * 3 + 2] = -gain;
  em.beta = em.beta_diagonal = 1.f;
  want = em.initial;
  want[a] = 1;
  want[b] = 2;
  return em;
}

TEST(AlphaExpansion, BlockMovesLetTwoLabelsEnterAtOnce) {
  std::vector<uint8_t> want;
  const EnergyModel em = twoCellsWantingTwoLabels(1 * 4 + 1, 1 * 4 + 2, 15.5f, want);
  const auto r = expectOnlyBlockMovesReach(em, want, 1.0, "two labels entering");
  EXPECT_EQ(r.metrics.at("alpha_expansion.block_moves"), 1.0);
}

// Two cells beside fixed ones: in a 4×4 grid of label 0 (w = 1), A = (1, 2) prefers label 1 and
// its diagonal neighbour B = (2, 1) label 2 by 11.5 each, and the other two cells of their block,
// (1, 1) and (2, 2), have no points (fixed, no pairs). Alone, either pays its six boundaries
// (+12); together they pay 22. No block of four free cells holds both, so the block moves must
// move the free cells of a block that has fixed ones (as on SemanticKITTI seq 00 frame 2, where
// Gibbs found such a move and α-expansion did not).
TEST(AlphaExpansion, BlockMovesMoveTheFreeCellsBesideFixedOnes) {
  std::vector<uint8_t> want;
  EnergyModel em = twoCellsWantingTwoLabels(1 * 4 + 2, 2 * 4 + 1, 11.5f, want);
  em.fixed[1 * 4 + 1] = em.fixed[2 * 4 + 2] = 1;
  const auto r = expectOnlyBlockMovesReach(em, want, 1.0, "beside fixed cells");
  EXPECT_EQ(r.metrics.at("alpha_expansion.block_moves"), 1.0);
}

// Strong diagonals (wd = 1 > 2·wb = 0.5), where splitting a 2×2 block along its diagonals is its
// cheapest cut (8wb = 2 against 2(2wb + wd) = 3 for one cell against three). In a 4×4 grid of
// label 0, the diagonal cells a, d of the middle block prefer label 1 and b, c label 2, each by
// 7.6: either label entering alone pays 16 for 15.2, both together pay 30 for 30.4. The move
// gains 0.4 and each cell's best label given the outside gains 0.6, so only a bound that uses
// the diagonal cut lets the block be searched.
TEST(AlphaExpansion, BlockMovesSplitAlongStrongDiagonals) {
  // Labels 1 and 2 cost 10 elsewhere: no diagonal pattern pays outside the middle block.
  EnergyModel em = labelZeroGrid(10.f);
  const int a = 1 * 4 + 1, b = 1 * 4 + 2, c = 2 * 4 + 1, d = 2 * 4 + 2;
  for (int i : {a, d}) em.unary[i * 3 + 1] = -7.6f;
  for (int i : {b, c}) em.unary[i * 3 + 2] = -7.6f;
  em.beta = 0.25f;
  em.beta_diagonal = 1.f;
  std::vector<uint8_t> want = em.initial;
  want[a] = want[d] = 1;
  want[b] = want[c] = 2;
  expectOnlyBlockMovesReach(em, want, 0.4, "diagonal split");
}

/// A grid of label 0 (unaries 0 for it, 1 + U(0, 0.3) for the others; w = 1) with `pairs`
/// neighbouring cells A, B planted at random, each preferring its own other label by 15.2–15.9:
/// alone, a cell with eight free neighbours cannot pay its boundaries (+16), together a pair can
/// (+30, one boundary shared), so only a block move takes it; near fixed cells (3 %) or another
/// pair, an expansion may.
EnergyModel plantedPairs(uint32_t seed, int size, int labels, int pairs) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> noise(0, 0.3), gain(15.2, 15.9), coin(0, 1);
  std::uniform_int_distribution<int> pos(1, size - 3), dir(0, 2), other(1, labels - 1);
  EnergyModel em;
  em.resize(size, size, labels);
  for (int k = 0; k < labels; ++k) em.active[k] = static_cast<LabelId>(k + 1);
  for (std::size_t i = 0; i < em.cells(); ++i) {
    for (int k = 0; k < labels; ++k)
      em.unary[i * labels + k] = k == 0 ? 0.f : static_cast<float>(1 + noise(rng));
    em.initial[i] = 0;
    em.fixed[i] = coin(rng) < 0.03;
  }
  for (int p = 0; p < pairs; ++p) {
    const int r = pos(rng), c = pos(rng), d = dir(rng);
    const int a = r * size + c, b = a + (d == 0 ? 1 : d == 1 ? size : size + 1);
    const int la = other(rng);
    int lb = other(rng);
    if (lb == la) lb = la % (labels - 1) + 1;
    em.fixed[a] = em.fixed[b] = 0;
    em.unary[std::size_t(a) * labels + la] = static_cast<float>(-gain(rng));
    em.unary[std::size_t(b) * labels + lb] = static_cast<float>(-gain(rng));
  }
  em.beta = em.beta_diagonal = 1.f;
  return em;
}

// At convergence no 2×2 block can do better given its neighbours (checked by enumerating every
// labelling of each block's non-fixed cells), and the result is no worse than the expansions'
// alone, which the block moves beat on grids with planted pairs.
TEST(AlphaExpansion, ResultIsALocalMinimumOfEveryBlockMove) {
  OptimiserHarness h;
  int lower = 0;
  for (int n = 0; n < 20; ++n) {
    const EnergyModel em = plantedPairs(700 + n, 10, 3 + n % 2, 4);
    const auto r = h.run("alpha_expansion", "{max_cycles: 100, strip_moves: false}", em);
    const auto plain =
        h.run("alpha_expansion", "{max_cycles: 100, block_moves: false, strip_moves: false}", em);
    test::expectValidResult(r, em, "grid " + std::to_string(n));
    ASSERT_TRUE(r.report.converged);
    EXPECT_LE(r.report.final_energy, plain.report.final_energy + 1e-9) << "grid " << n;
    lower += r.report.final_energy < plain.report.final_energy - 1e-6;
    std::vector<uint8_t> lab = OptimiserHarness::labelling(r, em);
    const double e = em.energy(lab);
    EXPECT_NEAR(e, r.report.final_energy, 1e-6);
    const int K = em.numLabels(), C = em.cols;
    for (int r0 = 0; r0 + 1 < em.rows; ++r0)
      for (int c0 = 0; c0 + 1 < C; ++c0) {
        const std::vector<int> movable = freeBlockCells(em, r0, c0);
        int codes = 1;
        for (std::size_t j = 0; j < movable.size(); ++j) codes *= K;
        std::vector<uint8_t> probe = lab;
        for (int code = 0; code < codes; ++code) {
          setCode(probe, movable, code, K);
          ASSERT_GE(em.energy(probe), e - 1e-6) << "grid " << n << " block " << r0 << "," << c0;
        }
      }
  }
  EXPECT_GE(lower, 5) << "the block moves found too little on grids planted for them";
}

// A 2 × 3 patch of a 7 × 7 grid of label 0 (w = 1): its top row prefers label 1 and its bottom
// row label 2 by 11.2 each. The whole patch gains 67.2 and pays 66 (26 boundary pairs and 7
// pairs between its rows, 2 each); its 2 × 2 blocks gain 44.8 and pay 48, a row alone gains
// 33.6 and pays 40. No expansion and no 2 × 2 block move pays, so only a strip move reaches it
// (the pattern of the SemanticKITTI scans on which annealed Gibbs ended lower, 3 × 2 and 4 × 2
// patches that two labels enter: docs/optimisers.md).
TEST(AlphaExpansion, StripMovesLetTwoLabelsEnterA2x3Patch) {
  for (const bool transposed : {false, true}) {
    EnergyModel em;
    const int C = 7;
    em.resize(C, C, 3);
    for (int k = 0; k < 3; ++k) em.active[k] = static_cast<LabelId>(k + 1);
    for (std::size_t i = 0; i < em.cells(); ++i) {
      em.unary[i * 3] = 0.f;
      em.unary[i * 3 + 1] = em.unary[i * 3 + 2] = 10.f;
      em.initial[i] = 0;
    }
    em.beta = em.beta_diagonal = 1.f;
    std::vector<uint8_t> want = em.initial;
    for (int row = 0; row < 2; ++row)
      for (int col = 2; col < 5; ++col) {
        const int i = transposed ? col * C + (2 + row) : (2 + row) * C + col;
        const int l = row == 0 ? 1 : 2;
        em.unary[std::size_t(i) * 3 + l] = -11.2f;
        want[i] = static_cast<uint8_t>(l);
      }
    const std::string what = transposed ? "3 × 2 patch" : "2 × 3 patch";
    const auto r = expectOnlyBlockMovesReach(em, want, 1.2, what, "{strip_moves: false}", "{}");
    EXPECT_EQ(r.metrics.at("alpha_expansion.strip_moves"), 1.0) << what;
    EXPECT_EQ(r.metrics.at("alpha_expansion.block_moves"), 0.0) << what;
  }
}

/// A 6 × 6 grid whose cells outside two rows (or, for odd n, two columns) have no points: label 0
/// everywhere at first and cheapest outside a run of 3–4 positions along the strip, in which one
/// side prefers label 1 and the other label 2 (of K ≥ 3), by about what entering costs (weights
/// 0.7–1.3, diagonals weaker or stronger); for n % 4 == 3 a cell without points inside the strip
/// too. The free cells go to `free_cells`.
EnergyModel twoCellWideModel(std::mt19937& rng, int n, int K, std::vector<int>& free_cells) {
  std::normal_distribution<double> noise(0, 0.5);
  std::uniform_real_distribution<double> weight(0.7, 1.3), gain(4.6, 5.9);
  EnergyModel em;
  em.resize(6, 6, K);
  const bool tall = n % 2;  // free: columns 2–3, else rows 2–3
  free_cells.clear();
  const double w = weight(rng);
  const int run0 = static_cast<int>(rng() % 3), run1 = run0 + 2 + static_cast<int>(rng() % 2);
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) {
      const int i = r * 6 + c, side = (tall ? c : r) - 2, along = tall ? r : c;
      em.unary[i * K] = 0.f;
      for (int k = 1; k < K; ++k)
        em.unary[i * K + k] = static_cast<float>(w * (4 + std::abs(noise(rng))));
      if (along >= run0 && along <= run1 && (side == 0 || side == 1))
        em.unary[i * K + 1 + side] = static_cast<float>(-w * gain(rng));
      em.initial[i] = 0;
      em.fixed[i] = side < 0 || side > 1;
      if (!em.fixed[i]) free_cells.push_back(i);
    }
  for (int k = 0; k < K; ++k) em.active[k] = static_cast<LabelId>(k + 1);
  if (n % 4 == 3) {
    const int i = free_cells[rng() % free_cells.size()];
    em.fixed[i] = 1;
    free_cells.erase(std::find(free_cells.begin(), free_cells.end(), i));
  }
  em.beta = static_cast<float>(w);
  em.beta_diagonal = static_cast<float>(w * weight(rng));
  return em;
}

// A grid two cells wide is one strip, so at convergence (no expansion, 2 × 2 block or strip move
// improves) α-expansion has its global optimum: the strip's search is exact, the labels it leaves
// out are dominated and the stretches it skips could only take expansion moves. Checked against
// all 3^12 labellings of 16 such grids (twoCellWideModel, 3 labels).
TEST(AlphaExpansion, TwoCellWideGridsReachTheirGlobalOptimum) {
  OptimiserHarness h;
  std::mt19937 rng(4242);
  int beaten_without_strips = 0;
  std::vector<int> free_cells;
  for (int n = 0; n < 16; ++n) {
    const EnergyModel em = twoCellWideModel(rng, n, 3, free_cells);
    double optimum = INFINITY;
    std::vector<uint8_t> lab = em.initial;
    long codes = 1;
    for (std::size_t j = 0; j < free_cells.size(); ++j) codes *= 3;
    for (long code = 0; code < codes; ++code) {
      long c = code;
      for (const int i : free_cells) {
        lab[i] = static_cast<uint8_t>(c % 3);
        c /= 3;
      }
      optimum = std::min(optimum, em.energy(lab));
    }
    const std::string what = "grid " + std::to_string(n);
    const auto r = h.run("alpha_expansion", "{max_cycles: 100}", em);
    test::expectValidResult(r, em, what);
    ASSERT_TRUE(r.report.converged) << what;
    EXPECT_NEAR(r.report.final_energy, optimum, 1e-5) << what;
    const auto plain = h.run("alpha_expansion", "{max_cycles: 100, strip_moves: false}", em);
    beaten_without_strips += plain.report.final_energy > optimum + 1e-6;
  }
  // The grids must be hard enough that expansions and 2 × 2 blocks alone miss some optima.
  EXPECT_GE(beaten_without_strips, 2) << "too easy: every optimum was found without strips";
}

// The strips' recursion runs four states per instruction where the CPU has AVX and two (SSE2)
// otherwise: the same sums and minima, so the same labelling and energy to the bit, for state
// counts that fill the registers (K = 2, 4) and that leave padding (K = 3).
TEST(AlphaExpansion, StripMovesAreTheSameWithEveryVectorWidth) {
  OptimiserHarness h;
  std::mt19937 rng(777);
  std::vector<int> free_cells;
  long moves = 0;
  for (int n = 0; n < 24; ++n) {
    const int K = 2 + n % 3;
    EnergyModel em = twoCellWideModel(rng, n / 3, std::max(K, 3), free_cells);
    if (K == 2) {  // two labels: keep the first two (a strip move then swaps them)
      EnergyModel two;
      two.resize(em.rows, em.cols, 2);
      for (int k = 0; k < 2; ++k) two.active[k] = em.active[k];
      for (std::size_t i = 0; i < em.cells(); ++i)
        for (int k = 0; k < 2; ++k) two.unary[i * 2 + k] = em.unary[i * 3 + k];
      two.fixed = em.fixed;
      two.initial = em.initial;
      two.beta = em.beta;
      two.beta_diagonal = em.beta_diagonal;
      em = two;
    }
    const std::string what = "grid " + std::to_string(n) + ", K = " + std::to_string(K);
    const auto wide = h.run("alpha_expansion", "{}", em);
    test::ScopedEnv sse2("TERRAMRF_SIMD", "sse2");
    const auto narrow = h.run("alpha_expansion", "{}", em);
    EXPECT_EQ(wide.indices, narrow.indices) << what;
    EXPECT_EQ(wide.report.final_energy, narrow.report.final_energy) << what;
    EXPECT_EQ(wide.metrics.at("alpha_expansion.strip_positions"),
              narrow.metrics.at("alpha_expansion.strip_positions"))
        << what;
    if (K > 2) moves += static_cast<long>(wide.metrics.at("alpha_expansion.strip_moves"));
  }
  EXPECT_GE(moves, 4) << "the grids must make the strips move";
}

TEST(AlphaExpansion, TwoLabelsFromAConstantStartGiveTheGlobalOptimum) {
  // With two labels and every cell at label 0, the expansion of label 1 can reach every
  // labelling, so one exact cut must find the global minimum (brute force over 2^16).
  OptimiserHarness h;
  for (int n = 0; n < 10; ++n) {
    RandomModelSpec s;
    s.size = 4;
    s.labels = 2;
    s.fixed_fraction = n % 2 ? 0.2 : 0.0;
    s.beta_lo = 0.2;
    s.beta_hi = 1.0;
    EnergyModel em = test::randomModel(80 + n, s);
    std::fill(em.initial.begin(), em.initial.end(), 0);
    const auto [e_star, best] = test::bruteForce(em);
    const auto r = h.run("alpha_expansion", "{pre_icm: false}", em);
    EXPECT_NEAR(r.report.final_energy, e_star, 1e-6) << "grid " << n;
  }
}

TEST(AlphaExpansion, ScoreIsTheLocalEnergyMarginLikeIcms) {
  // The spec's score for deterministic optimisers: s_k = min_{j≠k} E_c(j) − E_c(k) with the
  // final neighbours, the same numbers the ROC fallback gives ICM (localEnergyScores).
  RandomModelSpec s;
  s.size = 6;
  const EnergyModel em = test::randomModel(24, s);
  OptimiserHarness h;
  const auto r = h.run("alpha_expansion", "{}", em);
  const auto lab = OptimiserHarness::labelling(r, em);
  const auto fallback = localEnergyScores(em, r.grid_labels, h.labels().size());
  int positive = 0;
  for (int i = 0; i < static_cast<int>(em.cells()); ++i) {
    for (int k = 0; k < 3; ++k) {
      const float v = r.scores.at(kClasses[k])[i];
      const float f = fallback.at(em.active[k])[i];
      if (em.fixed[i]) {
        EXPECT_TRUE(std::isnan(v) && std::isnan(f)) << "cell " << i;
        continue;
      }
      double other = std::numeric_limits<double>::infinity();
      for (int j = 0; j < 3; ++j)
        if (j != k) other = std::min(other, em.localEnergy(lab, i, j));
      EXPECT_NEAR(v, other - em.localEnergy(lab, i, k), 1e-5) << "cell " << i << " label " << k;
      EXPECT_EQ(v, f) << "cell " << i << " label " << k;
      positive += v > 0;
    }
  }
  EXPECT_GT(positive, 0);
}

TEST(AlphaExpansion, FixedCellsTakeNoPartInTheEnergy) {
  RandomModelSpec s;
  s.size = 14;
  s.fixed_fraction = 0.3;
  const EnergyModel a = test::randomModel(25, s);
  EnergyModel b = a;
  for (std::size_t i = 0; i < b.cells(); ++i)
    if (b.fixed[i]) {
      b.initial[i] = static_cast<uint8_t>((b.initial[i] + 1) % 3);
      for (int k = 0; k < 3; ++k) b.unary[i * 3 + k] = -100.f * k;
    }
  OptimiserHarness h;
  const auto ra = h.run("alpha_expansion", "{}", a), rb = h.run("alpha_expansion", "{}", b);
  EXPECT_EQ(ra.grid_labels, rb.grid_labels);
  EXPECT_DOUBLE_EQ(ra.report.final_energy, rb.report.final_energy);
  // A frame with every cell fixed (no points anywhere): nothing to cut, every cell unknown, and
  // the instance still serves the next frame.
  EnergyModel all = a;
  std::fill(all.fixed.begin(), all.fixed.end(), 1);
  auto stage = h.make("alpha_expansion", "{}", a);
  ASSERT_TRUE(stage);
  EXPECT_EQ(h.run(*stage, a).grid_labels, ra.grid_labels);
  const auto rn = h.run(*stage, all);
  for (LabelId l : rn.grid_labels) EXPECT_EQ(l, labels::kUnknown);
  EXPECT_EQ(h.run(*stage, a).grid_labels, ra.grid_labels);
}

TEST(AlphaExpansion, InitChoicesAndReuseOfOneInstanceAcrossFrames) {
  RandomModelSpec s;
  s.size = 16;
  s.labels = 4;
  s.fixed_fraction = 0.15;
  OptimiserHarness h;
  const EnergyModel em1 = test::randomModel(26, s);
  s.fixed_fraction = 0.4;  // other fixed cells: the graph is rebuilt for this frame
  const EnergyModel em2 = test::randomModel(27, s);
  auto stage = h.make("alpha_expansion", "{init: unary_argmin}", em1);
  const auto r1 = h.run(*stage, em1);
  const auto r2 = h.run(*stage, em2);
  const auto r1_again = h.run("alpha_expansion", "{init: unary_argmin}", em1);
  test::expectValidResult(r1, em1, "frame 1");
  test::expectValidResult(r2, em2, "frame 2");
  EXPECT_EQ(r1.grid_labels, r1_again.grid_labels);
  const auto from_initial = h.run("alpha_expansion", "{init: initial}", em1);
  test::expectValidResult(from_initial, em1, "init initial");
  EXPECT_THROW(h.make("alpha_expansion", "{init: random}", em1), std::exception);
}

// With init: unary_argmin the run can end above a good given initial labelling; the optimiser
// then returns that labelling, and its report must not describe the discarded run as a converged
// local minimum of the moves (the premise of the factor-2 bound).
TEST(AlphaExpansion, AUnaryAtEq11sCapLeavesEveryCutAsItWas) {
  // Eq. 11's energy is capped at 1e20 so unaries stay finite. One such unary used to set the
  // integer capacity scale by itself and round every Potts capacity to 0, so the cuts ignored the
  // neighbours. Any unary far beyond what a cell's pairs can outweigh decides the same cuts: the
  // run with 1e20 must be the run with 1e3 (both far above 16·β here) in every label.
  for (uint32_t seed = 0; seed < 6; ++seed) {
    RandomModelSpec s;
    s.size = 14;
    s.labels = 4;
    s.beta_lo = 0.3;
    s.beta_hi = 1.0;
    EnergyModel tall = test::randomModel(90 + seed, s);
    EnergyModel capped = tall;
    std::mt19937 rng(seed);
    int set = 0;
    for (std::size_t i = 0; i < tall.cells() && set < 5; i += 1 + rng() % 40) {
      if (tall.fixed[i]) continue;
      const int k = static_cast<int>(rng() % 4);
      tall.unary[i * 4 + k] = 1e3f;
      capped.unary[i * 4 + k] = 1e20f;
      ++set;
    }
    ASSERT_GT(set, 0);
    OptimiserHarness h;
    for (const char* params :
         {"{}", "{pre_icm: false, block_moves: false, strip_moves: false, max_cycles: 50}"}) {
      const auto want = h.run("alpha_expansion", params, tall);
      const auto got = h.run("alpha_expansion", params, capped);
      test::expectValidResult(got, capped, params);
      EXPECT_EQ(OptimiserHarness::labelling(got, capped), OptimiserHarness::labelling(want, tall))
          << params << " seed " << seed;
      EXPECT_NEAR(got.report.final_energy, want.report.final_energy, 1e-6)
          << params << " seed " << seed;
      EXPECT_LT(got.report.final_energy, 1e3) << params << " seed " << seed;
    }
  }
}

TEST(AlphaExpansion, FallbackToTheInitialLabellingIsReported) {
  // Textbook expansions from the argmin against a given labelling that the full optimiser (blocks
  // and strips) found: on strongly coupled grids the textbook run often ends higher.
  test::RandomModelSpec s;
  s.size = 6;
  s.labels = 4;
  s.fixed_fraction = 0.0;
  s.beta_lo = 0.05;
  s.beta_hi = 0.6;
  OptimiserHarness h;
  int found = 0;
  for (uint32_t seed = 1; seed < 400 && found < 3; ++seed) {
    EnergyModel em = test::randomModel(seed, s);
    const auto full = h.run("alpha_expansion", "{}", em);
    em.initial = OptimiserHarness::labelling(full, em);
    const auto r =
        h.run("alpha_expansion",
              "{init: unary_argmin, pre_icm: false, block_moves: false, strip_moves: false}", em);
    test::expectValidResult(r, em, "seed " + std::to_string(seed));
    if (r.metrics.at("alpha_expansion.returned_initial") != 1) continue;
    ++found;
    EXPECT_FALSE(r.report.converged) << "seed " << seed;
    EXPECT_EQ(r.report.final_energy, em.energy(em.initial)) << "seed " << seed;
    EXPECT_EQ(OptimiserHarness::labelling(r, em), em.initial) << "seed " << seed;
  }
  EXPECT_EQ(found, 3)
      << "no grid where the argmin start ends above the given labelling: the test needs one";
}

}  // namespace
}  // namespace terramrf
