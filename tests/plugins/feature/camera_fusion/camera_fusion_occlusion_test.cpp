// camera_fusion's depth test (occlusion: depth_test) on hand-made frames whose answers follow from
// the geometry: the forward camera of fusion_test_frame.hpp (f = 100 px, principal point (100, 50),
// at the LiDAR origin, so a LiDAR point (x, y, z) lands at u = 100 − 100 y / x, v = 50 − 100 z / x
// with depth x), the flat ground z = −1 and boxes standing on it.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <set>

#include "../../../../plugins/feature/camera_fusion/ring_gap.hpp"
#include "plugins/feature/camera_fusion/fusion_test_frame.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

using test::forwardCamera;
using test::groundFrame;
using test::noFill;
using test::StageRunner;

std::set<uint32_t> cellSet(const CellPixels& cp, int cell) {
  return std::set<uint32_t>(cp.begin(cell), cp.end(cell));
}

/// Points of the vertical face x = `x`, y ∈ [y0, y1], z ∈ [z0, z1], every `dy` and `dz` [m]
/// (ends included).
void addFace(Frame& f, double x, double y0, double y1, double dy, double z0, double z1, double dz) {
  for (double y = y0; y <= y1 + 1e-9; y += dy)
    for (double z = z0; z <= z1 + 1e-9; z += dz)
      f.points.push_back(float(x), float(y), float(z), 0);
}

/// Pixels (u, v) with u ∈ [u0, u1], v ∈ [v0, v1] (inclusive), clipped to the 200 × 100 image.
std::set<uint32_t> rect(int u0, int u1, int v0, int v1) {
  std::set<uint32_t> s;
  for (int v = std::max(0, v0); v <= std::min(99, v1); ++v)
    for (int u = std::max(0, u0); u <= std::min(199, u1); ++u) s.insert(uint32_t(v * 200 + u));
  return s;
}

std::set<uint32_t> minus(const std::set<uint32_t>& a, const std::set<uint32_t>& b) {
  std::set<uint32_t> out;
  std::set_difference(a.begin(), a.end(), b.begin(), b.end(), std::inserter(out, out.end()));
  return out;
}

struct Runs {
  StageRunner none, depth;
};

/// The same frame fused without and with the depth test.
void runBoth(Frame& f, Runs& r, const std::string& depth_params) {
  r.none.add("camera_fusion", "{occlusion: none, max_pixels_per_cell: 100000}");
  r.depth.add("camera_fusion",
              "{occlusion: depth_test, max_pixels_per_cell: 100000, " + depth_params + "}");
  r.none.run(f);
  r.depth.run(f);
}

// A 0.9 m high, 0.8 m wide box face 2.2 m ahead, sampled every 5 mm (< 0.25 px): it projects to
// u ∈ [100 − 40/2.2, 100 + 40/2.2] = [81.8, 118.2], v ∈ [50 + 10/2.2, 50 + 100/2.2] =
// [54.5, 95.5], i.e. the pixel centres u 82..118, v 55..95, and with a splat of 1 px u 81..119,
// v 54..96. All ground from x = 3 m on is more than 20 % farther (2.2 / 3 = 0.73): every ground
// cell behind the box must lose exactly its pixels in that rectangle and keep all others.
void expectBoxHidesItsRectangle(const CameraModel& cam) {
  Frame f = groundFrame(cam, noFill);
  addFace(f, 2.2, -0.4, 0.4, 0.005, -1.0, -0.1, 0.005);
  Runs r;
  runBoth(f, r, "occlusion_margin: 0.2, occlusion_splat_px: 1");
  const TerrainGrid& g = r.none.grid;
  const CellPixels& a = r.none.grid.cellPixels().at(0);
  const CellPixels& b = r.depth.grid.cellPixels().at(0);
  const std::set<uint32_t> box = rect(81, 119, 54, 96);
  const int box_cells[] = {g.index(0, 3), g.index(0, 4)};  // box and ground share these
  std::size_t hidden_px = 0, kept_cells = 0, hidden_cells = 0;
  for (int c = 0; c < int(g.cells()); ++c) {
    if (std::count(std::begin(box_cells), std::end(box_cells), c)) continue;
    const std::set<uint32_t> all = cellSet(a, c), got = cellSet(b, c);
    const std::set<uint32_t> expect = minus(all, box);
    EXPECT_EQ(got, expect) << "cell " << c << " (row " << c / g.cols() << ", col " << c % g.cols()
                           << ")";
    hidden_px += all.size() - expect.size();
    kept_cells += expect.size() == all.size();
    hidden_cells += expect.empty() && !all.empty();
  }
  // The geometry has cells of every kind: untouched, partly and wholly hidden.
  EXPECT_GT(hidden_px, 800u);
  EXPECT_GT(kept_cells, 30u);
  EXPECT_GE(hidden_cells, 4u);
  // Without the test the hidden pixels stay with the ground cells; with it they are counted.
  EXPECT_EQ(r.none.ctx.metrics.count("camera_fusion.front.occluded_pixels"), 0u);
  const double occluded = r.depth.ctx.metrics.at("camera_fusion.front.occluded_pixels");
  // Also counted: what the box cells lost, and the point pixels hidden cells fell back to.
  EXPECT_GE(occluded, double(hidden_px));
  EXPECT_GE(occluded, double(a.pixels.size() - b.pixels.size()));
  EXPECT_GE(r.depth.ctx.metrics.at("camera_fusion.front.hidden_cells"), double(hidden_cells));
  EXPECT_GE(r.depth.ctx.metrics.at("camera_fusion.front.occluded_cells"),
            double(g.cells() - 2 - kept_cells));
}

TEST(CameraFusionOcclusion, GroundBehindABoxLosesExactlyThePixelsTheBoxCovers) {
  expectBoxHidesItsRectangle(forwardCamera());
}

TEST(CameraFusionOcclusion, SameAnswerThroughTheDistortionPath) {
  // A distortion too small to move any pixel still takes the per-point projection and the
  // least-squares inverse depth of the footprint instead of the exact plane.
  CameraModel cam = forwardCamera();
  cam.distortion = {1e-12, 0, 0, 0, 0};
  expectBoxHidesItsRectangle(cam);
}

TEST(CameraFusionOcclusion, NothingInFrontKeepsEveryPixel) {
  // Flat ground only: every ground point is nearer than the cells behind it, but never by 20 %
  // at a pixel its splat reaches, so no pixel is dropped and both modes agree exactly.
  Frame f = groundFrame(forwardCamera(), noFill);
  for (int splat : {0, 1, 2}) {
    Runs r;
    runBoth(f, r, "occlusion_splat_px: " + std::to_string(splat));
    EXPECT_EQ(r.none.grid.cellPixels().at(0).pixels, r.depth.grid.cellPixels().at(0).pixels);
    EXPECT_EQ(r.none.grid.cellPixels().at(0).offsets, r.depth.grid.cellPixels().at(0).offsets);
    EXPECT_EQ(r.depth.ctx.metrics.at("camera_fusion.front.occluded_pixels"), 0.0);
    EXPECT_EQ(r.depth.ctx.metrics.at("camera_fusion.front.hidden_cells"), 0.0);
  }
}

// A cell's own points never hide its pixels: they are what the cell looks like. Cell (3, 4)
// (x ∈ [5, 6], y ∈ [0, 1]) with a wall at its near edge, x = 5.05, y ∈ [0.1, 0.9], z ∈ [−1, 0]:
// its ground footprint (footprint_height: min) covers rows v = 67, 68, 69 (depth 5.9, 5.6, 5.3 m),
// where the wall (u 82..98) is nearer by 14 %, 10 %, 5 %: row 67 would go at margin 0.1 if the
// wall were another cell's. The cells behind the wall do lose the pixels it covers.
TEST(CameraFusionOcclusion, ACellsOwnPointsNeverHideItsPixels) {
  Frame f = groundFrame(forwardCamera(), noFill);
  addFace(f, 5.05, 0.1, 0.9, 0.005, -1.0, 0.0, 0.005);
  Runs r;
  r.none.add("camera_fusion", "{occlusion: none, footprint_height: min}");
  r.depth.add("camera_fusion",
              "{footprint_height: min, occlusion_margin: 0.1, occlusion_splat_px: 0}");
  r.none.run(f);
  r.depth.run(f);
  const TerrainGrid& g = r.none.grid;
  const int cell = g.index(3, 4);
  const auto own = cellSet(r.none.grid.cellPixels()[0], cell);
  ASSERT_EQ(own.size(), 54u);
  EXPECT_EQ(cellSet(r.depth.grid.cellPixels()[0], cell), own);
  const int behind = g.index(5, 4);  // x ∈ [7, 8]: rows 63, 64, u 88..99 behind the wall
  EXPECT_LT(r.depth.grid.cellPixels()[0].count(behind), r.none.grid.cellPixels()[0].count(behind));
}

// The margin at its boundary. A plate at depth 5.02 m covers u 94..106 of ground cell row 4
// (x ∈ [6, 7]), whose pixel rows are v = 65 (ground depth 100 / 15 = 6.667 m: ratio 0.753) and
// v = 66 (6.25 m: ratio 0.803). A pixel is dropped when the ratio is below 1 − margin.
TEST(CameraFusionOcclusion, MarginDecidesPixelByPixel) {
  Frame f = groundFrame(forwardCamera(), noFill);
  // v = 50 + 100 · (−z) / 5.02: z ∈ [−0.88, −0.72] gives v ∈ [64.3, 67.5]; y ∈ ±0.3: u ∈ [94, 106].
  addFace(f, 5.02, -0.3, 0.3, 0.005, -0.88, -0.72, 0.005);
  const std::set<uint32_t> plate = rect(94, 106, 64, 68);
  struct Case {
    double margin;
    std::set<int> dropped_rows;
  };
  for (const Case& k : {Case{0.1, {65, 66}}, Case{0.19, {65, 66}}, Case{0.2, {65}},
                        Case{0.24, {65}}, Case{0.25, {}}, Case{0.5, {}}}) {
    Runs r;
    runBoth(f, r, "occlusion_splat_px: 0, occlusion_margin: " + std::to_string(k.margin));
    const TerrainGrid& g = r.none.grid;
    std::size_t dropped = 0;
    for (int col : {3, 4}) {
      const int c = g.index(4, col);
      const std::set<uint32_t> all = cellSet(r.none.grid.cellPixels()[0], c);
      std::set<uint32_t> expect;
      for (uint32_t p : all)
        if (!(plate.count(p) && k.dropped_rows.count(int(p / 200)))) expect.insert(p);
      EXPECT_EQ(cellSet(r.depth.grid.cellPixels()[0], c), expect)
          << "margin " << k.margin << " col " << col;
      dropped += all.size() - expect.size();
    }
    EXPECT_EQ(dropped, 13u * k.dropped_rows.size()) << "margin " << k.margin;
  }
}

// The splat bridges the gaps between a scanner's rings. The box of the first test, sampled as
// rings 4 px apart (dz = 0.088 m at 2.2 m): v = 54.5, 58.5, …, 94.5, dense along each ring.
TEST(CameraFusionOcclusion, SplatBridgesTheGapsBetweenRings) {
  Frame f = groundFrame(forwardCamera(), noFill);
  addFace(f, 2.2, -0.4, 0.4, 0.005, -0.98, -0.1, 0.088);  // 11 rings, v = 94.55 − 4 k
  for (int splat : {0, 1, 2}) {
    Runs r;
    runBoth(f, r, "occlusion_splat_px: " + std::to_string(splat));
    const TerrainGrid& g = r.none.grid;
    // The rings hit pixel rows round(54.545 + 4 k) = 55 + 4 k, k = 0 … 10; with splat s rows
    // 55 + 4k − s … 55 + 4k + s. Splat 0 and 1 leave gaps, 2 closes them (2 · 2 + 1 ≥ 4).
    std::set<uint32_t> covered;
    for (int k = 0; k <= 10; ++k) {
      const auto band = rect(82 - splat, 118 + splat, 55 + 4 * k - splat, 55 + 4 * k + splat);
      covered.insert(band.begin(), band.end());
    }
    if (splat == 2) EXPECT_EQ(covered, rect(80, 120, 53, 97));
    const CellPixels& b = r.depth.grid.cellPixels()[0];
    int fell_back = 0;
    for (int c = 0; c < int(g.cells()); ++c) {
      if (c / g.cols() == 0) continue;  // box cells; ground from x = 3 m on only
      std::set<uint32_t> expect = minus(cellSet(r.none.grid.cellPixels()[0], c), covered);
      if (expect.empty()) {
        // Footprint wholly hidden: the cell's points seen through the gaps between the rings.
        std::set<uint32_t> own;
        for (const uint32_t* it = g.pointsBegin(c); it != g.pointsEnd(c); ++it)
          if (b.pixel_of_point[*it] >= 0) own.insert(uint32_t(b.pixel_of_point[*it]));
        expect = minus(own, covered);
        fell_back += !expect.empty();
      }
      EXPECT_EQ(cellSet(b, c), expect) << "splat " << splat << " cell " << c;
    }
    if (splat == 1) EXPECT_GT(fell_back, 0);  // e.g. row 6 (x ∈ [8, 9]): its points at v = 61
    if (splat == 2) EXPECT_EQ(fell_back, 0);
  }
}

// The splat has a plain and an AVX2 version (four keys per instruction, the rest one by one):
// both give the same pixels, for splats narrower and wider than four keys, and the wide ones hide
// more than the narrow ones.
TEST(CameraFusionOcclusion, SplatIsTheSameOnEveryInstructionSet) {
  Frame f = groundFrame(forwardCamera(), noFill);
  addFace(f, 2.2, -0.4, 0.4, 0.005, -0.98, -0.1, 0.088);
  std::size_t previous = std::numeric_limits<std::size_t>::max();
  for (int splat : {1, 2, 3, 7, 16}) {
    const std::string params =
        "{occlusion: depth_test, max_pixels_per_cell: 100000, "
        "occlusion_splat: fixed, occlusion_splat_px: " +
        std::to_string(splat) + "}";
    StageRunner wide, plain;
    wide.add("camera_fusion", params);
    plain.add("camera_fusion", params);
    wide.run(f);
    {
      test::ScopedEnv sse2("TERRAMRF_SIMD", "sse2");
      plain.run(f);
    }
    const CellPixels& a = wide.grid.cellPixels()[0];
    const CellPixels& b = plain.grid.cellPixels()[0];
    EXPECT_EQ(a.offsets, b.offsets) << "splat " << splat;
    EXPECT_EQ(a.pixels, b.pixels) << "splat " << splat;
    EXPECT_LT(a.pixels.size(), previous) << "splat " << splat;
    previous = a.pixels.size();
  }
}

// A cell whose footprint is wholly hidden falls back to its points' pixels, which the depth test
// drops too (they lie behind the box): the cell ends with no pixels and is counted as hidden.
TEST(CameraFusionOcclusion, HiddenCellsGetNoPixelsNotTheOccludersPixels) {
  Frame f = groundFrame(forwardCamera(), noFill);
  addFace(f, 2.2, -0.4, 0.4, 0.005, -1.0, -0.1, 0.005);
  Runs r;
  runBoth(f, r, "occlusion_splat_px: 1");
  const TerrainGrid& g = r.none.grid;
  const int far = g.index(7, 4);  // x ∈ [9, 10], y ∈ [0, 1]: u ∈ [88.9, 100], v ∈ [60, 61.1]
  EXPECT_GT(r.none.grid.cellPixels()[0].count(far), 0u);
  EXPECT_EQ(r.depth.grid.cellPixels()[0].count(far), 0u);
}

// The ring gap estimate: rings 6 px apart, points every 3 px along them, ring ids not in
// elevation order, one ring missing in the right half, and long steps from sky above the top
// ring (the median ignores them). Too few gaps or no ring ids give NaN.
TEST(CameraFusionOcclusion, RingGapIsTheMedianStepBetweenAdjacentRings) {
  const int W = 640, H = 200;
  std::vector<int32_t> pix;
  std::vector<uint16_t> ring;
  const uint16_t ids[] = {7, 3, 9, 1, 4, 8, 2, 6, 5, 0};
  for (int k = 0; k < 10; ++k)
    for (int u = k % 3; u < W; u += 3) {
      if (k == 4 && u >= W / 2) continue;        // a ring without returns there: a 12 px gap
      const int v = 40 + 6 * k + (u / 100) % 2;  // rings dip by a pixel every 100 columns
      pix.push_back(v * W + u);
      ring.push_back(ids[k]);
    }
  pix.push_back(-1);  // not visible
  ring.push_back(0);
  RingGapScratch s;
  EXPECT_DOUBLE_EQ(medianRingGapPx(pix, ring, W, 32, 100, s), 6.0);
  EXPECT_TRUE(std::isnan(medianRingGapPx(pix, ring, W, 32, 1000, s)));  // 20 bands × ≤ 9 gaps
  std::vector<uint16_t> unknown(ring.size(), kUnknownRing);
  EXPECT_TRUE(std::isnan(medianRingGapPx(pix, unknown, W, 32, 1, s)));
  EXPECT_TRUE(std::isnan(medianRingGapPx(pix, {}, W, 32, 1, s)));
  // The splat whose square spans the gap, to the nearest pixel, within [0, max].
  EXPECT_EQ(splatForGap(5.0, 16), 2);  // KITTI HDL-64E in image_2
  EXPECT_EQ(splatForGap(5.1, 16), 2);
  EXPECT_EQ(splatForGap(2.7, 16), 1);    // the simulator
  EXPECT_EQ(splatForGap(25.7, 16), 12);  // RELLIS-3D's Ouster in its 1920 px camera
  EXPECT_EQ(splatForGap(80, 16), 16);
  EXPECT_EQ(splatForGap(0.5, 16), 0);
}

// occlusion_splat: ring_gap measures the gap of the frame: a wall filling the image, scanned as
// rings 4 px apart, gives a 4 px gap (4 bands of 64 px × 23 gaps), a 2 px splat (2 · 2 + 1 ≥ 4),
// and the same pixels as a fixed 2 px splat. Without ring ids it falls back to
// occlusion_splat_px.
TEST(CameraFusionOcclusion, RingGapSplatFollowsTheScansRingSpacing) {
  Frame f = groundFrame(forwardCamera(), noFill);
  uint16_t k = 0;
  for (double z = -1.1; z <= 1.1; z += 0.088, ++k)  // v = 50 − 100 z / 2.2: 4 px per ring
    for (double y = -2.3; y <= 2.3; y += 0.005) f.points.push_back(2.2f, float(y), float(z), 0, k);
  StageRunner fixed2, gap;
  fixed2.add("camera_fusion", "{occlusion_splat: fixed, occlusion_splat_px: 2}");
  gap.add("camera_fusion", "{occlusion_splat: ring_gap, occlusion_splat_px: 0}");
  fixed2.run(f);
  gap.run(f);
  EXPECT_DOUBLE_EQ(gap.ctx.metrics.at("camera_fusion.front.ring_gap_px"), 4.0);
  EXPECT_EQ(gap.ctx.metrics.at("camera_fusion.front.splat_px"), 2);
  const CellPixels &a = fixed2.grid.cellPixels()[0], &b = gap.grid.cellPixels()[0];
  EXPECT_EQ(a.pixels, b.pixels);
  EXPECT_EQ(a.offsets, b.offsets);
  EXPECT_EQ(gap.ctx.metrics.at("camera_fusion.front.occluded_pixels"),
            fixed2.ctx.metrics.at("camera_fusion.front.occluded_pixels"));
  // No ring ids: the fixed half-width.
  for (auto& r : f.points.ring) r = kUnknownRing;
  StageRunner fallback;
  fallback.add("camera_fusion", "{occlusion_splat: ring_gap, occlusion_splat_px: 1}");
  fallback.run(f);
  EXPECT_EQ(fallback.ctx.metrics.at("camera_fusion.front.splat_px"), 1);
  EXPECT_TRUE(std::isnan(fallback.ctx.metrics.at("camera_fusion.front.ring_gap_px")));
}

TEST(CameraFusionOcclusion, RejectsBadParameters) {
  StageRunner r;
  EXPECT_THROW(r.add("camera_fusion", "{occlusion: zbuffer}"), std::runtime_error);
  EXPECT_THROW(r.add("camera_fusion", "{occlusion_margin: 1.0}"), std::runtime_error);
  EXPECT_THROW(r.add("camera_fusion", "{occlusion_margin: -0.1}"), std::runtime_error);
  EXPECT_THROW(r.add("camera_fusion", "{occlusion_splat_px: -1}"), std::runtime_error);
  EXPECT_THROW(r.add("camera_fusion", "{occlusion_splat_px: 17}"), std::runtime_error);
  EXPECT_THROW(r.add("camera_fusion", "{occlusion_splat: auto}"), std::runtime_error);
}

}  // namespace
}  // namespace terramrf
