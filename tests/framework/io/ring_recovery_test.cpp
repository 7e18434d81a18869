#include "terramrf/io/ring_recovery.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "io_test_util.hpp"
#include "terramrf/io/kitti.hpp"
#include "terramrf/io/sensor_origin.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

using test::readDataScan;
using test::seq00Scan;

/// Mean elevation [deg] per ring (NaN for empty rings).
std::vector<double> meanElevation(const PointCloud& c, int rings) {
  std::vector<double> sum(rings, 0), n(rings, 0);
  for (std::size_t i = 0; i < c.size(); ++i) {
    if (c.ring[i] >= rings) continue;
    sum[c.ring[i]] += std::atan2(c.z[i], std::hypot(c.x[i], c.y[i])) * 180 / M_PI;
    n[c.ring[i]] += 1;
  }
  for (int k = 0; k < rings; ++k) sum[k] = n[k] ? sum[k] / n[k] : NAN;
  return sum;
}

PointCloud permuted(const PointCloud& c, const std::vector<std::size_t>& order) {
  PointCloud o;
  o.reserve(order.size());
  for (std::size_t i : order)
    o.push_back(c.x[i], c.y[i], c.z[i], c.intensity[i], c.ring.empty() ? kUnknownRing : c.ring[i]);
  return o;
}

double agreement(const std::vector<uint16_t>& a, const std::vector<uint16_t>& b, int tol = 0) {
  std::size_t ok = 0;
  for (std::size_t i = 0; i < a.size(); ++i) ok += std::abs(int(a[i]) - int(b[i])) <= tol;
  return double(ok) / a.size();
}

TEST(RingRecovery, KittiSeq00Frame0Has64RingsFromScanOrder) {
  PointCloud c = readDataScan(seq00Scan(0));
  const RingRecoveryStats st = recoverRings(c);  // its time: BM_RecoverRings
  std::printf("ring recovery, 124668 points: elevation consistency %.3f\n",
              st.elevation_consistency);
  EXPECT_EQ(st.method, RingMethod::kScanOrder) << st.fallback_reason;
  EXPECT_EQ(st.segments, 64);
  EXPECT_EQ(st.rings_found, 64);
  EXPECT_EQ(st.missing_rings, 0);
  EXPECT_GT(st.ordered_fraction, 0.95);
  ASSERT_TRUE(c.hasRing());
  const auto mean = meanElevation(c, 64);
  for (int k = 0; k + 1 < 64; ++k) EXPECT_GT(mean[k], mean[k + 1]) << "ring " << k;
  // HDL-64E: top beam ~+2°, bottom ~-24.8°; points seen from the origin sit ~0.2 m low.
  EXPECT_NEAR(mean[0], 2.3, 0.6);
  EXPECT_NEAR(mean[63], -24.5, 1.5);
  // Rings are contiguous runs in the file, top first.
  EXPECT_EQ(c.ring.front(), 0);
  EXPECT_EQ(c.ring.back(), 63);
  EXPECT_TRUE(std::is_sorted(c.ring.begin(), c.ring.end()));
  EXPECT_GT(st.elevation_consistency, 0.4);
}

// elevation_consistency is computed without a search per point (each point is tested against its
// own ring's sorted neighbours); check it against the plain definition, on scan-order rings and on
// shuffled points (elevation binning, no runs).
TEST(RingRecovery, ElevationConsistencyMatchesNearestMedian) {
  auto reference = [](const PointCloud& c, const RingRecoveryStats& st) {
    const auto& med = st.ring_median_elevation_deg;
    std::size_t good = 0;
    for (std::size_t i = 0; i < c.size(); ++i) {
      const double e = std::atan2(c.z[i], std::hypot(c.x[i], c.y[i])) * 180 / M_PI;
      int best = -1;
      double bd = 1e9;
      for (int k = 0; k < int(med.size()); ++k)
        if (std::isfinite(med[k]) && std::fabs(e - med[k]) < bd)
          bd = std::fabs(e - med[k]), best = k;
      good += best == c.ring[i];
    }
    return double(good) / c.size();
  };
  PointCloud c = readDataScan(seq00Scan(0));
  const RingRecoveryStats st = recoverRings(c);
  ASSERT_EQ(st.method, RingMethod::kScanOrder);
  // The library's polynomial atan2 and tie rule differ from the reference by ~1e-5 rad.
  EXPECT_NEAR(st.elevation_consistency, reference(c, st), 0.002);
  std::vector<std::size_t> order(c.size());
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), std::mt19937(11));
  PointCloud sh = permuted(c, order);
  const RingRecoveryStats ss = recoverRings(sh);
  ASSERT_EQ(ss.method, RingMethod::kElevation);
  EXPECT_NEAR(ss.elevation_consistency, reference(sh, ss), 0.002);
  EXPECT_GT(ss.elevation_consistency, 0.9);  // binning puts every point at its nearest centre

  // Readers skip the measurement; the rings and the other statistics stay as they are.
  RingRecoveryOptions quick;
  quick.measure_consistency = false;
  for (const auto& [cloud, with] : {std::pair(c, st), std::pair(sh, ss)}) {
    PointCloud again = cloud;
    const RingRecoveryStats without = recoverRings(again, quick);
    EXPECT_TRUE(std::isnan(without.elevation_consistency));
    EXPECT_EQ(again.ring, cloud.ring);
    EXPECT_EQ(without.method, with.method);
    EXPECT_EQ(without.segments, with.segments);
    EXPECT_EQ(without.monotonic_violations, with.monotonic_violations);
  }
}

TEST(RingRecovery, EveryKittiScanOfTheDataIsRingOrdered) {
  std::vector<std::string> scans;
  for (int i = 0; i < 6; ++i) scans.push_back(seq00Scan(i));
  scans.push_back("kitti_object_fusion/training/velodyne/000000.bin");
  scans.push_back("kitti_object_fusion/training/velodyne/000001.bin");
  for (const auto& s : scans) {
    PointCloud c = readDataScan(s);
    const RingRecoveryStats st = recoverRings(c);
    EXPECT_EQ(st.method, RingMethod::kScanOrder) << s << ": " << st.fallback_reason;
    EXPECT_EQ(st.rings_found, 64) << s;
    EXPECT_EQ(st.monotonic_violations, 0) << s;
  }
}

TEST(RingRecovery, ShuffledKittiFallsBackToElevationBinning) {
  double acc_sum = 0, within1_sum = 0;
  const char* scans[] = {"semantickitti_seq00_000000-000005/sequences/00/velodyne/000000.bin",
                         "semantickitti_seq00_000000-000005/sequences/00/velodyne/000003.bin",
                         "kitti_object_fusion/training/velodyne/000000.bin",
                         "kitti_object_fusion/training/velodyne/000001.bin"};
  for (const char* s : scans) {
    PointCloud c = readDataScan(s);
    recoverRings(c);
    std::vector<std::size_t> order(c.size());
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), std::mt19937(42));
    PointCloud sh = permuted(c, order);
    const std::vector<uint16_t> truth = sh.ring;
    RingRecoveryOptions o;
    o.z_offset_m = 0.2;  // KITTI HDL-64E
    const RingRecoveryStats st = recoverRings(sh, o);
    EXPECT_EQ(st.method, RingMethod::kElevation);
    EXPECT_LT(st.ordered_fraction, 0.2);
    EXPECT_FALSE(st.fallback_reason.empty());
    const double acc = agreement(sh.ring, truth), w1 = agreement(sh.ring, truth, 1);
    std::printf("elevation binning on shuffled %s: exact %.3f, within one ring %.3f\n", s, acc, w1);
    EXPECT_GT(acc, 0.45) << s;
    EXPECT_GT(w1, 0.5) << s;
    acc_sum += acc;
    within1_sum += w1;
  }
  std::printf("elevation binning, mean over 4 KITTI scans: exact %.3f, within one %.3f\n",
              acc_sum / 4, within1_sum / 4);
}

TEST(RingRecovery, ReversedOrderStillGivesTopRingZero) {
  PointCloud c = readDataScan(seq00Scan(1));
  recoverRings(c);
  std::vector<std::size_t> order(c.size());
  std::iota(order.rbegin(), order.rend(), 0);
  PointCloud rev = permuted(c, order);
  const std::vector<uint16_t> truth = rev.ring;
  const RingRecoveryStats st = recoverRings(rev);
  EXPECT_EQ(st.method, RingMethod::kScanOrder) << st.fallback_reason;
  EXPECT_GT(agreement(rev.ring, truth), 0.9999);
}

// A cloud whose file begins mid-ring (rotated in memory, a recording cut mid-sweep): every
// azimuth run then holds the end of one ring and the start of the next, and the top ring is not
// the first. Before ringStartAzimuth() and the cyclic ordering, rotations past a few degrees gave
// agreement 0.49 (a quarter turn in) down to 0 (every id shifted).
TEST(RingRecovery, FileBeginningMidRingOrMidSweepGetsTheSameRings) {
  PointCloud c = readDataScan(seq00Scan(0));
  recoverRings(c);
  const std::size_t n = c.size();
  for (const bool reversed : {false, true}) {
    for (const double fraction : {0.008, 0.1, 0.3, 0.5, 0.75, 0.97}) {
      std::vector<std::size_t> order(n);
      std::iota(order.begin(), order.end(), 0);
      if (reversed) std::reverse(order.begin(), order.end());
      std::rotate(order.begin(), order.begin() + std::size_t(fraction * n), order.end());
      PointCloud r = permuted(c, order);
      const std::vector<uint16_t> truth = r.ring;
      const RingRecoveryStats st = recoverRings(r);
      EXPECT_EQ(st.method, RingMethod::kScanOrder) << st.fallback_reason;
      EXPECT_EQ(st.rings_found, 64);
      EXPECT_GT(agreement(r.ring, truth), 0.9999)
          << (reversed ? "reversed, " : "") << "file begins " << fraction << " of the way in";
    }
  }
  // Beginning exactly where a ring begins, mid-sweep: no ring is split, none is merged.
  {
    const std::size_t at = std::find(c.ring.begin(), c.ring.end(), 20) - c.ring.begin();
    std::vector<std::size_t> order(n);
    std::iota(order.begin(), order.end(), 0);
    std::rotate(order.begin(), order.begin() + at, order.end());
    PointCloud r = permuted(c, order);
    const std::vector<uint16_t> truth = r.ring;
    recoverRings(r);
    EXPECT_GT(agreement(r.ring, truth), 0.9999) << "file begins at the start of ring 20";
  }
  // Mid-ring, with the top ring missing (open sky): 64 runs, one of them the split ring's end.
  {
    std::vector<std::size_t> order;
    for (std::size_t i = 0; i < n; ++i)
      if (c.ring[i] != 0) order.push_back(i);
    std::rotate(order.begin(), order.begin() + order.size() / 3, order.end());
    PointCloud r = permuted(c, order);
    const std::vector<uint16_t> truth = r.ring;
    const RingRecoveryStats st = recoverRings(r);
    EXPECT_EQ(st.missing_rings, 1);
    EXPECT_GT(agreement(r.ring, truth), 0.9999) << "top ring missing, file begins a third in";
  }
}

TEST(RingRecovery, RingsWithoutReturnsKeepTheirIds) {
  PointCloud c = readDataScan(seq00Scan(2));
  recoverRings(c);
  // The top beam (open sky) and a hole of two neighbouring rings are placed by elevation.
  for (const std::vector<int>& gone : {std::vector<int>{0}, std::vector<int>{20, 21},
                                       std::vector<int>{0, 1}, std::vector<int>{0, 44, 45}}) {
    std::vector<std::size_t> keep;
    for (std::size_t i = 0; i < c.size(); ++i)
      if (std::find(gone.begin(), gone.end(), c.ring[i]) == gone.end()) keep.push_back(i);
    PointCloud sub = permuted(c, keep);
    const std::vector<uint16_t> truth = sub.ring;
    const RingRecoveryStats st = recoverRings(sub);
    EXPECT_EQ(st.method, RingMethod::kScanOrder) << st.fallback_reason;
    EXPECT_EQ(st.segments, 64 - int(gone.size()));
    EXPECT_EQ(st.missing_rings, int(gone.size()));
    EXPECT_GT(agreement(sub.ring, truth), 0.9999)
        << "removed ring " << gone[0] << " and " << gone.size() - 1 << " more";
  }
}

TEST(RingRecovery, LonePointAcrossTheCutDoesNotSplitARing) {
  PointCloud c = readDataScan(seq00Scan(0));
  recoverRings(c);
  // Put a point at azimuth -10° (just before the sweep start) among the first points of ring 10.
  const std::size_t at = std::find(c.ring.begin(), c.ring.end(), 10) - c.ring.begin() + 3;
  std::vector<std::size_t> order(c.size());
  std::iota(order.begin(), order.end(), 0);
  PointCloud g = permuted(c, order);
  const float r = 20, az = -10 * M_PI / 180;
  g.x.insert(g.x.begin() + at, r * std::cos(az));
  g.y.insert(g.y.begin() + at, r * std::sin(az));
  g.z.insert(g.z.begin() + at, -1.5f);
  g.intensity.insert(g.intensity.begin() + at, 0.f);
  g.ring.insert(g.ring.begin() + at, 10);
  const std::vector<uint16_t> truth = g.ring;
  const RingRecoveryStats st = recoverRings(g);
  EXPECT_EQ(st.segments, 64);
  EXPECT_EQ(agreement(g.ring, truth), 1.0);
}

TEST(RingRecovery, TinyCloudGetsNoRings) {
  PointCloud c = readDataScan("semantickitti_mmdet3d_fixture/sequences/00/velodyne/000000.bin");
  const RingRecoveryStats st = recoverRings(c);
  EXPECT_EQ(st.method, RingMethod::kNone);
  EXPECT_FALSE(c.hasRing());
  PointCloud empty;
  EXPECT_EQ(recoverRings(empty).method, RingMethod::kNone);
}

TEST(RingRecovery, Open3dMlScansAreNotInScanOrder) {
  for (const char* id : {"000700", "000750"}) {
    PointCloud c = readDataScan(
        std::string("semantickitti_o3dml_demo/converted_semantickitti/velodyne/") + id + ".bin");
    const SensorOriginEstimate o = estimateSensorOrigin(c);
    ASSERT_TRUE(o.ok) << o.note;
    translateXY(c, -o.origin_m.x(), -o.origin_m.y());
    RingRecoveryOptions opt;
    opt.z_offset_m = 0.2;
    const RingRecoveryStats st = recoverRings(c, opt);
    EXPECT_EQ(st.method, RingMethod::kElevation) << id;
    EXPECT_LT(st.ordered_fraction, 0.5) << id;
    EXPECT_GE(st.rings_found, 56) << id;
    // Binning puts each ring in its own elevation interval (seen from z = 0.2 m).
    PointCloud lowered = c;
    for (auto& z : lowered.z) z -= 0.2f;
    const auto mean = meanElevation(lowered, 64);
    int inversions = 0;
    for (int k = 0; k + 1 < 64; ++k)
      inversions += std::isfinite(mean[k + 1]) && mean[k + 1] >= mean[k];
    EXPECT_EQ(inversions, 0) << id;
  }
}

TEST(RingRecovery, SimulatorScansWithKnownRings) {
  PluginRegistry reg({test::pluginDir()});
  for (const std::string order : {"ring", "column"}) {
    auto p = reg.create("simulator");
    PluginContext ctx;
    setParams(*p, "{frames: 3, seed: 7, enable_camera: false, point_order: " + order + "}", ctx);
    auto& src = dynamic_cast<Source&>(*p);
    std::size_t total = 0, exact = 0;
    for (std::size_t i = 0; i < src.size(); ++i) {
      Frame f = src.read(i);
      ASSERT_TRUE(f.points.hasRing());
      const std::vector<uint16_t> truth = f.points.ring;
      f.points.ring.clear();
      const RingRecoveryStats st = recoverRings(f.points);
      EXPECT_EQ(st.method, order == "ring" ? RingMethod::kScanOrder : RingMethod::kElevation)
          << st.fallback_reason;
      ASSERT_EQ(f.points.ring.size(), truth.size());
      for (std::size_t k = 0; k < truth.size(); ++k) exact += f.points.ring[k] == truth[k];
      total += truth.size();
    }
    const double acc = double(exact) / total;
    std::printf("simulator, point_order %s: %zu points, rings recovered exactly for %.4f\n",
                order.c_str(), total, acc);
    EXPECT_GT(acc, order == "ring" ? 0.999 : 0.98) << order;
    // Shuffled simulator clouds go through elevation binning.
    if (order == "ring") {
      Frame f = src.read(0);
      std::vector<std::size_t> perm(f.points.size());
      std::iota(perm.begin(), perm.end(), 0);
      std::shuffle(perm.begin(), perm.end(), std::mt19937(3));
      PointCloud sh = permuted(f.points, perm);
      const std::vector<uint16_t> truth = sh.ring;
      const RingRecoveryStats st = recoverRings(sh);
      EXPECT_EQ(st.method, RingMethod::kElevation);
      const double a = agreement(sh.ring, truth);
      std::printf("simulator, shuffled: elevation binning exact for %.4f\n", a);
      EXPECT_GT(a, 0.98);
    }
  }
}

}  // namespace
}  // namespace terramrf
