#pragma once
// How far apart a scan's rings land in a camera image, for sizing the depth test's splat
// (camera_fusion `occlusion_splat: ring_gap`).
//
// The z-buffer of the scan is sparse: each ring crosses an image column once, a few to tens of
// pixels above the next (about 5 px for KITTI's HDL-64E in its 1242 px camera, 26 px for
// RELLIS-3D's Ouster OS1-64 in a 1920 px one). A splat of half-width r closes gaps up to
// 2r + 1 px, so the gap decides the splat a sensor/camera pair needs, and one number for every
// pair would either leave holes (sparse scanners) or smear depth beyond object edges (dense
// ones).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace terramrf {

/// Median vertical distance [px] between vertically adjacent rings in the image. The image is
/// cut into vertical bands `band_px` wide; in each band every ring is placed at the mean row of
/// its points there, these rows are sorted, and each step between consecutive ones is a gap.
/// Bands, not single columns: a ring has a point in a given column only every few columns
/// (2.5 px apart along a KITTI ring, 9 px along a RELLIS-3D one), and a column would see gaps
/// across missing rings. Ring ids need not follow elevation. Occlusion edges and sky make a few
/// long steps, which the median ignores. NaN when fewer than `min_gaps` gaps were seen (few
/// points in the image) or the cloud has no rings. Only every `stride`-th point is read (the
/// cost is one pass over them). `scratch` keeps its capacity between calls.
struct RingGapScratch {
  std::vector<float> row_sum;    // [band][ring]
  std::vector<uint32_t> count;   // [band][ring]
  std::vector<float> rows, gaps;
};

inline double medianRingGapPx(const std::vector<int32_t>& pixel_of_point,
                              const std::vector<uint16_t>& ring, int width, int band_px,
                              std::size_t min_gaps, RingGapScratch& s, std::size_t stride = 1) {
  constexpr uint16_t kNoRing = 0xffff;
  constexpr int kMaxRings = 1024;  // more would be no spinning LiDAR's ring ids
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (ring.size() != pixel_of_point.size() || width <= 0 || band_px <= 0) return nan;
  int rings = 0;
  for (std::size_t i = 0; i < ring.size(); i += stride)
    if (pixel_of_point[i] >= 0 && ring[i] != kNoRing) rings = std::max(rings, ring[i] + 1);
  if (rings == 0 || rings > kMaxRings) return nan;
  const int bands = (width + band_px - 1) / band_px;
  s.row_sum.assign(std::size_t(bands) * rings, 0.f);
  s.count.assign(std::size_t(bands) * rings, 0);
  for (std::size_t i = 0; i < ring.size(); i += stride) {
    const int32_t p = pixel_of_point[i];
    if (p < 0 || ring[i] == kNoRing) continue;
    const std::size_t k = std::size_t((p % width) / band_px) * rings + ring[i];
    s.row_sum[k] += float(p / width);
    ++s.count[k];
  }
  s.gaps.clear();
  for (int b = 0; b < bands; ++b) {
    s.rows.clear();
    for (int r = 0; r < rings; ++r) {
      const std::size_t k = std::size_t(b) * rings + r;
      if (s.count[k]) s.rows.push_back(s.row_sum[k] / s.count[k]);
    }
    std::sort(s.rows.begin(), s.rows.end());
    for (std::size_t j = 1; j < s.rows.size(); ++j) s.gaps.push_back(s.rows[j] - s.rows[j - 1]);
  }
  if (s.gaps.empty() || s.gaps.size() < min_gaps) return nan;
  const auto mid = s.gaps.begin() + s.gaps.size() / 2;
  std::nth_element(s.gaps.begin(), mid, s.gaps.end());
  return *mid;
}

/// The splat half-width [px] whose square spans a gap of `gap_px` (2r + 1 ≈ gap, to the nearest
/// pixel: a measured 5.1 px gap is KITTI's 5 px one), in [0, max_px].
inline int splatForGap(double gap_px, int max_px) {
  return std::clamp(int(std::lround((gap_px - 1) / 2)), 0, max_px);
}

}  // namespace terramrf
