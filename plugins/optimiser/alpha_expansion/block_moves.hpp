#pragma once
// Exact 2×2 block moves for the Potts energy: each 2×2 block of cells takes its best joint
// labelling given the labels around it. They contain the moves in which two labels enter a region
// at once (a rough patch that is part road, part obstacle), which no expansion (one label enters)
// and no swap (two labels trade cells) contains, so α-expansion tries them when its expansions
// are exhausted.
#include <cstdint>
#include <vector>

#include "label_sums.hpp"
#include "terramrf/energy_model.hpp"

namespace terramrf::expansion {

class BlockMoves {
 public:
  /// Labels up to which blocks are searched (the search keeps per-label arrays on the stack).
  static constexpr int kMaxLabels = 8;

  /// Starts a frame of `cells` cells: every block is to be searched once.
  void beginFrame(std::size_t cells) {
    dirty_.assign(cells, 1);
    taken_ = 0;
  }
  /// Marks the blocks whose best move may have changed because cell i changed label: those that
  /// hold i or have it among their twelve outside neighbours. R × C is the grid.
  void touch(int i, int R, int C);

  /// One raster pass of exact 2×2 block moves over the blocks marked dirty: the non-fixed cells
  /// of each block (at least two) take the joint labelling of least energy given the current
  /// labels around them (their unaries, the inner pairs between them and their pairs with the
  /// cells around).
  /// Returns the total energy change (≤ 0). A block is searched only if a bound says it could
  /// improve (every cell at its best label given the outside, every inner pair equal), which
  /// leaves uniform, settled regions alone; the search fixes the top two cells (K² cases) and
  /// solves the bottom pair of the Potts model exactly from each one's best and second-best label.
  /// Cells whose label changed are appended to `changed`, in the order they changed.
  double pass(const EnergyModel& em, std::vector<uint8_t>& lab, std::vector<int>& changed);

  /// Block moves taken since beginFrame.
  int taken() const { return taken_; }

 private:
  std::vector<uint8_t> dirty_;       ///< per block (top-left cell): its best move may have changed
  LabelSums sums_;
  std::vector<double> margin_;         ///< per cell: second-best label's sum minus its label's
  std::vector<uint8_t> margin_valid_;  ///< per cell: margin_ is from the current labels
  int taken_ = 0;
};

}  // namespace terramrf::expansion
