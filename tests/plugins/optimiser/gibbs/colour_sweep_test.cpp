// The chromatic sweep's kernels: the eight-lane AVX2 sweep and the one-cell-at-a-time sweep, both
// skipping settled groups, give the same bits as the one-cell sweep that skips nothing, for any
// K, odd and even grid sides, fixed cells and a temperature that falls and then rises; each colour
// is drawn from the right conditional (a 1 × 2 grid's exact frequencies); and the colour planes'
// layout round-trips.
#include "colour_sweep.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "colour_planes.hpp"
#include "optimiser_test_support.hpp"
#include "terramrf/simd.hpp"

namespace terramrf {
namespace {

/// A random rows × cols model (test::randomModel), unaries in ±1.5, weights 0.1–1.0.
EnergyModel randomRectModel(uint32_t seed, int rows, int cols, int K, double fixed_fraction) {
  test::RandomModelSpec s;
  s.size = rows;
  s.cols = cols;
  s.labels = K;
  s.fixed_fraction = fixed_fraction;
  s.unary_lo = -1.5;
  s.unary_hi = 1.5;
  s.beta_lo = 0.1;
  s.beta_hi = 1.0;
  return test::randomModel(seed, s);
}

struct Chain {
  ColourPlanes planes;
  std::vector<float> sums;
  double energy = 0;
  std::vector<int> changed;
};

/// Runs `inv_ts.size()` sweeps (sums from sweep `average_from` on) with the vector kernel or not,
/// skipping settled groups or not.
Chain runChain(const EnergyModel& em, const std::vector<float>& inv_ts, std::size_t average_from,
               bool avx2, bool skip_settled = true) {
  Chain ch;
  ch.planes.assign(em, em.initial);
  ch.sums.assign(4 * std::size_t(em.numLabels()) * ch.planes.planeSize(), 0.f);
  ColourSweepParams sp;
  sp.we = 2.f * em.beta;
  sp.wd = 2.f * em.beta_diagonal;
  sp.avx2 = avx2;
  sp.skip_settled = skip_settled;
  for (std::size_t s = 0; s < inv_ts.size(); ++s) {
    sp.inv_t = inv_ts[s];
    sp.sums = s >= average_from ? ch.sums.data() : nullptr;
    sp.keys = SweepKeys(7, s);
    ch.changed.push_back(colourSweep(ch.planes, sp, ch.energy));
  }
  return ch;
}

bool haveAvx2() {
#if defined(TERRAMRF_SIMD_DISPATCH)
  return __builtin_cpu_supports("avx2");
#else
  return false;
#endif
}

TEST(ColourSweep, SkippingSettledGroupsAndEightLanesGiveTheSameBits) {
  // Cold enough for whole groups to settle (and be skipped), then warmer again (they must be
  // unsettled), then cold: 1/T from 0.5 to 40, then 1, then 40.
  std::vector<float> inv_ts;
  for (int s = 0; s < 40; ++s) inv_ts.push_back(0.5f * std::pow(80.f, s / 39.f));
  for (int s = 0; s < 8; ++s) inv_ts.push_back(1.f);
  for (int s = 0; s < 8; ++s) inv_ts.push_back(40.f);
  const struct {
    int rows, cols, K;
  } shapes[] = {{13, 17, 2}, {16, 16, 3}, {9, 31, 4}, {40, 37, 4}, {20, 11, 5}, {7, 8, 6},
                {15, 15, 7}, {12, 19, 9}, {1, 1, 3},  {2, 40, 4},  {48, 66, 3}};
  // The reference skips nothing; the one-cell sweep that skips runs on any CPU, the eight-lane
  // one where there is AVX2 (CI's machines have it).
  std::vector<bool> vector_kernels = {false};
  if (haveAvx2()) vector_kernels.push_back(true);
  auto settledGroups = [](Chain& ch) {
    int n = 0;
    for (int p = 0; p < 4; ++p)
      for (int i = 0; i < ch.planes.subRows(); ++i)
        for (int g = 0; g * ColourPlanes::kLanes < ch.planes.subCols(); ++g)
          n += ch.planes.settled(p, i)[g];
    return n;
  };
  int settled_seen = 0;
  for (const auto& sh : shapes)
    for (double fixed : {0.0, 0.2}) {
      const EnergyModel em =
          randomRectModel(sh.rows * 100 + sh.cols + sh.K, sh.rows, sh.cols, sh.K, fixed);
      Chain a = runChain(em, inv_ts, 30, false, false);
      const int settled_ref = settledGroups(a);
      std::vector<uint8_t> la(em.cells(), 0);
      a.planes.extract(em, la);
      for (bool avx2 : vector_kernels) {
        const std::string what = std::to_string(sh.rows) + "×" + std::to_string(sh.cols) +
                                 " K=" + std::to_string(sh.K) + " fixed " + std::to_string(fixed) +
                                 (avx2 ? " avx2" : " one-cell");
        Chain b = runChain(em, inv_ts, 30, avx2);
        EXPECT_EQ(a.changed, b.changed) << what;
        EXPECT_EQ(std::memcmp(&a.energy, &b.energy, sizeof(double)), 0)
            << what << ": " << a.energy << " vs " << b.energy;
        std::vector<uint8_t> lb(em.cells(), 0);
        b.planes.extract(em, lb);
        EXPECT_EQ(la, lb) << what;
        ASSERT_EQ(a.sums.size(), b.sums.size());
        EXPECT_EQ(std::memcmp(a.sums.data(), b.sums.data(), a.sums.size() * sizeof(float)), 0)
            << what;
        // The reference marks the same groups settled at the end (it only does not skip them).
        const int settled_here = settledGroups(b);
        EXPECT_EQ(settled_here, settled_ref) << what;
        settled_seen += settled_here;
      }
    }
  EXPECT_GT(settled_seen, 20);  // the skipping was exercised at all
}

TEST(ColourSweep, RunningEnergyFollowsTheLabelling) {
  // The energy a sweep reports is the change of E of the labels it leaves, for both kernels.
  const EnergyModel em = randomRectModel(3, 21, 18, 4, 0.15);
  for (bool avx2 : {false, true}) {
    if (avx2 && !haveAvx2()) continue;
    std::vector<float> inv_ts(12);
    for (int s = 0; s < 12; ++s) inv_ts[s] = 0.3f * (s + 1);
    const Chain ch = runChain(em, inv_ts, 100, avx2);
    std::vector<uint8_t> lab = em.initial;
    ch.planes.extract(em, lab);
    EXPECT_NEAR(em.energy(em.initial) + ch.energy, em.energy(lab), 1e-3) << "avx2 " << avx2;
    EXPECT_GT(ch.changed.front(), 0);
  }
}

TEST(ColourSweep, TwoCellsAreDrawnFromTheirExactConditionals) {
  // A 1 × 2 grid: the cells are of different colours, so a sweep draws cell 0 given cell 1, then
  // cell 1 given the new cell 0, and the chain's pair frequencies converge to exp(−E/T)/Z.
  EnergyModel em;
  em.resize(1, 2, 3);
  for (int k = 0; k < 3; ++k) em.active[k] = static_cast<LabelId>(k + 1);
  const float u[6] = {0.2f, -0.3f, 0.5f, 0.0f, 0.4f, -0.6f};
  std::copy(u, u + 6, em.unary.begin());
  em.beta = 0.35f;
  em.fixed.assign(2, 0);
  em.initial = {0, 0};
  const double T = 0.8;
  double z = 0, exact[9];
  std::vector<uint8_t> lab(2);
  for (int c = 0; c < 9; ++c) {
    lab = {uint8_t(c / 3), uint8_t(c % 3)};
    z += exact[c] = std::exp(-em.energy(lab) / T);
  }
  for (bool avx2 : {false, true}) {
    if (avx2 && !haveAvx2()) continue;
    ColourPlanes planes;
    planes.assign(em, em.initial);
    ColourSweepParams sp;
    sp.we = 2.f * em.beta;
    sp.wd = 2.f * em.beta_diagonal;
    sp.inv_t = static_cast<float>(1.0 / T);
    sp.avx2 = avx2;
    double e = 0, freq[9] = {};
    const int n = 200000;
    for (int s = 0; s < n; ++s) {
      sp.keys = SweepKeys(11, s);
      colourSweep(planes, sp, e);
      planes.extract(em, lab);
      freq[lab[0] * 3 + lab[1]] += 1.0 / n;
    }
    for (int c = 0; c < 9; ++c)
      EXPECT_NEAR(freq[c], exact[c] / z, 0.005) << "pair " << c << " avx2 " << avx2;
  }
}

TEST(ColourPlanes, LayoutRoundTripsAndNeighboursAreTheGridsNeighbours) {
  for (int rows : {1, 4, 7})
    for (int cols : {1, 2, 9, 18}) {
      EnergyModel em = randomRectModel(rows * 31 + cols, rows, cols, 5, 0.2);
      // Distinct labels per cell would need more than 5; check the neighbour map with a
      // labelling where each cell's label encodes its position modulo 5 in both directions.
      std::vector<uint8_t> lab(em.cells());
      for (int r = 0; r < rows; ++r)
        for (int c = 0; c < cols; ++c) lab[r * cols + c] = uint8_t((r * 2 + c) % 5);
      ColourPlanes cp;
      cp.assign(em, lab);
      std::vector<uint8_t> back(em.cells(), 99);
      cp.extract(em, back);
      for (std::size_t i = 0; i < em.cells(); ++i)
        EXPECT_EQ(back[i], em.fixed[i] ? 99 : lab[i]) << rows << "×" << cols << " cell " << i;
      static const int d[8][2] = {{-1, 0},  {1, 0},  {0, -1}, {0, 1},
                                  {-1, -1}, {-1, 1}, {1, -1}, {1, 1}};
      for (int r = 0; r < rows; ++r)
        for (int c = 0; c < cols; ++c) {
          const int p = 2 * (r & 1) + (c & 1);
          const auto off = cp.neighbourOffsets(p);
          const std::size_t idx = cp.index(r / 2, c / 2);
          for (int n = 0; n < 8; ++n) {
            const int rr = r + d[n][0], cc = c + d[n][1];
            const bool inside = rr >= 0 && rr < rows && cc >= 0 && cc < cols;
            const uint8_t want =
                inside && !em.fixed[rr * cols + cc] ? lab[rr * cols + cc] : uint8_t(5);
            EXPECT_EQ(cp.data()[off[n] + idx], want)
                << rows << "×" << cols << " cell " << r << "," << c << " neighbour " << n;
          }
        }
    }
}

TEST(ColourPlanes, UnsettlingReachesEveryGroupNextToTheChangedLanes) {
  // A group is skipped while it is settled, so a change must unsettle every group that holds a
  // grid neighbour of a changed cell; a group missed here would be skipped with a stale draw.
  // Grids whose planes have several groups per row, every set of changed lanes of every group
  // (the kernels pass their changed lanes as this mask).
  for (const auto& [rows, cols] : {std::pair{9, 37}, std::pair{6, 50}}) {
    const EnergyModel em = randomRectModel(rows * 7 + cols, rows, cols, 3, 0.0);
    ColourPlanes cp;
    cp.assign(em, em.initial);
    auto settleAll = [&] {
      for (int q = 0; q < 4; ++q)
        for (int r = -1; r <= cp.subRows(); ++r)
          for (int h = -1; h * ColourPlanes::kLanes <= cp.subCols() + ColourPlanes::kLanes; ++h)
            cp.settled(q, r)[h] = 1;
    };
    for (int p = 0; p < 4; ++p) {
      const int a = p >> 1, b = p & 1;
      for (int i = 0; 2 * i + a < rows; ++i)
        for (int g = 0; g * ColourPlanes::kLanes < cp.subCols(); ++g)
          for (unsigned moved = 1; moved < 1u << ColourPlanes::kLanes; ++moved) {
            settleAll();
            cp.unsettleNeighbours(p, i, g, moved);
            for (int l = 0; l < ColourPlanes::kLanes; ++l) {
              if (!(moved >> l & 1)) continue;
              const int r = 2 * i + a, c = 2 * (g * ColourPlanes::kLanes + l) + b;
              if (c >= cols) continue;
              for (int dr = -1; dr <= 1; ++dr)
                for (int dc = -1; dc <= 1; ++dc) {
                  const int rr = r + dr, cc = c + dc;
                  if ((dr == 0 && dc == 0) || rr < 0 || rr >= rows || cc < 0 || cc >= cols)
                    continue;
                  const int q = 2 * (rr & 1) + (cc & 1);
                  EXPECT_EQ(cp.settled(q, rr / 2)[(cc / 2) / ColourPlanes::kLanes], 0)
                      << rows << "×" << cols << " plane " << p << " row " << i << " group " << g
                      << " lanes 0x" << std::hex << moved << std::dec << ": neighbour " << rr << ","
                      << cc;
                }
            }
          }
    }
  }
}

}  // namespace
}  // namespace terramrf
