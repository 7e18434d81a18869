#include "colour_planes.hpp"

#include <algorithm>

namespace terramrf {

void ColourPlanes::assign(const EnergyModel& em, const std::vector<uint8_t>& lab) {
  rows_ = em.rows;
  cols_ = em.cols;
  k_ = em.numLabels();
  sub_rows_ = (rows_ + 1) / 2;
  sub_cols_ = (cols_ + 1) / 2;
  // One pad column on each side, the last group of lanes rounded up, and one more group so that
  // a vector load at any index of a row stays in the plane.
  const int groups = (sub_cols_ + kLanes - 1) / kLanes;
  stride_ = groups * kLanes + kLanes + 2;
  plane_size_ = std::size_t(sub_rows_ + 2) * stride_;
  labels_.assign(4 * plane_size_, static_cast<uint8_t>(k_));
  settled_stride_ = groups + 2;
  settled_.assign(4 * std::size_t(sub_rows_ + 2) * settled_stride_, 0);
  settled_inv_t_ = 0.f;
  // Pad unaries are 0, not garbage: the vector sweep computes (and discards) their lanes.
  unary_.assign(4 * std::size_t(k_) * plane_size_, 0.f);
  for (int r = 0; r < rows_; ++r)
    for (int c = 0; c < cols_; ++c) {
      const std::size_t cell = std::size_t(r) * cols_ + c;
      const int p = 2 * (r & 1) + (c & 1);
      const std::size_t idx = index(r / 2, c / 2);
      if (!em.fixed[cell]) labels_[p * plane_size_ + idx] = lab[cell];
      for (int k = 0; k < k_; ++k)
        unary_[(std::size_t(p) * k_ + k) * plane_size_ + idx] = em.unary[cell * k_ + k];
    }
}

void ColourPlanes::extract(const EnergyModel& em, std::vector<uint8_t>& lab) const {
  for (int r = 0; r < rows_; ++r)
    for (int c = 0; c < cols_; ++c) {
      const std::size_t cell = std::size_t(r) * cols_ + c;
      if (!em.fixed[cell])
        lab[cell] = labels_[(2 * (r & 1) + (c & 1)) * plane_size_ + index(r / 2, c / 2)];
    }
}

void ColourPlanes::gatherLabelSums(const EnergyModel& em, const std::vector<float>& acc,
                                   float scale, std::vector<float>& out) const {
  for (int r = 0; r < rows_; ++r)
    for (int c = 0; c < cols_; ++c) {
      const std::size_t cell = std::size_t(r) * cols_ + c;
      if (em.fixed[cell]) continue;
      const int p = 2 * (r & 1) + (c & 1);
      const std::size_t idx = index(r / 2, c / 2);
      for (int k = 0; k < k_; ++k)
        out[cell * k_ + k] += acc[(std::size_t(p) * k_ + k) * plane_size_ + idx] * scale;
    }
}

std::array<std::ptrdiff_t, 8> ColourPlanes::neighbourOffsets(int p) const {
  // Neighbour (dr, dc) of cell (2i + a, 2j + b) is cell (2i + a + dr, 2j + b + dc): plane
  // ((a + dr) mod 2, (b + dc) mod 2), sub-row i + ⌊(a + dr) / 2⌋, sub-column j + ⌊(b + dc) / 2⌋.
  static constexpr int kOffsets[8][2] = {{-1, 0},  {1, 0},  {0, -1}, {0, 1},
                                         {-1, -1}, {-1, 1}, {1, -1}, {1, 1}};
  const int a = p >> 1, b = p & 1;
  auto floorHalf = [](int v) { return v < 0 ? -1 : v / 2; };
  std::array<std::ptrdiff_t, 8> out{};
  for (int n = 0; n < 8; ++n) {
    const int ra = a + kOffsets[n][0], cb = b + kOffsets[n][1];
    const int q = 2 * (ra & 1) + (cb & 1);
    const std::ptrdiff_t shift = std::ptrdiff_t(floorHalf(ra)) * stride_ + floorHalf(cb);
    out[n] = std::ptrdiff_t(q * plane_size_) + shift;
  }
  return out;
}

}  // namespace terramrf
