#include "terramrf/energy_model.hpp"

#include <stdexcept>
#include <string>

namespace terramrf {

void EnergyModel::resize(int r, int c, int k) {
  rows = r;
  cols = c;
  active.resize(k);
  unary.assign(std::size_t(r) * c * k, 0.f);
  fixed.assign(std::size_t(r) * c, 0);
  initial.assign(std::size_t(r) * c, 0);
}

double EnergyModel::energy(const std::vector<uint8_t>& lab) const {
  const int K = numLabels();
  double e = 0;
  // Each unordered pair once: right, down, down-right, down-left.
  static const int dr[4] = {0, 1, 1, 1}, dc[4] = {1, 0, 1, -1};
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const int i = r * cols + c;
      if (fixed[i]) continue;
      e += unary[std::size_t(i) * K + lab[i]];
      for (int n = 0; n < 4; ++n) {
        const int rr = r + dr[n], cc = c + dc[n];
        if (rr < 0 || rr >= rows || cc < 0 || cc >= cols) continue;
        const int j = rr * cols + cc;
        if (fixed[j]) continue;
        const double w = (dr[n] != 0 && dc[n] != 0) ? beta_diagonal : beta;
        e += lab[i] == lab[j] ? -w : w;
      }
    }
  }
  return e;
}

double EnergyModel::localEnergy(const std::vector<uint8_t>& lab, int i, int k) const {
  const int K = numLabels();
  const int r = i / cols, c = i % cols;
  double e = unary[std::size_t(i) * K + k];
  for (int a = -1; a <= 1; ++a) {
    for (int b = -1; b <= 1; ++b) {
      if (a == 0 && b == 0) continue;
      const int rr = r + a, cc = c + b;
      if (rr < 0 || rr >= rows || cc < 0 || cc >= cols) continue;
      const int j = rr * cols + cc;
      if (fixed[j]) continue;
      const double w = (a != 0 && b != 0) ? beta_diagonal : beta;
      e += lab[j] == k ? -w : w;
    }
  }
  return e;
}

}  // namespace terramrf

#include "terramrf/padded_labels.hpp"

namespace terramrf {

int icmSweeps(const EnergyModel& em, PaddedLabels& lab, int max_sweeps, std::vector<uint8_t>& dirty,
              bool& converged) {
  const int R = em.rows, C = em.cols, K = em.numLabels(), W = lab.stride();
  dirty.assign(lab.data().size(), 1);
  std::vector<float> s(K + 1);
  const std::ptrdiff_t off[8] = {-W - 1, -W, -W + 1, -1, 1, W - 1, W, W + 1};
  int sweep = 0;
  bool changed = true;
  for (; changed && sweep < max_sweeps; ++sweep) {
    changed = false;
    for (int r = 0; r < R; ++r) {
      uint8_t* p = lab.at(r, 0);
      uint8_t* d = &dirty[p - lab.data().data()];
      for (int c = 0; c < C; ++c, ++p, ++d) {
        if (!*d || *p == K) continue;  // unchanged surroundings, or fixed
        *d = 0;
        localScores(em, p, std::size_t(r) * C + c, W, s.data());
        int best = *p;
        for (int k = 0; k < K; ++k)
          if (s[k] < s[best]) best = k;
        if (best != *p) {
          *p = static_cast<uint8_t>(best);
          for (std::ptrdiff_t o : off) d[o] = 1;
          changed = true;
        }
      }
    }
  }
  converged = !changed;
  return sweep;
}

void EnergyModel::writeGridLabels(const std::vector<uint8_t>& lab,
                                  std::vector<LabelId>& out) const {
  if (out.size() != cells())
    throw std::logic_error("energy model has " + std::to_string(cells()) + " cells, the grid " +
                           std::to_string(out.size()));
  for (std::size_t i = 0; i < out.size(); ++i)
    out[i] = fixed[i] ? labels::kUnknown : active[lab[i]];
}

}  // namespace terramrf
