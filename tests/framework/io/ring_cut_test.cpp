// Ring recovery's internals. The cut search: binning only the last 40° first, and every point only
// when the sector bound cannot rule out the earlier bins, must find exactly what binning every
// point finds.
#include "io/ring_cut.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <random>
#include <vector>

#include "io_test_util.hpp"
#include "terramrf/io/kitti.hpp"
#include "terramrf/io/ring_recovery.hpp"
#include "terramrf/simd.hpp"

namespace terramrf::detail {
namespace {

constexpr double kTwoPi = 2 * M_PI;
constexpr int kLast40Deg = kRingCutBins / 9 * 8;

struct Runs {
  std::vector<float> a, el, med;
  std::vector<int> seg;
};

/// `nseg` runs of one turn each, ring s at elevation -0.4 s [deg] with noise; each run ends with
/// the first `head_deg` of the next ring (the rings start head_deg before the runs do), and a
/// share `strays` of points anywhere sit at another ring's elevation (near-range smear).
Runs makeRuns(int nseg, int points, double head_deg, double strays, std::mt19937& rng) {
  std::normal_distribution<float> noise(0.f, 0.05f);
  std::uniform_real_distribution<double> u(0, 1);
  Runs r;
  for (int s = 0; s < nseg; ++s) {
    r.med.push_back(-0.4f * s);
    for (int k = 0; k < points; ++k) {
      const double a = (k + 0.5 * u(rng)) / points * kTwoPi;
      const bool head = a >= kTwoPi * (1 - head_deg / 360) && s + 1 < nseg;
      const int ring = u(rng) < strays ? std::max(0, s + (u(rng) < 0.5 ? -1 : 2))
                       : head          ? s + 1
                                       : s;
      r.a.push_back(static_cast<float>(std::min(a, std::nextafter(kTwoPi, 0.0))));
      r.el.push_back(-0.4f * ring + noise(rng));
      r.seg.push_back(s);
    }
  }
  return r;
}

void expectSameCut(const Runs& r, bool expect_binned_all) {
  // The sector sums run eight points at a time (AVX2) where the CPU has it, else four (SSE2).
  test::widePathRuns();
  for (const bool sse2 : {false, true}) {
    SCOPED_TRACE(sse2 ? "SSE2" : "widest vectors of this CPU");
    std::optional<test::ScopedEnv> env;
    if (sse2) env.emplace("TERRAMRF_SIMD", "sse2");
    const RingCut fast = bestRingCut(r.a, r.el, r.seg, r.med, kLast40Deg);
    const RingCut full = bestRingCut(r.a, r.el, r.seg, r.med, 1);
    EXPECT_EQ(fast.bin, full.bin);
    EXPECT_EQ(fast.gain, full.gain);  // the same sums in the same order, so exactly equal
    EXPECT_EQ(fast.moved, full.moved);
    EXPECT_EQ(fast.binned_all, expect_binned_all);
  }
}

TEST(RingCut, BinningTheLast40DegreesFindsTheCutOfBinningEverything) {
  std::mt19937 rng(7);
  for (double head_deg : {0.0, 2.0, 8.0, 19.0, 35.0}) {
    for (double strays : {0.0, 0.1, 0.4}) {
      SCOPED_TRACE(testing::Message() << "head " << head_deg << "°, strays " << strays);
      const Runs r = makeRuns(16, 2000, head_deg, strays, rng);
      expectSameCut(r, false);
      const RingCut cut = bestRingCut(r.a, r.el, r.seg, r.med, kLast40Deg);
      if (head_deg >= 2) {  // the cut falls where the heads begin, to within a bin or two
        EXPECT_NEAR(cut.bin * 360.0 / kRingCutBins, 360 - head_deg, 0.2);
        EXPECT_LT(cut.gain, -0.1 * double(cut.moved));
      }
    }
  }
}

TEST(RingCut, ACutFurtherBackIsFoundByBinningEverything) {
  // Heads longer than 40°: the sector bound cannot rule out the early bins, every point is
  // binned, and the cut is where the heads begin.
  std::mt19937 rng(11);
  for (double head_deg : {45.0, 90.0, 200.0}) {
    SCOPED_TRACE(testing::Message() << "head " << head_deg << "°");
    const Runs r = makeRuns(16, 2000, head_deg, 0.1, rng);
    expectSameCut(r, true);
    const RingCut cut = bestRingCut(r.a, r.el, r.seg, r.med, kLast40Deg);
    EXPECT_NEAR(cut.bin * 360.0 / kRingCutBins, 360 - head_deg, 0.2);
  }
}

TEST(RingCut, ADipInsideOneSectorIsFound) {
  // Two runs 2° apart (so every delta is the cap, ±1): run 0 holds the first 5° of run 1's ring
  // at its end (the best cut within the last 40°, gain -28), and at 302.2–302.8° a cluster of 300
  // points (at 302.31°, 302.49° and 302.67°) at run 1's elevation. The gain dips there to about
  // -36, below -28, and the points of 300–302.2° lift it again before the 5° sector ends, so only
  // the sector's negative sum shows that the dip may be deeper than the best cut found.
  Runs r;
  r.med = {0.f, -2.f};
  auto add = [&](double deg, float el, int seg) {
    r.a.push_back(static_cast<float>(deg / 360 * kTwoPi));
    r.el.push_back(el);
    r.seg.push_back(seg);
  };
  for (int k = 0; k < 2000; ++k) {
    const double deg = (k + 0.5) * 360 / 2000;
    add(deg, deg >= 355 ? -2.f : 0.f, 0);
    if (deg >= 302.2 && deg < 302.8)
      for (int c = 0; c < 100; ++c) add(deg, -2.f, 0);
  }
  for (int k = 0; k < 2000; ++k) add((k + 0.5) * 360 / 2000, -2.f, 1);
  expectSameCut(r, true);
  const RingCut cut = bestRingCut(r.a, r.el, r.seg, r.med, kLast40Deg);
  EXPECT_NEAR(cut.bin * 360.0 / kRingCutBins, 302.31, 0.05);  // the cluster's first point
}

TEST(RingCut, RunsWithoutAKnownMedianOrANextRunStay) {
  std::mt19937 rng(3);
  Runs r = makeRuns(4, 500, 10, 0, rng);
  // Run 1's median unknown: neither run 0 (its next) nor run 1 may move; run 2 may; run 3 has
  // no next run. Only run 2's head counts.
  r.med[1] = NAN;
  const RingCut cut = bestRingCut(r.a, r.el, r.seg, r.med, kLast40Deg);
  EXPECT_NEAR(cut.bin * 360.0 / kRingCutBins, 350, 0.5);
  EXPECT_NEAR(double(cut.moved), 500 * 10 / 360.0, 4);
}

TEST(RingRecoveryAvx, SameRingsAndMediansAsSse2) {
  // The per-point angles run in AVX where the CPU has it: the same operations on eight lanes
  // must give the same bits as on four.
  PointCloud with_avx = test::readDataScan(test::seq00Scan(0));
  PointCloud with_sse2 = with_avx;
  test::widePathRuns(/*avx2=*/false);
  const RingRecoveryStats a = recoverRings(with_avx);
  test::ScopedEnv sse2("TERRAMRF_SIMD", "sse2");
  ASSERT_FALSE(useAvx());
  const RingRecoveryStats b = recoverRings(with_sse2);
  EXPECT_EQ(a.method, RingMethod::kScanOrder);
  EXPECT_EQ(with_avx.ring, with_sse2.ring);
  ASSERT_EQ(a.ring_median_elevation_deg.size(), b.ring_median_elevation_deg.size());
  for (std::size_t k = 0; k < a.ring_median_elevation_deg.size(); ++k)
    EXPECT_EQ(a.ring_median_elevation_deg[k], b.ring_median_elevation_deg[k]) << "ring " << k;
  EXPECT_EQ(a.elevation_consistency, b.elevation_consistency);
  EXPECT_EQ(a.ordered_fraction, b.ordered_fraction);
}

}  // namespace
}  // namespace terramrf::detail
