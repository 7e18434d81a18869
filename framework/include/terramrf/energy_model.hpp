#pragma once
// The MRF of paper 000 eq. 10–12 in the form optimisers consume.
//
// Labels an optimiser may assign are indexed 0..K-1 ("active labels", mapped to LabelIds by
// `active`). Cells marked `fixed` (no data) are not optimised, take no part in pairwise terms and
// end as unknown (`initial` is ignored for them).
//
//   E(ω) = Σ_cells unary[c][ω_c]  +  Σ_{unordered 8-neighbour pairs {c,d}} w_cd · δ(ω_c, ω_d)
//
// with δ = −1 for equal labels and +1 for different ones, w = beta for edge neighbours and
// beta_diagonal for corner neighbours. The unary already contains α·E_f (eq. 11–12) plus the class
// cost, if any. Summing each pair once makes the change of E when one cell flips equal to that
// cell's eq. 12 energy change, which is what ICM and the Gibbs sampler evaluate locally.
#include <cstdint>
#include <vector>

#include "terramrf/label_set.hpp"

namespace terramrf {

struct EnergyModel {
  int rows = 0, cols = 0;
  std::vector<LabelId> active;   ///< K project labels an optimiser may assign
  std::vector<float> unary;      ///< cells × K, row-major by cell
  std::vector<uint8_t> fixed;    ///< 1 = not optimised (no data)
  std::vector<uint8_t> initial;  ///< starting label index per cell (0..K-1; ignored when fixed)
  float beta = 0.8f;             ///< Potts weight of the 4 edge neighbours
  float beta_diagonal = 0.8f;    ///< Potts weight of the 4 corner neighbours

  int numLabels() const { return static_cast<int>(active.size()); }
  std::size_t cells() const { return std::size_t(rows) * cols; }
  bool empty() const { return active.empty(); }
  void resize(int r, int c, int k);

  /// Total energy of a labelling given as label indices (fixed cells ignored).
  double energy(const std::vector<uint8_t>& labelling) const;
  /// Energy of cell `c` taking label index `k` with its neighbours as in `labelling`
  /// (eq. 12 for one cell: unary + Σ_N w·δ).
  double localEnergy(const std::vector<uint8_t>& labelling, int c, int k) const;
  /// The grid's labels for a labelling: each non-fixed cell its active label, each fixed cell
  /// unknown (no data, no classification). `grid_labels` must hold cells() entries: a grid of
  /// another size was not the one this model was built for (std::logic_error naming both sizes).
  void writeGridLabels(const std::vector<uint8_t>& labelling,
                       std::vector<LabelId>& grid_labels) const;
};

/// What an optimiser reports (printed in the timing report and saved with the outputs).
struct OptimiserReport {
  double initial_energy = 0;
  double final_energy = 0;
  int iterations = 0;       ///< sweeps (ICM, Gibbs) or expansion cycles (α-expansion)
  bool converged = false;
};

}  // namespace terramrf
