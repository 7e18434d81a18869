// Properties shared by all optimisers (icm, gibbs, alpha_expansion) on random grids with fixed
// seeds, and the known bounds of α-expansion and simulated annealing on brute-forced 3×3 grids.
#include <gtest/gtest.h>

#include "optimiser_test_support.hpp"

namespace terramrf {
namespace {

using test::OptimiserHarness;
using test::RandomModelSpec;

constexpr int kRandomGrids = 20;

RandomModelSpec specFor(int n) {
  RandomModelSpec s;
  s.size = 8 + n % 9;    // 8..16 cells a side
  s.labels = 2 + n % 3;  // 2..4 labels
  s.fixed_fraction = (n % 4) * 0.1;
  return s;
}

TEST(OptimiserProperties, NoOptimiserEndsAboveItsInitialLabelling) {
  OptimiserHarness h;
  const std::vector<std::pair<std::string, std::string>> runs = {
      {"icm", "{}"},
      {"gibbs", "{sweeps: 30, burn_in: 10, seed: 3}"},
      // Hot constant temperature: the chain wanders far above the start, so only keeping the
      // best labelling seen keeps the promise.
      {"gibbs", "{schedule: constant, temperature: 50.0, sweeps: 20, burn_in: 5, seed: 4}"},
      {"alpha_expansion", "{}"},
      {"alpha_expansion", "{init: unary_argmin}"},
  };
  for (int n = 0; n < kRandomGrids; ++n) {
    const EnergyModel em = test::randomModel(1000 + n, specFor(n));
    for (const auto& [type, params] : runs) {
      const auto r = h.run(type, params, em);
      test::expectValidResult(r, em, type + " " + params + " grid " + std::to_string(n));
    }
  }
}

TEST(OptimiserProperties, AGoodInitialLabellingIsNeverMadeWorse) {
  // Start from the brute-force optimum: every optimiser must return an energy equal to it.
  OptimiserHarness h;
  for (int n = 0; n < 5; ++n) {
    RandomModelSpec s;
    s.size = 3;
    s.labels = 3;
    s.fixed_fraction = 0;
    EnergyModel em = test::randomModel(2000 + n, s);
    const auto [e_star, best] = test::bruteForce(em);
    em.initial = best;
    for (const auto& [type, params] : std::vector<std::pair<std::string, std::string>>{
             {"icm", "{}"},
             {"gibbs", "{schedule: constant, temperature: 5.0, sweeps: 50, burn_in: 0}"},
             {"alpha_expansion", "{init: unary_argmin}"}}) {
      const auto r = h.run(type, params, em);
      test::expectValidResult(r, em, type);
      EXPECT_NEAR(r.report.final_energy, e_star, 1e-9) << type << " grid " << n;
    }
  }
}

TEST(OptimiserProperties, AlphaExpansionIsNoWorseThanIcmFromTheSameStart) {
  // With pre_icm (the default) α-expansion starts from ICM's result and only goes down, so this
  // holds by construction; without it, it is an empirical property of these grids: changing one
  // cell is an expansion move, so α-expansion ends where ICM would not move either, but it does
  // not pass through ICM's local minimum.
  OptimiserHarness h;
  int strictly_better = 0;
  for (int n = 0; n < kRandomGrids; ++n) {
    const EnergyModel em = test::randomModel(3000 + n, specFor(n));
    const auto icm = h.run("icm", "{}", em);
    const auto ae = h.run("alpha_expansion", "{init: initial}", em);
    const auto ae_plain = h.run("alpha_expansion", "{init: initial, pre_icm: false}", em);
    EXPECT_LE(ae.report.final_energy, icm.report.final_energy + 1e-9) << "grid " << n;
    EXPECT_LE(ae_plain.report.final_energy, icm.report.final_energy + 1e-9) << "grid " << n;
    strictly_better += ae_plain.report.final_energy < icm.report.final_energy - 1e-6;
  }
  // Guards against the comparison passing because both return the same thing.
  EXPECT_GE(strictly_better, kRandomGrids / 2);
}

// The bound of Boykov, Veksler & Zabih (2001, Thm. 6.1) in the shifted metric form
// E'(ω) = Σ unary + Σ_pairs 2w·[ω_c ≠ ω_d] = E(ω) + Σ_pairs w: for a labelling α̂ that no
// expansion move improves and any labelling ω*,
//     E'(α̂) ≤ E_data(ω*) + 2·E'_smooth(ω*)        (c = 1 for Potts)
// which, when all unaries are ≥ 0, gives the familiar E'(α̂) ≤ 2·E'(ω*). Both are checked
// against the brute-force optimum ω* of 3×3 grids with 3 labels (3^9 labellings).
//
// The bound is loose, and on such small grids even a wrong graph (cuts that are not the best
// expansion move) mostly ends at the same labelling, only later: dropping the t-link of one pair
// case changed none of 1500 converged runs from random labellings, but 15 of the 1500 one-cycle
// runs below. So the premise
// is checked too: by enumeration, no expansion move improves α̂; the whole run retraces an
// α-expansion whose every move is the enumerated best one from the same start; and from 50
// random labellings per grid, one cycle (K moves) ends where the enumerating reference's does.
TEST(OptimiserProperties, AlphaExpansionIsWithinItsFactorTwoBoundOfTheOptimum) {
  OptimiserHarness h;
  int exact = 0;
  constexpr int kGrids = 30;
  for (int n = 0; n < kGrids; ++n) {
    RandomModelSpec s;
    s.size = 3;
    s.labels = 3;
    s.fixed_fraction = 0;
    const bool nonneg = n % 2 == 0;
    if (nonneg) s.unary_lo = 0.0;
    s.beta_lo = 0.3;
    s.beta_hi = 1.5;
    const EnergyModel em = test::randomModel(4000 + n, s);
    const auto [e_star, best] = test::bruteForce(em);
    const bool pre_icm = n % 3 == 0;
    const auto r = h.run("alpha_expansion",
                         pre_icm ? "{max_cycles: 100, block_moves: false}"
                                 : "{max_cycles: 100, pre_icm: false, block_moves: false}",
                         em);
    test::expectValidResult(r, em, "grid " + std::to_string(n));
    ASSERT_TRUE(r.report.converged) << "the bound holds for a converged labelling";
    const auto lab = OptimiserHarness::labelling(r, em);
    for (int alpha = 0; alpha < s.labels; ++alpha)
      EXPECT_GE(test::bestExpansionEnergy(em, lab, alpha), r.report.final_energy - 1e-6)
          << "an expansion move improves the result: grid " << n << " alpha " << alpha;
    EnergyModel start = em;  // the labelling the expansions start from
    if (pre_icm) start.initial = OptimiserHarness::labelling(h.run("icm", "{}", em), em);
    int ref_cycles = 0;
    EXPECT_EQ(lab, test::referenceExpansion(start, &ref_cycles)) << "grid " << n;
    EXPECT_EQ(r.report.iterations, ref_cycles) << "grid " << n;
    std::mt19937 rng(n);
    std::uniform_int_distribution<int> label(0, s.labels - 1);
    for (int probe = 0; probe < 50; ++probe) {
      for (auto& l : start.initial) l = static_cast<uint8_t>(label(rng));
      const auto one = h.run("alpha_expansion", "{max_cycles: 1, pre_icm: false, block_moves: false}", start);
      int cycles = 0;
      EXPECT_EQ(OptimiserHarness::labelling(one, start),
                test::referenceExpansion(start, &cycles, nullptr, 1))
          << "one cycle from random labelling " << probe << " of grid " << n;
    }

    const double shift = test::pairWeightSum(em);
    const double e_alpha = r.report.final_energy + shift;  // E'(α̂)
    const double e_opt = e_star + shift;                   // E'(ω*)
    const double data_opt = test::dataEnergy(em, best);
    const double smooth_opt = e_opt - data_opt;  // E'_smooth(ω*) ≥ 0
    EXPECT_GE(smooth_opt, -1e-9);
    EXPECT_LE(e_alpha, data_opt + 2 * smooth_opt + 1e-6) << "grid " << n;
    if (nonneg) {
      EXPECT_LE(e_alpha, 2 * e_opt + 1e-6) << "grid " << n;
    }
    EXPECT_GE(r.report.final_energy, e_star - 1e-9) << "below the brute-force minimum?";
    exact += std::abs(r.report.final_energy - e_star) < 1e-6;
  }
  // In practice α-expansion is (near) exact on such small grids; report how often.
  RecordProperty("alpha_expansion_exact", exact);
  EXPECT_GE(exact, kGrids * 2 / 3);
}

// Annealing, not luck. The returned labelling is the best one seen, and 3000 sweeps of a chain
// that never cools visit the optimum of 3^9 labellings too (at a constant T0 = 3 in 88 % of such
// runs). So the test also looks at where the chain is when the annealing ends
// (`gibbs.annealed_energy`), which for a chain at T0 = 3 is the optimum in ~1 % of runs. Slow
// annealing ends there in most runs but not all: on these coupled grids the chain settles on a
// basin at a temperature comparable to the gap to the runner-up minimum (0.5–2.7 energy units),
// so about 30 % freeze in that local minimum, with 3000 sweeps as with 30 000.
TEST(OptimiserProperties, SlowlyAnnealedGibbsFindsTheExactOptimum) {
  OptimiserHarness h;
  int annealed_at_optimum = 0, runs = 0;
  for (int n = 0; n < 10; ++n) {
    RandomModelSpec s;
    s.size = 3;
    s.labels = 3;
    s.fixed_fraction = 0;
    const EnergyModel em = test::randomModel(5000 + n, s);
    const auto [e_star, best] = test::bruteForce(em);
    int hits = 0;
    for (int seed = 1; seed <= 10; ++seed) {
      const auto r = h.run("gibbs",
                           "{schedule: geometric, temperature: 3.0, final_temperature: 0.01, "
                           "sweeps: 3000, seed: " +
                               std::to_string(seed) + "}",
                           em);
      const std::string what = "grid " + std::to_string(n) + " seed " + std::to_string(seed);
      test::expectValidResult(r, em, what);
      EXPECT_NEAR(r.report.final_energy, e_star, 1e-6) << what;
      ASSERT_EQ(r.metrics.count("gibbs.annealed_energy"), 1u);
      const double e_annealed = r.metrics.at("gibbs.annealed_energy");
      EXPECT_GE(e_annealed, r.report.final_energy - 1e-9) << what;
      hits += std::abs(e_annealed - e_star) < 1e-6;
      ++runs;
    }
    EXPECT_GE(hits, 1) << "the annealing never ended at the optimum of grid " << n;
    annealed_at_optimum += hits;
  }
  RecordProperty("annealed_at_optimum", annealed_at_optimum);
  EXPECT_GE(annealed_at_optimum, runs * 6 / 10);
}

}  // namespace
}  // namespace terramrf
