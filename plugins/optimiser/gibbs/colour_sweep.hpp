#pragma once
// One chromatic Gibbs sweep: the four colours of ColourPlanes in turn, every cell of a colour
// drawn from its conditional P(k | neighbours) ∝ exp(−E_c(k) / T) given the other colours.
// Two implementations of the same arithmetic: one cell at a time (any CPU), and eight cells
// at a time in AVX2; both skip the same settled groups. Each performs the same IEEE operations in
// the same order per cell and the random numbers depend only on (seed, sweep, cell), so the two
// give the same bits.
#include <cstdint>

#include "colour_planes.hpp"
#include "counter_rng.hpp"
#include "neg_exp.hpp"

namespace terramrf {

struct ColourSweepParams {
  float inv_t = 1.f;  ///< 1 / temperature [1/energy]
  float we = 0.f;     ///< 2·β: the conditional's weight of an edge neighbour with the same label
  float wd = 0.f;     ///< 2·β_diagonal, the same for a corner neighbour
  /// Add each drawn cell's conditional to the per-label sums (plane layout, K planes per
  /// colour), the Rao-Blackwellised marginal estimate.
  float* sums = nullptr;
  SweepKeys keys{0, 0};
  bool avx2 = false;  ///< the eight-lane version (the caller checks the CPU)
  /// Skip the groups ColourPlanes marks settled (exact: their draws are certain and the same).
  /// Off only to check that it is exact.
  bool skip_settled = true;
};

/// Runs one sweep over `planes`; returns the number of labels changed and adds the energy change
/// to `energy`, cell by cell in the order one-at-a-time sampling visits them.
int colourSweep(ColourPlanes& planes, const ColourSweepParams& params, double& energy);

}  // namespace terramrf
