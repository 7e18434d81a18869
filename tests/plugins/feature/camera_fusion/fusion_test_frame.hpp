#pragma once
// Hand-made frames for the camera-fusion and image-feature tests: a pinhole camera at the LiDAR
// origin looking along +x, and helpers to run stages through the registry.
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"
#include "test_support.hpp"

namespace terramrf::test {

/// 200 × 100 px, f = 100 px, principal point (100, 50); camera axes x right, y down, z forward,
/// i.e. cam = (−y_lidar, −z_lidar, x_lidar).
/// Pixel filler for frames whose image content does not matter: mid grey.
inline void noFill(int, int, uint8_t* p) { p[0] = p[1] = p[2] = 128; }

inline CameraModel forwardCamera(const std::string& name = "front") {
  CameraModel m;
  m.name = name;
  m.width = 200;
  m.height = 100;
  m.P << 100, 0, 100, 0,  //
      0, 100, 50, 0,      //
      0, 0, 1, 0;
  Eigen::Matrix3d R;
  R << 0, -1, 0,  //
      0, 0, -1,   //
      1, 0, 0;
  m.T_camera_lidar = Eigen::Isometry3d::Identity();
  m.T_camera_lidar.linear() = R;
  return m;
}

/// Grid of 8 × 8 cells of 1 m in front of the camera: x ∈ [2, 10], y ∈ [−4, 4].
inline GridGeometry forwardGrid() {
  GridGeometry g;
  g.size_m = 8;
  g.cell_m = 1;
  g.centre_m = Eigen::Vector2d(6, 0);
  return g;
}

/// A frame with a flat ground (z = −1) sampled every 0.25 m over the grid, and one camera whose
/// image is filled by `fill(u, v, rgb)`.
template <class Fill>
Frame groundFrame(const CameraModel& cam, Fill fill, int channels = 3,
                  const std::string& image_path = "/data/front/000007.png") {
  Frame f;
  f.id = "000007";
  f.source_path = "/data/velodyne/000007.bin";
  for (double x = 2.125; x < 10; x += 0.25)
    for (double y = -3.875; y < 4; y += 0.25) f.points.push_back(float(x), float(y), -1.f, 0.f);
  CameraImage ci;
  ci.model = cam;
  auto img = std::make_shared<Image>(cam.width, cam.height, channels);
  for (int v = 0; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u) fill(u, v, img->at(u, v));
  ci.image = img;
  ci.source_path = image_path;
  f.cameras.push_back(ci);
  return f;
}

/// Runs stages on one frame with a fresh grid.
struct StageRunner {
  LabelSet labels = LabelSet::defaults();
  GridGeometry geom;
  TerrainGrid grid;
  FrameContext ctx;
  PluginContext pctx;
  std::vector<std::unique_ptr<Plugin>> stages;

  explicit StageRunner(const GridGeometry& g = forwardGrid()) : geom(g) {
    pctx.grid = g;
    pctx.labels = &labels;
  }
  Stage& add(const std::string& type, const std::string& params = "{}") {
    PluginRegistry reg({pluginDir()});
    auto p = reg.create(type);
    setParams(*p, params, pctx);
    stages.push_back(std::move(p));
    return static_cast<Stage&>(*stages.back());
  }
  /// Bins the frame into a fresh grid (clears fused pixels and layers).
  void prepare(Frame& f) {
    grid.reset(geom);
    grid.binPoints(f.points);
    ctx = FrameContext{};
    ctx.frame = &f;
    ctx.grid = &grid;
    ctx.labels = &labels;
  }
  /// Runs every stage in order on the prepared frame.
  void process() {
    for (auto& s : stages) static_cast<Stage&>(*s).process(ctx);
  }
  void run(Frame& f) {
    prepare(f);
    process();
  }
};

/// Replaces the grid's fused pixels by one hand-made set: cell `cell` gets the pixels of the
/// rectangle [u0, u1) × [v0, v1) of camera 0 (for feature tests independent of the projection).
inline void setCellRect(TerrainGrid& g, int width, int height, int cell, int u0, int u1, int v0,
                        int v1) {
  CellPixels cp;
  cp.camera = 0;
  cp.width = width;
  cp.height = height;
  cp.offsets.assign(g.cells() + 1, 0);
  for (std::size_t c = 0; c < g.cells(); ++c) {
    cp.offsets[c] = uint32_t(cp.pixels.size());
    if (int(c) != cell) continue;
    for (int v = v0; v < v1; ++v)
      for (int u = u0; u < u1; ++u) cp.pixels.push_back(uint32_t(v * width + u));
  }
  cp.offsets[g.cells()] = uint32_t(cp.pixels.size());
  g.cellPixels().clear();
  g.cellPixels().push_back(cp);
}

}  // namespace terramrf::test
