#pragma once
// Internals of ring recovery (ring_recovery.cpp), declared here for their tests.
#include <cstddef>
#include <vector>

namespace terramrf::detail {

/// Azimuth bins of the cut search: 0.05°.
constexpr int kRingCutBins = 7200;

struct RingCut {
  int bin = kRingCutBins;   ///< first bin moved on; kRingCutBins if no cut lowers the misfit
  double gain = 0;          ///< change of the summed elevation misfit [deg], <= 0
  std::size_t moved = 0;    ///< points the cut moves on to the next run
  bool binned_all = false;  ///< the early bins could not be ruled out: every point was binned
};

/// The cut c that lowers the summed elevation misfit most when the points of run s at unwrapped
/// azimuth >= c move on to run s + 1, over the runs s whose median med[s] and med[s + 1] are
/// known. a: unwrapped azimuth [rad, in [0, 2π)], el: elevation [deg], seg: run of each point
/// (non-decreasing, runs contiguous). Points in bins >= fine_from_bin are binned; the others are
/// binned only if their 5° sector sums cannot rule out a better cut among them, so the result
/// is that of binning every point (fine_from_bin <= 1) whatever fine_from_bin is.
RingCut bestRingCut(const std::vector<float>& a, const std::vector<float>& el,
                    const std::vector<int>& seg, const std::vector<float>& med, int fine_from_bin);

}  // namespace terramrf::detail
