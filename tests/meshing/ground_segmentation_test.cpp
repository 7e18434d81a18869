// Image ground segmentation (paper 004 §3.2) on the simulator against its pixel truth, both
// solvers; the real RELLIS-3D example frame against its pixel labels; bad input (camera looking
// away, wrong image format).
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>

#include "sim_scene.hpp"
#include "terramrf/adapters/opencv_image.hpp"
#include "terramrf/errors.hpp"
#include "terramrf/label_set.hpp"
#include "terramrf/meshing/ground_segmentation.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/plugin.hpp"
#include "terramrf/registry.hpp"
#include "test_support.hpp"

namespace terramrf::meshing {
namespace {

using test::SimScene;

const SimScene& scene() {
  static const SimScene s(3);
  return s;
}

// Frames spread over ~70 m of road (buildings, trees, ditch, cars in view).
const std::vector<Frame>& frames() {
  static const std::vector<Frame> f = [] {
    std::vector<Frame> v;
    for (std::size_t i = 0; i < 80; i += 10) v.push_back(scene().frame(i));
    return v;
  }();
  return f;
}

GroundConfusion runAll(MrfMode mode, double* ms_per_image) {
  GroundSegParams p;
  p.mrf.mode = mode;
  GroundConfusion total;
  double ms = 0;
  for (const Frame& f : frames()) {
    const CameraImage& cam = f.cameras.at(0);
    const auto t0 = std::chrono::steady_clock::now();
    const GroundSegmentation g = segmentGround(*cam.image, cam.model, f.points, p, "sim");
    ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    const GroundConfusion c = compareGround(g, *cam.truth);
    std::printf("  frame %s (%s): found %.2f %%, errors %.2f %%, seeds %zu, evaluated %zu\n",
                f.id.c_str(), toString(mode), 100 * c.groundFound(), 100 * c.errorRate(), g.seeds,
                g.evaluated);
    total.add(c);
    // Set TERRAMRF_MESH_DEBUG=<folder> to look at the result: image | segmentation | truth.
    if (const char* dbg = std::getenv("TERRAMRF_MESH_DEBUG")) {
      const Image& im = *cam.image;
      Image out(im.width, im.height * 4, 3);
      for (int v = 0; v < im.height; ++v)
        for (int u = 0; u < im.width; ++u) {
          const uint8_t* px = im.at(u, v);
          const bool sg = g.isGround(u, v);
          const LabelId t = *cam.truth->at(u, v);
          const bool tg = t == 1 || t == 2;
          for (int k = 0; k < 3; ++k) {
            out.at(u, v)[k] = px[k];
            out.at(u, v + im.height)[k] = sg ? (k == 2 ? 255 : px[k] / 2) : px[k];
            const std::size_t q = std::size_t(v) * im.width + u;
            out.at(u, v + 3 * im.height)[k] = g.seed[q] ? (k == 1 ? 255 : 0) : (g.observed[q] ? (k == 2 ? 255 : 0) : 60);
            out.at(u, v + 2 * im.height)[k] =
                tg && !sg ? (k == 2 ? 0 : 255) : (!tg && sg ? (k == 1 ? 0 : 255) : px[k] / 3);
          }
        }
      writeImageAtomic(std::string(dbg) + "/seg_" + toString(mode) + "_" + f.id + ".png", out);
    }
  }
  if (ms_per_image) *ms_per_image = ms / frames().size();
  return total;
}

TEST(GroundSegmentation, FloodFillOnHardSimulatorFrames) {
  double ms = 0;
  const GroundConfusion c = runAll(MrfMode::kFloodFill, &ms);
  std::printf("flood_fill: ground found %.2f %%, errors %.2f %% over %zu px, %.2f ms/image\n",
              100 * c.groundFound(), 100 * c.errorRate(), c.total(), ms);
  // Paper Table 1: 97.68 % / 3.19 %. These 8 frames are spread over buildings, trees and the
  // ditch: 98.4 % / 1.1 % (docs/meshing.md); before the seed cells covered the whole view and
  // ditch floors stopped making their rims "objects", 94.7 % / 3.3 %.
  EXPECT_GE(c.groundFound(), 0.977);
  EXPECT_LE(c.errorRate(), 0.032);
}

TEST(GroundSegmentation, GibbsModeSegmentsToo) {
  double ms = 0;
  const GroundConfusion c = runAll(MrfMode::kGibbs, &ms);
  std::printf("gibbs: ground found %.2f %%, errors %.2f %% over %zu px, %.2f ms/image\n",
              100 * c.groundFound(), 100 * c.errorRate(), c.total(), ms);
  EXPECT_GE(c.groundFound(), 0.977);  // 98.4 % / 1.1 %, as the flood fill
  EXPECT_LE(c.errorRate(), 0.032);
}

TEST(GroundSegmentation, FloodFillDoesLessWorkThanGibbs) {
  const Frame& f = frames()[2];
  GroundSegParams p;
  p.mrf.mode = MrfMode::kFloodFill;
  const auto a = segmentGround(*f.cameras[0].image, f.cameras[0].model, f.points, p);
  p.mrf.mode = MrfMode::kGibbs;
  const auto b = segmentGround(*f.cameras[0].image, f.cameras[0].model, f.points, p);
  EXPECT_LT(a.evaluated * 5, b.evaluated);  // one pass over part of the image vs full sweeps
  std::size_t differ = 0;
  for (std::size_t s = 0; s < a.ground.size(); ++s) differ += a.ground[s] != b.ground[s];
  EXPECT_LT(differ, a.ground.size() / 10);
}

TEST(GroundSegmentation, CameraLookingAwayIsAClearError) {
  const Frame& f = frames().front();
  CameraModel away = f.cameras[0].model;
  // Turn the camera round: it now looks backwards, where the frame's points are cut away.
  PointCloud ahead;
  for (std::size_t i = 0; i < f.points.size(); ++i)
    if (f.points.x[i] > 0) ahead.push_back(f.points.x[i], f.points.y[i], f.points.z[i], 0);
  Eigen::Isometry3d turn = Eigen::Isometry3d::Identity();
  turn.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  away.T_camera_lidar = away.T_camera_lidar * turn;
  try {
    segmentGround(*f.cameras[0].image, away, ahead, GroundSegParams{}, "cam_away.png");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cam_away.png"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no LiDAR point projects"), std::string::npos) << e.what();
  }
}

TEST(GroundSegmentation, GreyImageIsRejected) {
  const Frame& f = frames().front();
  Image grey(f.cameras[0].image->width, f.cameras[0].image->height, 1);
  EXPECT_THROW(segmentGround(grey, f.cameras[0].model, f.points, GroundSegParams{}, "g.png"), InputError);
}

// An image of another size than its camera model would put every projected point on the wrong
// pixel: refused, naming the image and both sizes.
TEST(GroundSegmentation, ImageOfAnotherSizeThanItsCameraIsRejected) {
  const Frame& f = frames().front();
  const Image& img = *f.cameras[0].image;
  Image half(img.width / 2, img.height / 2, 3);
  try {
    segmentGround(half, f.cameras[0].model, f.points, GroundSegParams{}, "half.png");
    FAIL() << "expected an error";
  } catch (const InputError& e) {
    const std::string want = "image is " + std::to_string(img.width / 2) + "x" +
                             std::to_string(img.height / 2) + " px but the camera model says " +
                             std::to_string(img.width) + "x" + std::to_string(img.height);
    EXPECT_NE(std::string(e.what()).find("half.png"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(want), std::string::npos) << e.what();
  }
}

// The real RELLIS-3D example frame (Ouster OS1-64, 1920×1200 camera, off-road: grass, bushes,
// trees, a puddle-covered path), read through the rellis3d source plugin. Truth: the pixel labels
// mapped by configs/label_maps/rellis3d.yaml (grass, puddle, mud, ... = ground; bush, tree, person,
// sky = non-ground).
const Frame& rellis() {
  static const Frame f = [] {
    PluginRegistry reg({test::pluginDir()});
    auto src = reg.create("rellis3d");
    PluginContext ctx;
    ctx.config_dir = test::sourceDir() + "/configs";
    setParams(*src, "{path: " + test::dataPath("rellis3d_example_000104") +
                        ", use_images: true, use_image_labels: true}", ctx);
    return static_cast<Source&>(*src).read(0);
  }();
  return f;
}

GroundSegParams rellisParams() {
  // As configs/mesh_rellis.yaml (the reasons are there).
  GroundSegParams p;
  p.sensor_height_m = 1.45;
  p.fit_ground_plane = true;
  p.seed_max_step_m = 0.35;
  p.lidar_observation_px = 4;
  p.column_fill_px = 40;
  p.column_fill_halfwidth_px = 5;
  p.colour_smooth_px = 4;
  p.colour_band_rows = 64;
  return p;
}

void dumpRellis(const GroundSegmentation& g, const Image& im, const Image& truth, const std::string& dir) {
  // Per RELLIS id: pixels called ground / all.
  const Image raw = readImage(test::dataPath("rellis3d_example_000104/frame000104-1581624663_149.png"));
  std::size_t n[256] = {}, gr[256] = {};
  for (std::size_t s = 0; s < g.ground.size(); ++s) {
    ++n[raw.data[s]];
    gr[raw.data[s]] += g.ground[s];
  }
  for (int k = 0; k < 256; ++k)
    if (n[k]) std::printf("  RELLIS id %3d: %8zu px, called ground %6.2f %%\n", k, n[k], 100.0 * gr[k] / n[k]);
  {
    // Missed ground above the farthest seed of its column (no LiDAR ground return that far).
    std::size_t fn_far = 0, fn = 0;
    for (int u = 0; u < im.width; ++u) {
      int top = im.height;
      for (int v = 0; v < im.height; ++v)
        if (g.seed[std::size_t(v) * im.width + u]) { top = v; break; }
      for (int v = 0; v < im.height; ++v) {
        const std::size_t q = std::size_t(v) * im.width + u;
        const bool tg = truth.data[q] == labels::kRoad || truth.data[q] == labels::kRough;
        if (tg && !g.ground[q]) { ++fn; fn_far += v < top - 30; }
      }
    }
    std::printf("  missed ground %zu px, of which %zu above the farthest seed of the column\n", fn, fn_far);
  }
  Image out(im.width, im.height, 3), seeds(im.width, im.height, 3), err(im.width, im.height, 3);
  for (int v = 0; v < im.height; ++v)
    for (int u = 0; u < im.width; ++u) {
      const std::size_t q = std::size_t(v) * im.width + u;
      const uint8_t* px = im.at(u, v);
      const bool sg = g.ground[q], tg = truth.data[q] == labels::kRoad || truth.data[q] == labels::kRough;
      for (int k = 0; k < 3; ++k) {
        out.at(u, v)[k] = sg ? (k == 2 ? 255 : px[k] / 2) : px[k];
        seeds.at(u, v)[k] = g.seed[q] ? (k == 1 ? 255 : 0) : (g.observed[q] ? (k == 2 ? 200 : 0) : px[k] / 3);
        err.at(u, v)[k] = tg && !sg ? (k == 2 ? 0 : 255) : (!tg && sg ? (k == 1 ? 0 : 255) : px[k] / 3);
      }
    }
  writeImageAtomic(dir + "/rellis_seg.png", out);
  writeImageAtomic(dir + "/rellis_seeds.png", seeds);
  writeImageAtomic(dir + "/rellis_err.png", err);
}

TEST(GroundSegmentation, RellisRealFrame) {
  const Frame& f = rellis();
  ASSERT_EQ(f.cameras.size(), 1u);
  const CameraImage& cam = f.cameras[0];
  ASSERT_TRUE(cam.truth);
  const GroundSegParams p = rellisParams();
  const auto t0 = std::chrono::steady_clock::now();
  const GroundSegmentation g = segmentGround(*cam.image, cam.model, f.points, p, "rellis");
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  const GroundConfusion c = compareGround(g, *cam.truth);
  std::printf("RELLIS 000104: ground found %.2f %%, errors %.2f %% (tp %zu fn %zu fp %zu tn %zu), "
              "seeds %zu, object samples %zu, %.1f ms\n",
              100 * c.groundFound(), 100 * c.errorRate(), c.tp, c.fn, c.fp, c.tn, g.seeds,
              g.object_samples, ms);
  std::printf("  ground plane z = %.4f x + %.4f y + %.3f m (fitted %d)\n", g.ground_plane[0], g.ground_plane[1], g.ground_plane[2], int(g.plane_fitted));
  if (const char* dbg = std::getenv("TERRAMRF_MESH_DEBUG")) dumpRellis(g, *cam.image, *cam.truth, dbg);
  // Measured 95.14 % / 3.75 % (with the paper's fixed band and per-pixel colours 53.0 % /
  // 17.5 %). Of the 40.8k missed pixels 31.6k are the meadow beyond the path's end, above the
  // farthest LiDAR ground return of their column; false ground is mostly the feet of the bushes
  // along the path (42.8k px) and the person's legs (2.7k px).
  EXPECT_GE(c.groundFound(), 0.94);
  EXPECT_LE(c.errorRate(), 0.045);
  EXPECT_TRUE(g.plane_fitted);
  // The fitted plane: pitched forward by ~2 deg (x points backwards), ~1.4 m below the sensor.
  EXPECT_NEAR(g.ground_plane[2], -1.4, 0.15);
  // The same frame with the paper's flat band (h1 = 1.45 m, no plane fit) loses most ground.
  GroundSegParams flat = p;
  flat.fit_ground_plane = false;
  const GroundConfusion cf = compareGround(segmentGround(*cam.image, cam.model, f.points, flat), *cam.truth);
  std::printf("  fixed band: ground found %.2f %%, errors %.2f %%\n", 100 * cf.groundFound(), 100 * cf.errorRate());
  EXPECT_LT(cf.groundFound(), c.groundFound() - 0.1);
}

TEST(PixelMrf, FloodFillStaysInTheSeedsRegion) {
  // Left half dark grey, right half bright green; seeds in the left half only.
  Image img(40, 20, 3);
  std::vector<uint8_t> seed(800, 0), obs(800, 0);
  for (int v = 0; v < 20; ++v)
    for (int u = 0; u < 40; ++u) {
      uint8_t* px = img.at(u, v);
      if (u < 20) px[0] = px[1] = px[2] = 90;
      else { px[0] = 40; px[1] = 200; px[2] = 40; }
      obs[v * 40 + u] = u < 20;
    }
  seed[10 * 40 + 5] = 1;
  for (MrfMode m : {MrfMode::kFloodFill, MrfMode::kGibbs}) {
    PixelMrfParams p;
    p.mode = m;
    const PixelMrfResult r = solvePixelMrf(img, seed, obs, {}, p);
    std::size_t left = 0, right = 0;
    for (int v = 0; v < 20; ++v)
      for (int u = 0; u < 40; ++u) (u < 20 ? left : right) += r.label[v * 40 + u];
    EXPECT_EQ(left, 400u) << toString(m);
    EXPECT_EQ(right, 0u) << toString(m);
  }
}

}  // namespace
}  // namespace terramrf::meshing
