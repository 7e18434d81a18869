#include "strip_moves.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "frame_graph.hpp"
#include "terramrf/simd.hpp"

namespace terramrf::expansion {
namespace {

inline double dl(int a, int b) { return a == b ? -1.0 : 1.0; }
/// Bits set in a label mask (8 bits); the build targets x86-64 without POPCNT.
inline int popcount(unsigned m) {
  m = m - (m >> 1 & 0x55u);
  m = (m & 0x33u) + (m >> 2 & 0x33u);
  return static_cast<int>((m + (m >> 4)) & 0x0Fu);
}

/// Row stride of the transition matrices for S states: S rounded up to a multiple of four (one
/// AVX register of doubles), +∞ in the padding.
constexpr int stride(int S) { return (S + 3) & ~3; }

/// One step of the recursion: cur[x] = local[x] + min_y (prev[y] + T[y·SP + x]) for x < S, SP =
/// stride(S). S is a compile-time constant so that the running minima stay in registers, two per
/// SSE2 register.
template <int S>
void minPlus(const double* __restrict prev, const double* __restrict T,
             const double* __restrict local, double* __restrict cur) {
  constexpr int SP = stride(S);
#if defined(__SSE2__)
  constexpr int H = SP / 2;
  __m128d acc[H];
  for (int h = 0; h < H; ++h) acc[h] = _mm_set1_pd(INFINITY);
  for (int y = 0; y < S; ++y) {
    const double py = prev[y];
    if (!(py < INFINITY)) continue;  // a state ruled out: no path through it
    const __m128d p = _mm_set1_pd(py);
    const double* Ty = T + y * SP;
    for (int h = 0; h < H; ++h)
      acc[h] = _mm_min_pd(acc[h], _mm_add_pd(p, _mm_loadu_pd(Ty + 2 * h)));
  }
  alignas(16) double m[SP];
  for (int h = 0; h < H; ++h) _mm_store_pd(m + 2 * h, acc[h]);
#else
  double m[SP];
  for (int x = 0; x < SP; ++x) m[x] = INFINITY;
  for (int y = 0; y < S; ++y) {
    const double py = prev[y];
    if (!(py < INFINITY)) continue;
    for (int x = 0; x < SP; ++x) m[x] = std::min(m[x], py + T[y * SP + x]);
  }
#endif
  for (int x = 0; x < S; ++x) cur[x] = m[x] + local[x];
}

#if defined(TERRAMRF_SIMD_DISPATCH)
/// The same four states per register (AVX): the same sums and minima, so the same bits.
template <int S>
TERRAMRF_TARGET_AVX void minPlusAvx(const double* __restrict prev, const double* __restrict T,
                                    const double* __restrict local, double* __restrict cur) {
  constexpr int SP = stride(S), Q = SP / 4;
  __m256d acc[Q];
  for (int q = 0; q < Q; ++q) acc[q] = _mm256_set1_pd(INFINITY);
  for (int y = 0; y < S; ++y) {
    const double py = prev[y];
    if (!(py < INFINITY)) continue;
    const __m256d p = _mm256_set1_pd(py);
    const double* Ty = T + y * SP;
    for (int q = 0; q < Q; ++q)
      acc[q] = _mm256_min_pd(acc[q], _mm256_add_pd(p, _mm256_loadu_pd(Ty + 4 * q)));
  }
  if constexpr (S == SP) {
    for (int q = 0; q < Q; ++q)
      _mm256_storeu_pd(cur + 4 * q, _mm256_add_pd(acc[q], _mm256_loadu_pd(local + 4 * q)));
  } else {
    alignas(32) double m[SP];
    for (int q = 0; q < Q; ++q) _mm256_store_pd(m + 4 * q, acc[q]);
    for (int x = 0; x < S; ++x) cur[x] = m[x] + local[x];
  }
}
#endif

}  // namespace

void StripMoves::beginFrame(int R, int C) {
  R_ = R;
  C_ = C;
  dirty_rows_.assign(std::max(0, R - 1), 1);
  dirty_cols_.assign(std::max(0, C - 1), 1);
  taken_ = searched_ = searched_positions_ = 0;
}

void StripMoves::touch(int i) {
  const int r = i / C_, c = i % C_;
  for (int s = std::max(0, r - 2); s <= std::min(R_ - 2, r + 1); ++s) dirty_rows_[s] = 1;
  for (int s = std::max(0, c - 2); s <= std::min(C_ - 2, c + 1); ++s) dirty_cols_[s] = 1;
}

void StripMoves::relabel(const EnergyModel& em, std::vector<uint8_t>& lab, int i, int to,
                         std::vector<int>& changed) {
  const int from = lab[i];
  lab[i] = static_cast<uint8_t>(to);
  changed.push_back(i);
  sums_.relabel(em, i, from, to, [&](int n) { updateAllowed(em, lab, n); });
  updateAllowed(em, lab, i);
  touch(i);
}

void StripMoves::updateAllowed(const EnergyModel& em, const std::vector<uint8_t>& lab, int i) {
  const int K = em.numLabels();
  unsigned mask = 1u << lab[i];
  if (!em.fixed[i]) {
    const double* ns = sums_.at(em, i);
    // The cheapest label always stays: the dominated ones are left out in its favour.
    const int best = static_cast<int>(std::min_element(ns, ns + K) - ns);
    for (int k = 0; k < K; ++k)
      if (k == best || ns[k] - ns[best] < reach_) mask |= 1u << k;
  }
  allowed_[i] = static_cast<uint8_t>(mask);
}

double StripMoves::pass(const EnergyModel& em, std::vector<uint8_t>& lab,
                        std::vector<int>& changed) {
  const double wb = em.beta, wd = em.beta_diagonal;
  avx_ = useAvx();
  sums_.begin(em, lab);  // computed for every non-fixed cell by updateAllowed below
  // A cell's pairs inside a strip (three edges, two diagonals at most) move the difference of
  // two labels' outside costs against their eq. 12 sums by 2·Σ|w| at most, and dominance needs
  // the outside costs 2·Σ|w| apart: so the sums 4·Σ|w| apart. The same for every strip.
  reach_ = 4 * (3 * std::abs(wb) + 2 * std::abs(wd));
  allowed_.resize(em.cells());
  // A cell's mask is made with its sums, when a strip first reads it (a pass after a few moves
  // reads only the strips they touched), and follows its neighbours' changes from then on.
  auto mask = [&](int i) -> unsigned {
    if (em.fixed[i]) return 1u << lab[i];
    if (!sums_.computed(i)) updateAllowed(em, lab, i);
    return allowed_[i];
  };
  double total = 0;
  for (const bool rows : {true, false}) {
    std::vector<uint8_t>& dirty = rows ? dirty_rows_ : dirty_cols_;
    const int strips = rows ? R_ - 1 : C_ - 1, length = rows ? C_ : R_;
    for (int s = 0; s < strips; ++s) {
      if (!dirty[s]) continue;
      auto cell = [&](int t, int j) { return rows ? (s + j) * C_ + t : t * C_ + s + j; };
      auto open = [&](int t) {
        return popcount(mask(cell(t, 0))) + popcount(mask(cell(t, 1))) > 2;
      };
      for (int t = 0; t < length;) {
        if (!open(t)) {
          ++t;
          continue;
        }
        int t1 = t;
        while (t1 + 1 < length && open(t1 + 1)) ++t1;
        // The labels the stretch's cells may change to: with fewer than two, any move is an
        // expansion, which no longer improves.
        unsigned entering = 0;
        for (int u = t; u <= t1; ++u)
          for (int j = 0; j < 2; ++j) {
            const int i = cell(u, j);
            entering |= mask(i) & ~(1u << lab[i]);
          }
        if (popcount(entering) >= 2) total += solveStretch(em, lab, rows, s, t, t1, changed);
        t = t1 + 1;
      }
      dirty[s] = 0;  // its own moves marked it; it is now best given the cells around it
    }
  }
  return total;
}

double StripMoves::solveStretch(const EnergyModel& em, std::vector<uint8_t>& lab, bool rows, int s,
                                int t0, int t1, std::vector<int>& changed) {
  using Solve = double (StripMoves::*)(const EnergyModel&, std::vector<uint8_t>&, bool, int, int,
                                       int, std::vector<int>&);
  static constexpr Solve kByLabels[kMaxLabels + 1] = {nullptr,
                                                      nullptr,
                                                      &StripMoves::solveStretchK<2>,
                                                      &StripMoves::solveStretchK<3>,
                                                      &StripMoves::solveStretchK<4>,
                                                      &StripMoves::solveStretchK<5>,
                                                      &StripMoves::solveStretchK<6>,
                                                      &StripMoves::solveStretchK<7>,
                                                      &StripMoves::solveStretchK<8>};
  return (this->*kByLabels[em.numLabels()])(em, lab, rows, s, t0, t1, changed);
}

template <int K>
double StripMoves::solveStretchK(const EnergyModel& em, std::vector<uint8_t>& lab, bool rows, int s,
                                 int t0, int t1, std::vector<int>& changed) {
  constexpr int S = K * K;
  const int n = t1 - t0 + 1;
  const double wb = em.beta, wd = em.beta_diagonal;
  ++searched_;
  searched_positions_ += n;
  // Per position u: its two cells (2u, 2u + 1), their fixed flags and labels.
  const int dt = rows ? 1 : C_, dj = rows ? C_ : 1;
  idx_.resize(std::size_t(n) * 2);
  fixed_.resize(std::size_t(n) * 2);
  labs_.resize(std::size_t(n) * 2);
  for (int u = 0, i = (rows ? s * C_ : s) + t0 * dt; u < n; ++u, i += dt)
    for (int j = 0; j < 2; ++j) {
      idx_[2 * u + j] = i + j * dj;
      fixed_[2 * u + j] = em.fixed[i + j * dj];
      labs_[2 * u + j] = lab[i + j * dj];
    }
  // Per position u and state x = a·K + b (labels of its two cells): the cost of the cells there,
  // their outside pairs (eq. 12 sums less the pairs with the stretch's other non-fixed cells) and
  // their pair with each other; +∞ for labels ruled out. A fixed cell has one label and no pairs.
  local_.resize(std::size_t(n) * S);
  double o[2][kMaxLabels];
  for (int u = 0; u < n; ++u) {
    for (int j = 0; j < 2; ++j) {
      const int slot = 2 * u + j, i = idx_[slot];
      const unsigned mask = fixed_[slot] ? 1u << labs_[slot] : allowed_[i];
      if (fixed_[slot]) {
        for (int k = 0; k < K; ++k) o[j][k] = mask >> k & 1 ? 0.0 : INFINITY;
        continue;
      }
      // Less the pairs inside the stretch: w·δ(k, l_n) is −w for k = l_n and +w otherwise. (Summed
      // per label in registers: adding into the row entry by entry stalls on store forwarding.)
      int nb[5];
      double nw[5];
      int m = 0;
      auto inside = [&](int other, double w) {
        if (fixed_[other]) return;
        nb[m] = labs_[other];
        nw[m++] = w;
      };
      inside(slot ^ 1, wb);
      if (u > 0) {
        inside(slot - 2, wb);
        inside((slot - 2) ^ 1, wd);
      }
      if (u + 1 < n) {
        inside(slot + 2, wb);
        inside((slot + 2) ^ 1, wd);
      }
      double w_in = 0;
      for (int q = 0; q < m; ++q) w_in += nw[q];
      const double* ns = sums_.at(em, i);
      double v[K];
      for (int k = 0; k < K; ++k) v[k] = ns[k] - w_in;
      for (int q = 0; q < m; ++q)
        for (int k = 0; k < K; ++k) v[k] += nb[q] == k ? 2 * nw[q] : 0.0;
      for (int k = 0; k < K; ++k) o[j][k] = mask >> k & 1 ? v[k] : INFINITY;
    }
    const double inner = fixed_[2 * u] || fixed_[2 * u + 1] ? 0.0 : wb;
    double* l = &local_[std::size_t(u) * S];
    for (int a = 0; a < K; ++a)
      for (int b = 0; b < K; ++b) l[a * K + b] = o[0][a] + o[1][b] + inner * dl(a, b);
  }
  // Pairs between consecutive positions, state y before x: the two edges along the strip and the
  // two diagonals, each only between non-fixed cells.
  constexpr int SP = stride(S);
  auto fill = [&](std::vector<double>& T, bool p0, bool q0, bool p1, bool q1) {
    T.assign(std::size_t(S) * SP, INFINITY);
    for (int y = 0; y < S; ++y)
      for (int x = 0; x < S; ++x) {
        const int pa = y / K, pb = y % K, a = x / K, b = x % K;
        double v = 0;
        if (p0 && p1) v += wb * dl(pa, a);
        if (q0 && q1) v += wb * dl(pb, b);
        if (p0 && q1) v += wd * dl(pa, b);
        if (q0 && p1) v += wd * dl(pb, a);
        T[std::size_t(y) * SP + x] = v;
      }
  };
  // One matrix per pattern of fixed cells at the two positions (bit 0: p at u − 1, 1: q at
  // u − 1, 2: p at u, 3: q at u), made once for the weights and label count.
  if (trans_k_ != K || trans_wb_ != wb || trans_wd_ != wd) {
    trans_.resize(16);
    for (int f = 0; f < 16; ++f) fill(trans_[f], !(f & 1), !(f & 2), !(f & 4), !(f & 8));
    trans_k_ = K;
    trans_wb_ = wb;
    trans_wd_ = wd;
  }
  auto transAt = [&](int u) -> const double* {  // u ≥ 1: between u − 1 and u
    const int f =
        fixed_[2 * u - 2] | fixed_[2 * u - 1] << 1 | fixed_[2 * u] << 2 | fixed_[2 * u + 1] << 3;
    return trans_[f].data();
  };
  // Forward: cost_[u][x] = local[u][x] + min_y (cost_[u − 1][y] + T[y][x]). The argmins are
  // found again on the way back, for one state per position.
  cost_.resize(std::size_t(n) * S);
  std::copy(local_.begin(), local_.begin() + S, cost_.begin());
#if defined(TERRAMRF_SIMD_DISPATCH)
  if (avx_) {
    for (int u = 1; u < n; ++u)
      minPlusAvx<S>(&cost_[std::size_t(u - 1) * S], transAt(u), &local_[std::size_t(u) * S],
                    &cost_[std::size_t(u) * S]);
  } else
#endif
    for (int u = 1; u < n; ++u)
      minPlus<S>(&cost_[std::size_t(u - 1) * S], transAt(u), &local_[std::size_t(u) * S],
                 &cost_[std::size_t(u) * S]);
  // The current labelling's cost by the same sums.
  auto stateOf = [&](int u) { return labs_[2 * u] * K + labs_[2 * u + 1]; };
  double now = local_[stateOf(0)];
  for (int u = 1; u < n; ++u)
    now += transAt(u)[std::size_t(stateOf(u - 1)) * SP + stateOf(u)] +
           local_[std::size_t(u) * S + stateOf(u)];
  const double* last = &cost_[std::size_t(n - 1) * S];
  const int best_x = static_cast<int>(std::min_element(last, last + S) - last);
  const double best = last[best_x];
  if (!(best < now - 1e-9 * (1.0 + std::abs(now)))) return 0.0;
  // Back along the recursion: at each position the previous state that gave the minimum.
  stretch_states_.assign(n, 0);
  stretch_states_[n - 1] = best_x;
  for (int u = n - 1; u > 0; --u) {
    const int x = stretch_states_[u];
    const double* T = transAt(u);
    const double* prev = &cost_[std::size_t(u - 1) * S];
    int arg = 0;
    double m = INFINITY;
    for (int y = 0; y < S; ++y) {
      const double v = prev[y] + T[std::size_t(y) * SP + x];
      if (v < m) {
        m = v;
        arg = y;
      }
    }
    stretch_states_[u - 1] = arg;
  }
  for (int u = 0; u < n; ++u)
    for (int j = 0; j < 2; ++j) {
      const int i = idx_[2 * u + j], to = j == 0 ? stretch_states_[u] / K : stretch_states_[u] % K;
      if (lab[i] != to) relabel(em, lab, i, to, changed);
    }
  ++taken_;
  return best - now;
}

}  // namespace terramrf::expansion
