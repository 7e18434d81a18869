#pragma once
// Each cell's eq. 12 energy for every label with its 8 neighbours at their current labels, in
// doubles (the block and strip moves judge exact energy changes on them), computed when first
// asked for in a pass and kept up to date as cells change label. The 2×2 block moves and the
// strip moves both read them.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "frame_graph.hpp"
#include "terramrf/energy_model.hpp"
#include "terramrf/padded_labels.hpp"

namespace terramrf::expansion {

class LabelSums {
 public:
  /// Labels up to which sums are kept (a per-cell scratch array on the stack).
  static constexpr int kMaxLabels = 8;

  /// Starts a pass over labelling `lab`: no sums computed yet.
  void begin(const EnergyModel& em, const std::vector<uint8_t>& lab) {
    K_ = em.numLabels();
    C_ = em.cols;
    pad_.assign(em, lab);
    sums_.resize(em.cells() * std::size_t(K_));
    computed_.assign(em.cells(), 0);
  }
  bool computed(int i) const { return computed_[i] != 0; }

  /// Cell i's sums, one per label (a non-fixed cell).
  const double* at(const EnergyModel& em, int i) {
    double* s = &sums_[std::size_t(i) * K_];
    if (computed_[i]) return s;
    computed_[i] = 1;
    // w·δ(k, l_n) summed over the neighbours: +w for every k, −2w more for the neighbour's own
    // label. The pad and fixed cells hold K, whose slot t[K] is scratch.
    const int W = pad_.stride();
    const std::ptrdiff_t off[8] = {-W - 1, -W, -W + 1, -1, 1, W - 1, W, W + 1};
    const uint8_t* p = pad_.at(i / C_, i % C_);
    double t[kMaxLabels + 1] = {}, all = 0;
    for (int d = 0; d < 8; ++d) {
      const double w = isDiagonal(d) ? em.beta_diagonal : em.beta;
      all += p[off[d]] < K_ ? w : 0.0;
      t[p[off[d]]] -= 2 * w;
    }
    const float* u = &em.unary[std::size_t(i) * K_];
    for (int k = 0; k < K_; ++k) s[k] = u[k] + all + t[k];
    return s;
  }

  /// Cell i changes from label `from` to `to`: the sums computed so far of its non-fixed
  /// neighbours follow, and `changed(n)` is called for each such neighbour n.
  template <class Changed>
  void relabel(const EnergyModel& em, int i, int from, int to, Changed&& changed) {
    const int r = i / C_, c = i % C_;
    *pad_.at(r, c) = static_cast<uint8_t>(to);  // the sums computed later read it
    for (int d = 0; d < 8; ++d) {
      const int rr = r + kDr[d], cc = c + kDc[d], n = rr * C_ + cc;
      if (rr < 0 || rr >= em.rows || cc < 0 || cc >= C_ || em.fixed[n]) continue;
      if (!computed_[n]) continue;  // computed from the new labels when needed
      const double w = isDiagonal(d) ? em.beta_diagonal : em.beta;
      double* s = &sums_[std::size_t(n) * K_];
      s[from] += 2 * w;
      s[to] -= 2 * w;
      changed(n);
    }
  }

 private:
  int K_ = 0, C_ = 0;
  PaddedLabels pad_;
  std::vector<double> sums_;       ///< per cell and label
  std::vector<uint8_t> computed_;  ///< per cell: its sums are computed in this pass
};

}  // namespace terramrf::expansion
