// The "gibbs" optimiser: known marginals (independent cells, and a brute-forced 3×3 chain at
// constant temperature), marginals summing to 1, fixed cells, determinism, parameter checks.
#include <gtest/gtest.h>

#include <cmath>

#include "optimiser_test_support.hpp"

namespace terramrf {
namespace {

using test::OptimiserHarness;
using test::RandomModelSpec;

const char* kClasses[] = {"road", "rough", "obstacle", "vegetation"};

TEST(Gibbs, MarginalsOfIndependentCellsAreTheSoftmaxOfTheUnaries) {
  // β = 0: every cell is independent and its conditional is its exact marginal, so the
  // (Rao-Blackwellised) estimate must match exp(−u_k/T)/Σ exp(−u_j/T) to table accuracy.
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
      h.run("gibbs", "{schedule: constant, temperature: 0.7, sweeps: 3, burn_in: 1}", em);
  for (std::size_t i = 0; i < em.cells(); ++i) {
    double z = 0;
    for (int k = 0; k < 4; ++k) z += std::exp(-em.unary[i * 4 + k] / T);
    for (int k = 0; k < 4; ++k)
      EXPECT_NEAR(r.scores.at(kClasses[k])[i], std::exp(-em.unary[i * 4 + k] / T) / z, 1e-4)
          << "cell " << i << " label " << k;
  }
}

TEST(Gibbs, MarginalsMatchBruteForceAtConstantTemperature) {
  // 3×3 grid, 2 labels, coupled cells: exact marginals at T = 1 by enumerating 2^9 labellings.
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
      "gibbs", "{schedule: constant, temperature: 1.0, sweeps: 40000, burn_in: 100, seed: 5}", em);
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
  EXPECT_THROW(h.make("gibbs", "{sweeps: 10, burn_in: 10}", em), std::exception);
  EXPECT_THROW(h.make("gibbs", "{temperature: 1.0, final_temperature: 2.0}", em), std::exception);
  EXPECT_THROW(h.make("gibbs", "{schedule: cubic}", em), std::exception);
  EXPECT_THROW(h.make("gibbs", "{temperature: 0.0}", em), std::exception);
  EXPECT_NO_THROW(
      h.make("gibbs", "{schedule: constant, temperature: 1.0, final_temperature: 2.0}", em));
}

}  // namespace
}  // namespace terramrf
