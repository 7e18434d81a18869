// The "gibbs" optimiser: known marginals (independent cells, brute-forced 3×3 fields at the
// marginal temperature after annealing, and at a constant temperature), marginals summing to 1,
// the marginal sweeps leaving the result alone, fixed cells, determinism, parameter checks, the
// accuracy of its e^−x, and the vector sweep against the one-cell one.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>

#include "neg_exp.hpp"
#include "optimiser_test_support.hpp"

namespace terramrf {
namespace {

using test::OptimiserHarness;
using test::RandomModelSpec;

const char* kClasses[] = {"road", "rough", "obstacle", "vegetation"};

TEST(Gibbs, MarginalsOfIndependentCellsAreTheSoftmaxOfTheUnaries) {
  // β = 0: every cell is independent and its conditional is its exact marginal, so the
  // (Rao-Blackwellised) estimate must match exp(−u_k/T)/Σ exp(−u_j/T) at the marginal
  // temperature T to table accuracy, whatever the annealing did before.
  RandomModelSpec s;
  s.size = 6;
  s.labels = 4;
  s.fixed_fraction = 0;
  s.unary_lo = -2;
  s.unary_hi = 2;
  EnergyModel em = test::randomModel(7, s);
  em.beta = em.beta_diagonal = 0.f;
  OptimiserHarness h;
  const double T = 0.7;
  const auto r =
      h.run("gibbs",
            "{sweeps: 3, marginal_temperature: 0.7, marginal_sweeps: 2, marginal_burn_in: 0}", em);
  for (std::size_t i = 0; i < em.cells(); ++i) {
    double z = 0;
    for (int k = 0; k < 4; ++k) z += std::exp(-em.unary[i * 4 + k] / T);
    for (int k = 0; k < 4; ++k)
      EXPECT_NEAR(r.scores.at(kClasses[k])[i], std::exp(-em.unary[i * 4 + k] / T) / z, 1e-4)
          << "cell " << i << " label " << k;
  }
}

TEST(Gibbs, MarginalsAtTheMarginalTemperatureMatchBruteForceAfterAnnealing) {
  // 3×3 grids, 3 labels, coupled cells: the default annealing (1.0 → 0.05), then the marginal
  // chain at T_m. Exact marginals of exp(−E/T_m) by enumerating 3^9 labellings. T_m ≠ 1 and
  // ≠ T0, so using the wrong temperature (or 1/T) shows. The coupling is weak enough for the chain
  // to move between minima at T_m = 0.7; with β ≈ 0.5 it would stay in the annealed one.
  OptimiserHarness h;
  for (int n = 0; n < 2; ++n) {
    RandomModelSpec s;
    s.size = 3;
    s.labels = 3;
    s.fixed_fraction = 0;
    s.beta_lo = 0.1;
    s.beta_hi = 0.3;
    const EnergyModel em = test::randomModel(40 + n, s);
    const double T = n == 0 ? 0.7 : 2.0;
    const auto exact = test::bruteForceMarginals(em, T);
    const auto r = h.run("gibbs",
                         "{marginal_temperature: " + std::to_string(T) +
                             ", marginal_sweeps: 30000, marginal_burn_in: 100, seed: 5}",
                         em);
    for (int i = 0; i < 9; ++i)
      for (int k = 0; k < 3; ++k)
        EXPECT_NEAR(r.scores.at(kClasses[k])[i], exact[i * 3 + k], 0.01)
            << "T " << T << " cell " << i << " label " << k;
    EXPECT_EQ(r.metrics.at("gibbs.marginal_sweeps"), 30100);
    // What the scores were before: the conditionals averaged over the annealing sweeps after
    // burn-in, at temperatures from 0.55 down to 0.05. They are not these marginals (off by 0.36
    // to 0.77 here).
    const auto old = h.run("gibbs", "{marginal_sweeps: 0, seed: 5}", em);
    double worst = 0;
    for (int i = 0; i < 9; ++i)
      for (int k = 0; k < 3; ++k)
        worst = std::max(worst, std::abs(old.scores.at(kClasses[k])[i] - exact[i * 3 + k]));
    EXPECT_GT(worst, 0.2) << "T " << T;
  }
}

TEST(Gibbs, MarginalSweepsChangeNeitherTheLabellingNorTheReport) {
  // The returned labelling is the annealing's (the MAP estimate); the marginal chain runs after
  // it on its own copy and its energies are not the result.
  RandomModelSpec s;
  s.size = 16;
  s.labels = 4;
  s.fixed_fraction = 0.1;
  const EnergyModel em = test::randomModel(13, s);
  OptimiserHarness h;
  const auto a = h.run("gibbs", "{sweeps: 30, marginal_sweeps: 0, seed: 8}", em);
  const auto b = h.run("gibbs", "{sweeps: 30, seed: 8}", em);
  const auto c =
      h.run("gibbs", "{sweeps: 30, marginal_sweeps: 50, marginal_temperature: 5.0, seed: 8}", em);
  for (const auto* r : {&b, &c}) {
    EXPECT_EQ(r->grid_labels, a.grid_labels);
    EXPECT_EQ(r->report.final_energy, a.report.final_energy);
    EXPECT_EQ(r->report.initial_energy, a.report.initial_energy);
    EXPECT_EQ(r->report.iterations, 30);
    EXPECT_EQ(r->report.converged, a.report.converged);
    for (const char* m : {"gibbs.best_sweep", "gibbs.annealed_energy", "gibbs.energy"})
      EXPECT_EQ(r->metrics.at(m), a.metrics.at(m)) << m;
  }
  EXPECT_NE(b.scores.at("road"), a.scores.at("road"));
  EXPECT_NE(c.scores.at("road"), b.scores.at("road"));
  EXPECT_EQ(a.metrics.at("gibbs.marginal_sweeps"), 0);
  EXPECT_EQ(b.metrics.at("gibbs.marginal_sweeps"), 25);  // 5 burn-in + 20 averaged
}

TEST(Gibbs, MarginalsMatchBruteForceAtConstantTemperature) {
  // 3×3 grid, 2 labels, coupled cells: exact marginals at T = 1 by enumerating 2^9 labellings.
  // marginal_sweeps: 0 averages the (constant-temperature) chain itself after burn-in.
  RandomModelSpec s;
  s.size = 3;
  s.labels = 2;
  s.fixed_fraction = 0;
  s.unary_lo = -0.5;
  s.unary_hi = 0.5;
  s.beta_lo = 0.2;
  s.beta_hi = 0.5;
  const EnergyModel em = test::randomModel(8, s);
  std::vector<double> exact(em.cells() * 2, 0.0);
  double z = 0;
  std::vector<uint8_t> lab(em.cells());
  for (int code = 0; code < 512; ++code) {
    for (int i = 0; i < 9; ++i) lab[i] = (code >> i) & 1;
    const double p = std::exp(-em.energy(lab));
    z += p;
    for (int i = 0; i < 9; ++i) exact[i * 2 + lab[i]] += p;
  }
  OptimiserHarness h;
  const auto r = h.run(
      "gibbs",
      "{schedule: constant, temperature: 1.0, sweeps: 40000, burn_in: 100, marginal_sweeps: 0, "
      "seed: 5}",
      em);
  for (int i = 0; i < 9; ++i)
    for (int k = 0; k < 2; ++k)
      EXPECT_NEAR(r.scores.at(kClasses[k])[i], exact[i * 2 + k] / z, 0.01)
          << "cell " << i << " label " << k;
}

TEST(Gibbs, MarginalsSumToOneAndFixedCellsAreUnknownWithNaNScores) {
  RandomModelSpec s;
  s.size = 20;
  s.labels = 4;
  s.fixed_fraction = 0.25;
  const EnergyModel em = test::randomModel(9, s);
  OptimiserHarness h;
  const auto r = h.run("gibbs", "{sweeps: 40, burn_in: 10, seed: 2}", em);
  test::expectValidResult(r, em, "gibbs");
  ASSERT_EQ(r.scores.size(), 4u);
  int fixed = 0;
  for (std::size_t i = 0; i < em.cells(); ++i) {
    double sum = 0;
    for (int k = 0; k < 4; ++k) {
      const float v = r.scores.at(kClasses[k])[i];
      if (em.fixed[i]) {
        EXPECT_TRUE(std::isnan(v)) << "cell " << i;
      } else {
        EXPECT_GE(v, 0.f);
        EXPECT_LE(v, 1.f + 1e-6f);
        sum += v;
      }
    }
    if (em.fixed[i]) {
      ++fixed;
      EXPECT_EQ(r.grid_labels[i], labels::kUnknown);
    } else {
      EXPECT_NEAR(sum, 1.0, 1e-4) << "cell " << i;
    }
  }
  EXPECT_GT(fixed, 50);  // the test exercises fixed cells at all
}

TEST(Gibbs, FixedCellsTakeNoPartInTheEnergy) {
  // Whatever a fixed cell's initial label and unary, the result on the other cells is the same.
  RandomModelSpec s;
  s.size = 10;
  s.fixed_fraction = 0.3;
  const EnergyModel a = test::randomModel(10, s);
  EnergyModel b = a;
  for (std::size_t i = 0; i < b.cells(); ++i)
    if (b.fixed[i]) {
      b.initial[i] = static_cast<uint8_t>((b.initial[i] + 1) % 3);
      for (int k = 0; k < 3; ++k) b.unary[i * 3 + k] = 100.f * k;
    }
  OptimiserHarness h;
  const std::string p = "{sweeps: 30, burn_in: 5, seed: 9}";
  const auto ra = h.run("gibbs", p, a), rb = h.run("gibbs", p, b);
  EXPECT_EQ(ra.grid_labels, rb.grid_labels);
  EXPECT_DOUBLE_EQ(ra.report.final_energy, rb.report.final_energy);
}

TEST(Gibbs, SameSeedSameResultOtherSeedOtherSamples) {
  RandomModelSpec s;
  s.size = 16;
  s.labels = 4;
  s.fixed_fraction = 0;
  const EnergyModel em = test::randomModel(11, s);
  OptimiserHarness h;
  const std::string p = "{schedule: constant, temperature: 1.5, sweeps: 20, burn_in: 5, seed: ";
  const auto r1 = h.run("gibbs", p + "42}", em);
  const auto r2 = h.run("gibbs", p + "42}", em);
  const auto r3 = h.run("gibbs", p + "43}", em);
  EXPECT_EQ(r1.grid_labels, r2.grid_labels);
  EXPECT_EQ(r1.report.final_energy, r2.report.final_energy);
  for (const char* c : kClasses) {
    // Bitwise equal: NaN-free since no cell is fixed here.
    EXPECT_EQ(r1.scores.at(c), r2.scores.at(c)) << c;
    EXPECT_NE(r1.scores.at(c), r3.scores.at(c)) << c;
  }
  // One instance, two frames: the second run does not depend on the first.
  auto stage = h.make("gibbs", p + "42}", em);
  const auto a = h.run(*stage, em);
  const auto b = h.run(*stage, em);
  EXPECT_EQ(a.scores.at("road"), b.scores.at("road"));
  EXPECT_EQ(a.scores.at("road"), r1.scores.at("road"));
}

TEST(Gibbs, EveryScheduleLowersTheEnergyOfANoisyStart) {
  RandomModelSpec s;
  s.size = 24;
  s.labels = 3;
  const EnergyModel em = test::randomModel(12, s);
  OptimiserHarness h;
  for (const char* sched : {"geometric", "logarithmic", "linear"}) {
    const auto r =
        h.run("gibbs",
              std::string("{schedule: ") + sched +
                  ", temperature: 1.0, final_temperature: 0.05, sweeps: 60, burn_in: 10}",
              em);
    test::expectValidResult(r, em, sched);
    // A random start on 24×24 cells is far from any minimum: annealing must gain a lot.
    EXPECT_LT(r.report.final_energy,
              r.report.initial_energy - 0.2 * std::abs(r.report.initial_energy))
        << sched;
    EXPECT_EQ(r.report.iterations, 60);
  }
}

TEST(Gibbs, RejectsInconsistentParameters) {
  OptimiserHarness h;
  const EnergyModel em = test::randomModel(1);
  EXPECT_THROW(h.make("gibbs", "{sweeps: 10, burn_in: 10, marginal_sweeps: 0}", em),
               std::exception);
  EXPECT_NO_THROW(h.make("gibbs", "{sweeps: 10, burn_in: 10}", em));  // burn_in unused then
  EXPECT_THROW(h.make("gibbs", "{marginal_temperature: 0.0}", em), std::exception);
  EXPECT_THROW(h.make("gibbs", "{marginal_sweeps: -1}", em), std::exception);
  EXPECT_THROW(h.make("gibbs", "{temperature: 1.0, final_temperature: 2.0}", em), std::exception);
  EXPECT_THROW(h.make("gibbs", "{schedule: cubic}", em), std::exception);
  EXPECT_THROW(h.make("gibbs", "{temperature: 0.0}", em), std::exception);
  EXPECT_NO_THROW(
      h.make("gibbs", "{schedule: constant, temperature: 1.0, final_temperature: 2.0}", em));
}

TEST(Gibbs, NegExpErrorIsTheDocumentedOne) {
  // Below 1.5e-6 relative on [0, 17), and not below 5e-7 (the polynomial's own error shows, so a
  // wrong coefficient would too); exactly 1 at 0 and exactly 0 from kMax on.
  double worst = 0;
  for (int i = 0; i < 17 * 4096; ++i) {
    const float x = static_cast<float>((i + 0.37) / 4096);
    if (!(x < NegExp::kMax)) break;
    worst = std::max(worst, std::abs(NegExp::eval(x) / std::exp(-double(x)) - 1.0));
  }
  EXPECT_LT(worst, 1.5e-6);
  EXPECT_GT(worst, 5e-7);
  EXPECT_EQ(NegExp::eval(0.f), 1.f);
  EXPECT_EQ(NegExp::eval(17.f), 0.f);
  EXPECT_EQ(NegExp::eval(1e9f), 0.f);
  EXPECT_EQ(NegExp::eval(std::nanf("")), 0.f);
  // Dropped weights are below the 2^−24 resolution of the uniform draw.
  EXPECT_LT(std::exp(-double(NegExp::kMax)), std::ldexp(1.0, -24));
}

TEST(Gibbs, VectorSweepsGiveTheSameResultAsOneCellAtATime) {
  // The whole plugin, default annealing and marginal chain (colder, then warmer again), with the
  // AVX2 sweep and with TERRAMRF_SIMD=sse2: labels, report and scores bit for bit.
  RandomModelSpec s;
  s.size = 37;
  s.labels = 4;
  s.fixed_fraction = 0.1;
  const EnergyModel em = test::randomModel(21, s);
  OptimiserHarness h;
  const std::string p = "{sweeps: 60, marginal_sweeps: 10, marginal_burn_in: 2, seed: 4}";
  test::widePathRuns();
  const auto vec = h.run("gibbs", p, em);
  const auto one = [&] {
    test::ScopedEnv sse2("TERRAMRF_SIMD", "sse2");
    return h.run("gibbs", p, em);
  }();
  EXPECT_EQ(vec.grid_labels, one.grid_labels);
  EXPECT_EQ(vec.report.final_energy, one.report.final_energy);
  for (const char* m : {"gibbs.best_sweep", "gibbs.annealed_energy", "gibbs.last_sweep_changes"})
    EXPECT_EQ(vec.metrics.at(m), one.metrics.at(m)) << m;
  for (const char* c : kClasses) {
    const Layer& a = vec.scores.at(c);
    const Layer& b = one.scores.at(c);
    ASSERT_EQ(a.size(), b.size());
    EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)), 0) << c;
  }
}

}  // namespace
}  // namespace terramrf
