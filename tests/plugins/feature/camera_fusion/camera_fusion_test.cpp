// camera_fusion on hand-made frames: known projections, known footprints, the pixel cap, the
// point-pixel fallback, several cameras, and every bad-input case naming its file.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>

#include "plugins/feature/camera_fusion/fusion_test_frame.hpp"

namespace terramrf {
namespace {

using test::forwardCamera;
using test::groundFrame;
using test::noFill;
using test::StageRunner;

const CellPixels& only(const TerrainGrid& g) {
  EXPECT_EQ(g.cellPixels().size(), 1u);
  return g.cellPixels().at(0);
}

std::vector<uint32_t> cellSet(const CellPixels& cp, int cell) {
  return std::vector<uint32_t>(cp.begin(cell), cp.end(cell));
}

TEST(CameraFusion, ProjectsKnownPointsToKnownPixels) {
  Frame f = groundFrame(forwardCamera(), noFill);
  f.points.clear();
  f.points.push_back(10, 0, -1, 0);       // cam (0, 1, 10)  → (100, 60)
  f.points.push_back(5, 2, 0, 0);         // cam (−2, 0, 5)  → (60, 50)
  f.points.push_back(-5, 0, 0, 0);        // behind the camera
  f.points.push_back(1, 5, 0, 0);         // cam (−5, 0, 1)  → u = −400: outside
  f.points.push_back(4, -1.99, 0.49, 0);  // cam (1.99, −0.49, 4) → (149.75, 37.75)
  f.points.push_back(10, 1.953, -1, 0);  // cam (−1.953, 1, 10) → (80.47, 60): nearest centre 80
  StageRunner r;
  r.add("camera_fusion");
  r.run(f);
  const CellPixels& cp = only(r.grid);
  EXPECT_EQ(cp.camera, 0);
  EXPECT_EQ(cp.width, 200);
  EXPECT_EQ(cp.height, 100);
  ASSERT_EQ(cp.pixel_of_point.size(), 6u);
  EXPECT_EQ(cp.pixel_of_point[0], 60 * 200 + 100);
  EXPECT_EQ(cp.pixel_of_point[1], 50 * 200 + 60);
  EXPECT_EQ(cp.pixel_of_point[2], -1);
  EXPECT_EQ(cp.pixel_of_point[3], -1);
  EXPECT_EQ(cp.pixel_of_point[4], 38 * 200 + 150);  // pixel centres are at integer coordinates
  EXPECT_EQ(cp.pixel_of_point[5], 60 * 200 + 80);
  EXPECT_EQ(r.ctx.metrics.at("camera_fusion.front.visible_points"), 4.0);
}

TEST(CameraFusion, KittiStyleProjectionWithBaselineAndTranslation) {
  // P2-like: the last column carries f·baseline; the extrinsic has a translation.
  CameraModel m = forwardCamera();
  m.P(0, 3) = 45.0;
  m.T_camera_lidar.translation() = Eigen::Vector3d(0.1, -0.2, -0.3);
  Frame f = groundFrame(m, noFill);
  f.points.clear();
  // cam = R·(10, 0, −1) + t = (0.1, 0.8, 9.7); u = (10 + 970 + 45) / 9.7 = 105.67,
  // v = (80 + 485) / 9.7 = 58.25 → nearest pixel centre (106, 58).
  f.points.push_back(10, 0, -1, 0);
  StageRunner r;
  r.add("camera_fusion");
  r.run(f);
  EXPECT_EQ(only(r.grid).pixel_of_point[0], 58 * 200 + 106);
}

TEST(CameraFusion, PointPixelsMatchCameraModelProject) {
  // The pinhole fast path and the distortion path must agree with CameraModel::project.
  for (double k1 : {0.0, -0.2}) {
    CameraModel m = forwardCamera();
    m.P(0, 3) = 30.0;
    m.distortion = {k1, 0.05 * (k1 != 0), 0.001 * (k1 != 0), -0.002 * (k1 != 0), 0};
    m.T_camera_lidar.translation() = Eigen::Vector3d(0.05, 0.3, -0.1);
    Frame f = groundFrame(m, noFill);
    f.points.clear();
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> ux(-5, 30), uy(-20, 20), uz(-3, 3);
    for (int i = 0; i < 20000; ++i) f.points.push_back(ux(rng), uy(rng), uz(rng), 0);
    StageRunner r;
    r.add("camera_fusion");
    r.run(f);
    const CellPixels& cp = only(r.grid);
    int visible = 0;
    for (std::size_t i = 0; i < f.points.size(); ++i) {
      const auto uv = m.project(Eigen::Vector3d(f.points.x[i], f.points.y[i], f.points.z[i]));
      int expect = -1;
      if (uv && std::lround(uv->x()) < 200 && std::lround(uv->y()) < 100)
        expect = int(std::lround(uv->y())) * 200 + int(std::lround(uv->x()));
      ASSERT_EQ(cp.pixel_of_point[i], expect) << "point " << i << " k1 " << k1;
      visible += expect >= 0;
    }
    EXPECT_GT(visible, 2000) << "k1 " << k1;
  }
}

TEST(CameraModel, PointsBeyondTheDistortionsTurningPointProjectNowhere) {
  // k1 = −0.2: r_d = r (1 − 0.2 r²) grows up to r² = 1/0.6 and then falls. A point at r = 2
  // would land at r_d = 0.4, i.e. u = 140 px, inside the image, though it is 63° off axis.
  CameraModel m;
  m.width = 200;
  m.height = 100;
  m.P << 100, 0, 100, 0,  //
      0, 100, 50, 0,      //
      0, 0, 1, 0;
  m.distortion = {-0.2, 0, 0, 0, 0};
  const auto near = m.project(Eigen::Vector3d(0.3, 0, 1));  // camera frame = LiDAR frame here
  ASSERT_TRUE(near);
  EXPECT_NEAR(near->x(), 100 + 100 * 0.3 * (1 - 0.2 * 0.09), 1e-9);
  EXPECT_FALSE(m.project(Eigen::Vector3d(2.0, 0, 1)));
  EXPECT_FALSE(m.projectUnbounded(Eigen::Vector3d(2.0, 0, 1)));
  EXPECT_TRUE(m.projectUnbounded(Eigen::Vector3d(1.25, 0, 1)));  // r² = 1.5625 < 1.667
  EXPECT_FALSE(m.projectUnbounded(Eigen::Vector3d(1.3, 0, 1)));  // r² = 1.69
  // A k2 > 0 polynomial that dips below zero slope and rises again: the fold in between is
  // found although the slope is positive again at the point itself.
  m.distortion = {-0.5, 0.1, 0, 0, 0};  // g(s) = 1 − 1.5 s + 0.5 s²: negative on (1, 2)
  EXPECT_TRUE(m.projectUnbounded(Eigen::Vector3d(0.9, 0, 1)));
  EXPECT_FALSE(m.projectUnbounded(Eigen::Vector3d(1.2, 0, 1)));
  EXPECT_FALSE(m.projectUnbounded(Eigen::Vector3d(1.8, 0, 1)));  // s = 3.24: g > 0 again
}

// Pixel centres (u, v) strictly inside the convex quad (independent oracle); `on_edge` collects
// those within 1e-9 px of an edge, whose ownership is a convention.
void quadOracle(const std::vector<Eigen::Vector2d>& q, int w, int h, std::set<uint32_t>* inside,
                std::set<uint32_t>* on_edge) {
  double area2 = 0;
  for (int i = 0; i < 4; ++i) {
    const auto& a = q[i];
    const auto& b = q[(i + 1) % 4];
    area2 += a.x() * b.y() - b.x() * a.y();
  }
  const double sgn = area2 > 0 ? 1 : -1;
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const Eigen::Vector2d p(u, v);
      double mind = 1e300;
      bool in = true;
      for (int i = 0; i < 4; ++i) {
        const Eigen::Vector2d e = q[(i + 1) % 4] - q[i], d = p - q[i];
        const double dist = sgn * (e.x() * d.y() - e.y() * d.x()) / e.norm();
        mind = std::min(mind, std::abs(dist));
        in = in && dist > 0;
      }
      const uint32_t idx = uint32_t(v * w + u);
      if (mind < 1e-9)
        on_edge->insert(idx);
      else if (in)
        inside->insert(idx);
    }
}

TEST(CameraFusion, CellFootprintIsTheProjectedQuad) {
  Frame f = groundFrame(forwardCamera(), noFill);
  StageRunner r;
  r.add("camera_fusion", "{max_pixels_per_cell: 1000000}");
  r.run(f);
  const CellPixels& cp = only(r.grid);
  const TerrainGrid& g = r.grid;
  ASSERT_EQ(cp.offsets.size(), g.cells() + 1);

  // Cell (row 3, col 4): x ∈ [5, 6], y ∈ [0, 1] at z = −1 projects to the trapezoid
  // (100, 70) (100, 66.67) (83.33, 66.67) (80, 70), left edge u = 80 + (70 − v): pixel centres
  // in rows 67, 68, 69 from u = 83, 82, 81 to 99 (u = 100 is on the right edge: not inside).
  const int cell = g.index(3, 4);
  std::vector<uint32_t> expect;
  for (int v = 67, u0 = 83; v <= 69; ++v, --u0)
    for (int u = u0; u <= 99; ++u) expect.push_back(uint32_t(v * 200 + u));
  EXPECT_EQ(cellSet(cp, cell), expect);
  EXPECT_EQ(cp.count(cell), 54u);

  // Every cell against the oracle.
  const CameraModel m = forwardCamera();
  for (int c = 0; c < int(g.cells()); ++c) {
    const int row = c / g.cols(), col = c % g.cols();
    const double x0 = 2 + row, y0 = -4 + col;
    std::vector<Eigen::Vector2d> q;
    for (auto [x, y] : {std::pair{x0, y0}, {x0 + 1, y0}, {x0 + 1, y0 + 1}, {x0, y0 + 1}})
      q.push_back(*m.projectUnbounded(Eigen::Vector3d(x, y, -1)));
    std::set<uint32_t> inside, edge;
    quadOracle(q, 200, 100, &inside, &edge);
    const std::vector<uint32_t> got = cellSet(cp, c);
    ASSERT_TRUE(std::is_sorted(got.begin(), got.end()));
    for (uint32_t p : inside)
      ASSERT_TRUE(std::binary_search(got.begin(), got.end(), p)) << "cell " << c << " px " << p;
    for (uint32_t p : got)
      ASSERT_TRUE(inside.count(p) || edge.count(p)) << "cell " << c << " px " << p;
  }
  // Neighbouring footprints tile the image: no pixel belongs to two cells.
  std::vector<uint32_t> all(cp.pixels);
  std::sort(all.begin(), all.end());
  EXPECT_EQ(std::adjacent_find(all.begin(), all.end()), all.end());
}

TEST(CameraFusion, PixelCapShrinksTheFootprintAboutItsCentre) {
  Frame f = groundFrame(forwardCamera(), noFill);
  StageRunner full, capped;
  full.add("camera_fusion", "{max_pixels_per_cell: 1000000}");
  capped.add("camera_fusion", "{max_pixels_per_cell: 20}");
  full.run(f);
  capped.run(f);
  const CellPixels& a = only(full.grid);
  const CellPixels& b = only(capped.grid);
  int shrunk = 0;
  for (int c = 0; c < int(full.grid.cells()); ++c) {
    const auto fa = cellSet(a, c), fb = cellSet(b, c);
    ASSERT_LE(fb.size(), 20u);
    if (fa.size() <= 20) {
      EXPECT_EQ(fa, fb) << "cell " << c;
      continue;
    }
    ++shrunk;
    EXPECT_GE(fb.size(), 10u) << "cell " << c;
    for (uint32_t p : fb) EXPECT_TRUE(std::binary_search(fa.begin(), fa.end(), p));
  }
  EXPECT_GT(shrunk, 10);
  EXPECT_EQ(capped.ctx.metrics.at("camera_fusion.front.capped_cells"), double(shrunk));
  // The 54-pixel cell keeps a block around its centre (90.5, 68.0).
  const auto kept = cellSet(b, capped.grid.index(3, 4));
  double su = 0, sv = 0;
  for (uint32_t p : kept) su += p % 200, sv += p / 200;
  EXPECT_NEAR(su / kept.size(), 90.5, 1.5);
  EXPECT_NEAR(sv / kept.size(), 68.0, 1.0);
}

TEST(CameraFusion, FallsBackToPointPixelsWhereTheFootprintIsEmpty) {
  // Cells of a long grid: x ∈ [0, 1] straddles the camera plane (a corner at z = 0 is behind),
  // x ∈ [60, 61] is thinner than a pixel row (v from 51.64 to 51.67 holds no pixel centre).
  GridGeometry g;
  g.size_m = 128;
  g.cell_m = 1;
  g.centre_m = Eigen::Vector2d(60, 0);  // x ∈ [−4, 124]
  Frame f = groundFrame(forwardCamera(), noFill);
  f.points.clear();
  f.points.push_back(0.9f, 0.f, -0.1f, 0);   // cam (0, 0.1, 0.9) → (100, 61.1)
  f.points.push_back(60.5f, 0.5f, -1.f, 0);  // cam (−0.5, 1, 60.5) → (99.17, 51.65) → (99, 52)
  const int near_cell = g.cellOf(0.9, 0.0);
  const int far_cell = g.cellOf(60.5, 0.5);
  for (const char* mode : {"fallback", "combine", "none"}) {
    StageRunner r(g);
    r.add("camera_fusion", std::string("{point_pixels: ") + mode + "}");
    r.run(f);
    const CellPixels& cp = only(r.grid);
    if (std::string(mode) == "none") {
      EXPECT_EQ(cp.count(near_cell), 0u);
      EXPECT_EQ(cp.count(far_cell), 0u);
      EXPECT_EQ(cp.pixels.size(), 0u);
    } else {
      EXPECT_EQ(cellSet(cp, near_cell), std::vector<uint32_t>{61 * 200 + 100}) << mode;
      EXPECT_EQ(cellSet(cp, far_cell), std::vector<uint32_t>{52 * 200 + 99}) << mode;
    }
  }
}

TEST(CameraFusion, CombineAddsPointPixelsToTheFootprint) {
  Frame f = groundFrame(forwardCamera(), noFill);
  f.points.push_back(5.5f, 0.5f, 1.f, 0);  // a point 2 m above the ground of cell (3, 4)
  StageRunner fb, cb;
  fb.add("camera_fusion", "{footprint_height: min}");
  cb.add("camera_fusion", "{footprint_height: min, point_pixels: combine}");
  fb.run(f);
  cb.run(f);
  const int cell = fb.grid.index(3, 4);
  const auto a = cellSet(only(fb.grid), cell), b = cellSet(only(cb.grid), cell);
  ASSERT_EQ(a.size(), 54u);  // min height: the ground quad
  ASSERT_TRUE(std::is_sorted(b.begin(), b.end()));
  EXPECT_TRUE(std::includes(b.begin(), b.end(), a.begin(), a.end()));
  // cam (−0.5, −1, 5.5) → (90.9, 31.8): the raised point's own pixel joins the set.
  EXPECT_TRUE(std::binary_search(b.begin(), b.end(), uint32_t(32 * 200 + 91)));
}

TEST(CameraFusion, CombineKeepsTheWholeFootprintWhenThePointPixelsPassTheCap) {
  // Cell (3, 4)'s footprint is 54 pixels (rows 64–72); the raised point's pixel lies far above
  // it, at row 32. With a cap of 54 the footprint fills it: the point pixel is left out, not the
  // footprint's last row (cutting the merged, sorted set did that).
  Frame f = groundFrame(forwardCamera(), noFill);
  f.points.push_back(5.5f, 0.5f, 1.f, 0);
  StageRunner alone, tight, roomy;
  alone.add("camera_fusion", "{footprint_height: min}");
  tight.add("camera_fusion",
            "{footprint_height: min, point_pixels: combine, max_pixels_per_cell: 54}");
  roomy.add("camera_fusion", "{footprint_height: min, point_pixels: combine}");
  for (StageRunner* r : {&alone, &tight, &roomy}) r->run(f);
  const int cell = alone.grid.index(3, 4);
  const auto footprint = cellSet(only(alone.grid), cell);
  ASSERT_EQ(footprint.size(), 54u);
  const uint32_t point_px = 32 * 200 + 91;
  EXPECT_EQ(cellSet(only(tight.grid), cell), footprint);
  EXPECT_GE(tight.ctx.metrics.at("camera_fusion.front.capped_cells"), 1.0);
  // Metrics are named after the stage, so two fusion stages of one config do not collide.
  StageRunner named;
  named.add("camera_fusion").setIdentity("fuse_near", "camera_fusion");
  named.run(f);
  EXPECT_EQ(named.ctx.metrics.count("fuse_near.front.pixels"), 1u);
  EXPECT_EQ(named.ctx.metrics.count("camera_fusion.front.pixels"), 0u);
  // Under the default cap every point pixel joins, the raised one among them.
  const auto all = cellSet(only(roomy.grid), cell);
  EXPECT_TRUE(std::includes(all.begin(), all.end(), footprint.begin(), footprint.end()));
  EXPECT_TRUE(std::binary_search(all.begin(), all.end(), point_px));
  // One place more than the footprint: the point pixel nearest the footprint's centre, not the
  // raised one 35 rows above it.
  StageRunner one_more;
  one_more.add("camera_fusion",
               "{footprint_height: min, point_pixels: combine, max_pixels_per_cell: 55}");
  one_more.run(f);
  const auto plus1 = cellSet(only(one_more.grid), cell);
  ASSERT_EQ(plus1.size(), 55u);
  EXPECT_TRUE(std::includes(plus1.begin(), plus1.end(), footprint.begin(), footprint.end()));
  EXPECT_FALSE(std::binary_search(plus1.begin(), plus1.end(), point_px));
}

TEST(CameraFusion, FootprintHeightMeanOrMin) {
  Frame f = groundFrame(forwardCamera(), noFill);
  // Raise every point of cell (3, 4) by 0.5 m except one: mean ≈ −0.53, min = −1.
  for (std::size_t i = 0; i < f.points.size(); ++i)
    if (f.points.x[i] > 5 && f.points.x[i] < 6 && f.points.y[i] > 0 && f.points.y[i] < 1 &&
        !(f.points.x[i] < 5.2f && f.points.y[i] < 0.2f))
      f.points.z[i] = -0.5f;
  StageRunner mean, low;
  mean.add("camera_fusion", "{footprint_height: mean}");
  low.add("camera_fusion", "{footprint_height: min}");
  mean.run(f);
  low.run(f);
  const int cell = mean.grid.index(3, 4);
  EXPECT_EQ(only(low.grid).count(cell), 54u);
  // At z = −0.53 the quad sits higher in the image (v ≈ 58.9 .. 60.6: rows 59, 60), smaller.
  const auto m = cellSet(only(mean.grid), cell);
  ASSERT_FALSE(m.empty());
  EXPECT_LT(m.size(), 54u);
  for (uint32_t p : m) {
    EXPECT_GE(int(p / 200), 59);
    EXPECT_LE(int(p / 200), 60);
  }
}

TEST(CameraFusion, OneCellPixelsPerCamera) {
  CameraModel left = forwardCamera("left");
  // Looks along +y: cam = (x, −z, y).
  Eigen::Matrix3d R;
  R << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  left.T_camera_lidar.linear() = R;
  Frame f = groundFrame(forwardCamera("front"), noFill);
  for (double x = 0.125; x < 4; x += 0.25)
    for (double y = 2.125; y < 6; y += 0.25) f.points.push_back(float(x), float(y), -1.f, 0.f);
  CameraImage second = f.cameras[0];
  second.model = left;
  second.source_path = "/data/left/000007.png";
  f.cameras.push_back(second);
  GridGeometry g;
  g.size_m = 16;
  g.cell_m = 1;
  {
    StageRunner r(g);
    r.add("camera_fusion");
    r.run(f);
    ASSERT_EQ(r.grid.cellPixels().size(), 2u);
    EXPECT_EQ(r.grid.cellPixels()[0].camera, 0);
    EXPECT_EQ(r.grid.cellPixels()[1].camera, 1);
    // A cell left of the vehicle is seen by the left camera only.
    const int c = g.cellOf(1.5, 3.5);
    EXPECT_EQ(r.grid.cellPixels()[0].count(c), 0u);
    EXPECT_GT(r.grid.cellPixels()[1].count(c), 0u);
  }
  {
    StageRunner r(g);
    r.add("camera_fusion", "{cameras: [left]}");
    r.run(f);
    ASSERT_EQ(r.grid.cellPixels().size(), 1u);
    EXPECT_EQ(r.grid.cellPixels()[0].camera, 1);
  }
  {
    StageRunner r(g);
    r.add("camera_fusion", "{cameras: [rear]}");
    try {
      r.run(f);
      FAIL() << "expected InputError";
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), f.source_path);
      EXPECT_NE(std::string(e.what()).find("rear"), std::string::npos) << e.what();
    }
  }
}

// ---- bad input ---------------------------------------------------------------------------------

void expectInputError(Frame& f, const std::string& file, const std::string& needle,
                      const std::string& needle2 = "") {
  StageRunner r;
  r.add("camera_fusion");
  try {
    r.run(f);
    FAIL() << "expected InputError naming " << file;
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), file);
    const std::string what = e.what();
    EXPECT_NE(what.find(file), std::string::npos) << what;
    EXPECT_NE(what.find(needle), std::string::npos) << what;
    EXPECT_NE(what.find(needle2), std::string::npos) << what;
  }
}

const char* kCalib = "/data/calib/000007.txt (P2, R0_rect, Tr_velo_to_cam)";

TEST(CameraFusionBadInput, ImageSizeDiffersFromCalibration) {
  CameraModel m = forwardCamera();
  Frame f = groundFrame(m, noFill);
  f.cameras[0].image = std::make_shared<Image>(100, 100, 3);
  expectInputError(f, "/data/front/000007.png", "100x100", "P and T_camera_lidar");
  f.cameras[0].model.calibration = kCalib;
  expectInputError(f, "/data/front/000007.png", "100x100", kCalib);
}

// The error names the calibration file and entries the source read (CameraModel::calibration),
// not only the image: the calibration is what is wrong.
TEST(CameraFusionBadInput, CalibrationProjectsNothingIntoTheImage) {
  CameraModel m = forwardCamera();
  // Looks backwards (cam z = −x): every point of the scan is behind the camera.
  Eigen::Matrix3d R;
  R << 0, 1, 0, 0, 0, -1, -1, 0, 0;
  m.T_camera_lidar.linear() = R;
  m.calibration = kCalib;
  Frame f = groundFrame(m, noFill);
  expectInputError(f, "/data/front/000007.png", "projects none", kCalib);
  // Points in front but all outside the image (a wildly wrong principal point); a model from no
  // file is named by its own members.
  CameraModel off = forwardCamera();
  off.P(0, 2) = 5000;
  Frame g = groundFrame(off, noFill);
  expectInputError(g, "/data/front/000007.png", "projects none", "(P and T_camera_lidar)");
}

TEST(CameraFusionBadInput, FrameWithoutCamera) {
  Frame f = groundFrame(forwardCamera(), noFill);
  f.cameras.clear();
  expectInputError(f, "/data/velodyne/000007.bin", "no camera");
  f.source_path.clear();
  expectInputError(f, "frame 000007", "no camera");
}

TEST(CameraFusionBadInput, CameraWithoutImage) {
  Frame f = groundFrame(forwardCamera(), noFill);
  f.cameras[0].image.reset();
  expectInputError(f, "/data/front/000007.png", "no image");
}

TEST(CameraFusionParams, RejectsBadValues) {
  StageRunner r;
  EXPECT_THROW(r.add("camera_fusion", "{footprint_height: max}"), std::runtime_error);
  EXPECT_THROW(r.add("camera_fusion", "{point_pixels: all}"), std::runtime_error);
  EXPECT_THROW(r.add("camera_fusion", "{max_pixels_per_cell: 0}"), std::runtime_error);
}

}  // namespace
}  // namespace terramrf
