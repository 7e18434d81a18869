#pragma once
// Exact moves over strips two cells wide: all the cells of two adjacent rows (or columns) take
// their best joint labelling given the labels around the strip, found by dynamic programming
// along the strip (state: the labels of the strip's two cells at one position; at most K² states
// and K⁴ transitions per position). A strip holds every 2 × n and n × 2 patch, so these moves
// contain the 2×2 block moves and reach what they cannot: two labels entering a patch of 3 × 2
// or 4 × 2 cells, where annealed Gibbs found lower energies than α-expansion with 2×2 blocks
// (docs/optimisers.md).
//
// Only labels that can be part of a best labelling are tried. A cell's pairs inside a strip
// (three edges and two diagonals at most) can move the difference between two of its labels'
// costs by 2·Σ|w| whatever the strip's other cells take, and its eq. 12 sums (every neighbour at
// its current label) differ from its costs given the cells around the strip by as much again.
// So a label whose sum lies 4·Σ|w| or more above the cell's cheapest label costs, in any
// labelling of the strip, at least as much as that label: switching the cell to it does not
// raise the energy, and some best labelling avoids the first (dominance). Where only the cells'
// own labels remain the strip is settled; the search runs over the stretches between settled
// positions, and only where the labels left let two different labels enter: a move that brings
// in one label is an expansion, and the strips run once expansions no longer improve.
#include <cstdint>
#include <vector>

#include "label_sums.hpp"
#include "terramrf/energy_model.hpp"

namespace terramrf::expansion {

class StripMoves {
 public:
  /// Labels up to which strips are searched (one bit per label in the masks of allowed labels).
  static constexpr int kMaxLabels = 8;

  /// Starts a frame of R × C cells: every strip is to be searched once.
  void beginFrame(int R, int C);
  /// Marks the strips whose best labelling may have changed because cell i changed label.
  void touch(int i);

  /// One pass over the strips marked (rows, then columns): each takes its best labelling given
  /// the cells around it if that is lower than its current one. Returns the energy change (≤ 0);
  /// cells whose label changed are appended to `changed`, in the order they changed.
  double pass(const EnergyModel& em, std::vector<uint8_t>& lab, std::vector<int>& changed);

  /// Strips relabelled since beginFrame, and strip stretches searched.
  long taken() const { return taken_; }
  long searched() const { return searched_; }
  /// Strip positions (pairs of cells) in those stretches, summed.
  long searchedPositions() const { return searched_positions_; }

 private:
  /// The stretch [t0, t1] of strip `s` (rows s, s + 1 if `rows`, else columns s, s + 1): its best
  /// labelling by dynamic programming; applied if lower. Returns the energy change (≤ 0).
  double solveStretch(const EnergyModel& em, std::vector<uint8_t>& lab, bool rows, int s, int t0,
                      int t1, std::vector<int>& changed);
  template <int K>  ///< the same with the label count known to the compiler
  double solveStretchK(const EnergyModel& em, std::vector<uint8_t>& lab, bool rows, int s, int t0,
                       int t1, std::vector<int>& changed);
  void relabel(const EnergyModel& em, std::vector<uint8_t>& lab, int i, int to,
               std::vector<int>& changed);
  /// The labels cell i may take in any strip (bit k: label k), from its eq. 12 sums.
  void updateAllowed(const EnergyModel& em, const std::vector<uint8_t>& lab, int i);

  int R_ = 0, C_ = 0;
  std::vector<uint8_t> dirty_rows_, dirty_cols_;  ///< per strip: to be searched
  LabelSums sums_;
  std::vector<uint8_t> allowed_;  ///< per cell: the labels it may take (updateAllowed)
  double reach_ = 0;              ///< 4·Σ|w| of a cell's pairs inside a strip
  // A stretch's search, per position u and state x = a·K + b (its two cells' labels): the cost
  // of the cells at u, the best cost of the stretch up to u, and the best labelling found.
  std::vector<int> idx_;        ///< per position u: its two cells (2u, 2u + 1)
  std::vector<uint8_t> fixed_;  ///< per position u: its two cells' fixed flags
  std::vector<uint8_t> labs_;   ///< per position u: its two cells' labels at the search
  std::vector<double> local_, cost_;
  std::vector<int> stretch_states_;
  /// Pairs between consecutive positions (state before × state after), one matrix per pattern
  /// of fixed cells among the four, for the weights and label count they were made for.
  std::vector<std::vector<double>> trans_;
  int trans_k_ = 0;
  bool avx_ = false;  ///< the recursion four states per instruction (useAvx())
  double trans_wb_ = 0, trans_wd_ = 0;
  long taken_ = 0, searched_ = 0, searched_positions_ = 0;
};

}  // namespace terramrf::expansion
