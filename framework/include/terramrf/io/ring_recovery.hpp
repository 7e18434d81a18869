#pragma once
// Recovers the laser ring of each point of a cloud stored without it (KITTI .bin).
//
// Primary method, scan order: KITTI HDL-64E files store the points ring by ring (top laser
// first); within a ring the azimuth sweeps monotonically through one turn, so the start of the
// next ring shows as the azimuth stepping back by about one turn. Counting those steps gives the
// ring without knowing the sensor's per-laser angles (they differ from the nominal ones by up to
// ~0.3° and each laser sits ~0.2 m off the origin, which smears elevation angles at short range).
// The result is checked against elevation: the median elevation must fall ring by ring.
// A file need not begin where a ring begins (a cloud rotated in memory, a recording cut
// mid-sweep): the azimuth at which the rings really start is found from the elevation step it
// leaves inside every run, and the rings are numbered from the top beam whichever comes first in
// the file. What cannot be told apart: a file that begins within a few degrees of a seam where
// every ring's elevation steps by about a ring spacing (KITTI's HDL-64E scans have one behind the
// car) looks like one that begins at a ring start.
// Fallback, elevation binning: when the order carries no ring structure (shuffled or subsampled
// clouds such as Open3D-ML's .npy scans), each point goes to the nearest peak of the elevation
// histogram (or of a given per-ring table).
#include <cstddef>
#include <string>
#include <vector>

#include "terramrf/point_cloud.hpp"

namespace terramrf {

enum class RingMethod { kNone, kScanOrder, kElevation };
const char* toString(RingMethod m);

struct RingRecoveryOptions {
  int rings = 64;              ///< lasers of the sensor (KITTI HDL-64E: 64)
  bool use_scan_order = true;  ///< false: always bin by elevation
  /// Height of the lasers' optical centre above the cloud origin [m] when computing elevation
  /// angles (KITTI HDL-64E: ~0.2 m, fitted on seq 00). Only elevation binning depends on it.
  double z_offset_m = 0.0;
  /// Optional elevation per ring [deg], ring 0 (top) first; empty = find histogram peaks.
  std::vector<double> elevations_deg;
  /// Clouds with fewer points per ring than this get no rings (method kNone).
  int min_points_per_ring = 8;
  /// Compute RingRecoveryStats::elevation_consistency, a diagnostic pass over every point (about
  /// a tenth of the recovery on an HDL-64E scan); readers, which only need the rings, skip it.
  bool measure_consistency = true;
};

struct RingRecoveryStats {
  RingMethod method = RingMethod::kNone;
  std::size_t points = 0;
  /// Consecutive point pairs whose azimuth steps forward by less than 5° (ring-major order ~0.99,
  /// shuffled ~0.03).
  double ordered_fraction = 0;
  int segments = 0;              ///< azimuth runs found in scan order (0 if not tried)
  int rings_found = 0;           ///< distinct ring ids assigned
  int missing_rings = 0;         ///< rings without any point, inferred from elevation gaps
  int monotonic_violations = 0;  ///< adjacent rings whose median elevation does not fall
  /// Points whose elevation is closer to their own ring's median than to any other ring's; NaN
  /// unless RingRecoveryOptions::measure_consistency.
  double elevation_consistency = 0;
  std::vector<float> ring_median_elevation_deg;  ///< per ring id; NaN if the ring has no point
  std::string fallback_reason;                   ///< why scan order was not used ("" if it was)
};

/// Fills cloud.ring (0 = top beam). With method kNone the ring array is left empty.
RingRecoveryStats recoverRings(PointCloud& cloud, const RingRecoveryOptions& options = {});

}  // namespace terramrf
