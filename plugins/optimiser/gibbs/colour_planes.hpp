#pragma once
// The grid split by the parity of row and column into four colour planes, the layout of the
// chromatic Gibbs sampler. No two cells of one colour are 8-neighbours, so a whole colour can be
// drawn at once from the same conditionals as one cell at a time (Besag's coding sets, the
// parallel updates of Geman & Geman §XI). In its own plane a colour's cells are contiguous, and
// each of a cell's neighbours sits at the same index, shifted by at most one row and one column,
// in one of the three other planes: eight cells take eight contiguous loads, not gathers.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "terramrf/energy_model.hpp"

namespace terramrf {

class ColourPlanes {
 public:
  /// Cells drawn together by the vector sweep; planes are padded so that a row's last group of
  /// lanes and its neighbours' loads stay inside the plane.
  static constexpr int kLanes = 8;

  /// Lays out the labels of `lab` (fixed cells ignored) and the unaries of `em`, no group
  /// settled. Fixed cells,
  /// cells beyond an odd grid's last row or column, and the one-cell pad hold the sentinel K.
  void assign(const EnergyModel& em, const std::vector<uint8_t>& lab);
  /// Writes the labels of the non-fixed cells back into `lab` (row-major grid order).
  void extract(const EnergyModel& em, std::vector<uint8_t>& lab) const;
  /// Adds plane-layout per-label sums `acc` (as accumulated by a sweep), times `scale`, into
  /// `out` (cells × K, row-major by cell), for the non-fixed cells.
  void gatherLabelSums(const EnergyModel& em, const std::vector<float>& acc, float scale,
                       std::vector<float>& out) const;

  int labels() const { return k_; }
  int subRows() const { return sub_rows_; }
  int subCols() const { return sub_cols_; }
  int gridCols() const { return cols_; }
  /// Bytes (labels) or floats (per label layer) per plane.
  std::size_t planeSize() const { return plane_size_; }
  /// Index of sub-row i, sub-column j within a plane (a plane's cell (i, j) of colour (a, b) is
  /// grid cell (2i + a, 2j + b)).
  std::size_t index(int i, int j) const { return std::size_t(i + 1) * stride_ + j + 1; }

  /// Label plane p = 2a + b (a = row parity, b = column parity).
  uint8_t* plane(int p) { return &labels_[p * plane_size_]; }
  /// Unaries of label k in plane p.
  const float* unary(int p, int k) const {
    return &unary_[(std::size_t(p) * k_ + k) * plane_size_];
  }
  /// For plane p, the offsets of the 8 neighbours into data(): data()[offsets[n] + idx] is the
  /// label of neighbour n of the cell at index idx; n = 0..3 are the edge neighbours, 4..7 the
  /// diagonal ones. (Offsets, not pointers: a pointer before the array would be undefined.)
  std::array<std::ptrdiff_t, 8> neighbourOffsets(int p) const;

  /// All labels (the four planes back to back), for copying whole states.
  std::vector<uint8_t>& data() { return labels_; }

  /// Per group of kLanes cells of a plane row: 1 = "settled", every cell's draw was certain
  /// and left its label, and no neighbour has changed since. With the temperature not rising,
  /// such a group's draws stay certain and the same, so a sweep may skip it. Indexed by group
  /// g = j / kLanes, from −1 to groups (pads, so that unsettling neighbours needs no bounds).
  uint8_t* settled(int p, int i) {
    return &settled_[(std::size_t(p) * (sub_rows_ + 2) + i + 1) * settled_stride_ + 1];
  }
  /// Unsettles the groups whose cells neighbour the lanes set in `moved` (bit l = lane l, not 0)
  /// of group g in plane p's sub-row i: they are in the other three planes, sub-rows i − 1 to
  /// i + 1, and the groups beside g when the first or last lane moved.
  void unsettleNeighbours(int p, int i, int g, unsigned moved) {
    const int first = __builtin_ctz(moved), last = 31 - __builtin_clz(moved);
    const int g_lo = g + ((first - 1) >> 3), g_hi = g + ((last + 1) >> 3);
    static_assert(kLanes == 8, "the shifts above divide by kLanes");
    for (int q = 0; q < 4; ++q) {
      if (q == p) continue;
      for (int r = i - 1; r <= i + 1; ++r)
        for (int h = g_lo; h <= g_hi; ++h) settled(q, r)[h] = 0;
    }
  }
  /// To be called before each sweep with its 1/T: unsettles every group when the temperature
  /// rose since the last sweep (certain draws may not be any more).
  void sweepAt(float inv_t) {
    if (inv_t < settled_inv_t_) std::fill(settled_.begin(), settled_.end(), uint8_t(0));
    settled_inv_t_ = inv_t;
  }

 private:
  int rows_ = 0, cols_ = 0, k_ = 0;
  int sub_rows_ = 0, sub_cols_ = 0, stride_ = 0;
  std::size_t plane_size_ = 0;
  int settled_stride_ = 0;
  float settled_inv_t_ = 0.f;  ///< 1/T of the last sweep
  std::vector<uint8_t> labels_, settled_;
  std::vector<float> unary_;
};

}  // namespace terramrf
