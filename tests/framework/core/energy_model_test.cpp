#include "terramrf/energy_model.hpp"

#include <gtest/gtest.h>

#include <random>
#include <stdexcept>
#include <string>

namespace terramrf {

namespace {
EnergyModel randomModel(int R, int C, int K, unsigned seed) {
  EnergyModel em;
  em.resize(R, C, K);
  for (int k = 0; k < K; ++k) em.active[k] = static_cast<LabelId>(k + 1);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0, 3);
  for (auto& v : em.unary) v = u(rng);
  for (std::size_t i = 0; i < em.cells(); ++i) em.fixed[i] = (rng() % 7) == 0;
  em.beta = 0.8f;
  em.beta_diagonal = 0.5f;
  return em;
}
}  // namespace

TEST(EnergyModel, HandComputedTwoByOne) {
  EnergyModel em;
  em.resize(1, 2, 2);
  em.unary = {1, 2, 3, 0.5};  // cell0: (1, 2), cell1: (3, 0.5)
  em.beta = 0.8f;
  // labels (0, 1): 1 + 0.5 + 0.8 (different) = 2.3; (0, 0): 1 + 3 − 0.8 = 3.2
  EXPECT_NEAR(em.energy({0, 1}), 2.3, 1e-6);
  EXPECT_NEAR(em.energy({0, 0}), 3.2, 1e-6);
}

TEST(EnergyModel, LocalChangeEqualsTotalChange) {
  // Flipping one cell changes the total energy by exactly its local (eq. 12) energy difference.
  EnergyModel em = randomModel(7, 9, 3, 42);
  std::mt19937 rng(1);
  std::vector<uint8_t> lab(em.cells());
  for (auto& l : lab) l = rng() % 3;
  for (int trial = 0; trial < 200; ++trial) {
    const int i = rng() % em.cells();
    if (em.fixed[i]) continue;
    const int k = rng() % 3;
    const double before = em.energy(lab), local_before = em.localEnergy(lab, i, lab[i]);
    const double local_after = em.localEnergy(lab, i, k);
    lab[i] = static_cast<uint8_t>(k);
    EXPECT_NEAR(em.energy(lab) - before, local_after - local_before, 1e-4);
  }
}

TEST(EnergyModel, GridLabelsMapActiveLabelsAndLeaveFixedCellsUnknown) {
  EnergyModel em;
  em.resize(1, 3, 2);
  em.active = {5, 2};  // label index 0 is project label 5, index 1 is label 2
  em.fixed = {0, 1, 0};
  std::vector<LabelId> grid(3, 9);
  em.writeGridLabels({1, 1, 0}, grid);
  EXPECT_EQ(grid, (std::vector<LabelId>{2, labels::kUnknown, 5}));
  std::vector<LabelId> other_grid(4);
  try {
    em.writeGridLabels({1, 1, 0}, other_grid);
    FAIL() << "expected std::logic_error";
  } catch (const std::logic_error& e) {
    EXPECT_NE(std::string(e.what()).find("3 cells, the grid 4"), std::string::npos) << e.what();
  }
}

}  // namespace terramrf
