#pragma once
// The graph α-expansion cuts for one frame: its nodes are the cells that are not fixed (cells
// without points keep "unknown" and take no part), its edges their unordered 8-neighbour pairs,
// kept as flat arrays with per-node adjacency lists, which the cut's searches walk.
#include <cstdint>
#include <vector>

#include "terramrf/energy_model.hpp"

namespace terramrf::expansion {

/// The 8-neighbourhood as row and column steps; directions 4–7 point forward in raster order.
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

/// The non-fixed cells (graph nodes) and their unordered 8-neighbour pairs (graph edges).
struct FrameGraph {
  std::vector<int> cells;    ///< non-fixed cells; node id n = position here
  std::vector<int> node_of;  ///< per cell: node id, −1 if fixed
  std::vector<int> pair_p,
      pair_q;  ///< unordered neighbour pairs (cells), p before q in raster order
  std::vector<int> pair_np, pair_nq;     ///< their node ids
  std::vector<float> pair_w;             ///< their Potts weight w
  std::vector<int64_t> pair_v;           ///< V = 2w in capacity units (set once the scale is known)
  std::vector<int> pairs_off, pairs_of;  ///< per node n: its pairs pairs_of[pairs_off[n] …)

  /// Rebuilds the graph from the energy model's fixed cells and Potts weights; pair_v is left
  /// to the cut, which knows the capacity scale.
  void build(const EnergyModel& em);
};

}  // namespace terramrf::expansion
