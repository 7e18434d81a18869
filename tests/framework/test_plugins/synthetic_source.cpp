// Test-only source: a flat ground plane with one box obstacle, known truth, and frames that can be
// told to fail, so the runner's skip-and-report path and config checks are testable without data.
#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <random>

#include "terramrf/plugin.hpp"

namespace terramrf {

class SyntheticSource final : public Source {
 public:
  void declare(ParamDecl& d) override {
    d.add("frames", frames_, "number of frames").range(0, 1000);
    d.add("bad_frames", bad_, "indices of frames whose read throws InputError");
    d.add("spacing_m", spacing_m_, "ground sample spacing").unit("m").range(0.01, 1);
    d.add("path", path_, "optional folder that must exist").existingPath();
    d.add("mode", mode_, "scene kind").choices({"plane", "empty"});
    d.add("nonfinite_points", nonfinite_, "NaN points each read reports as dropped").range(0, 1e6);
    d.add("no_return_points", no_return_, "origin points each read reports as dropped")
        .range(0, 1e6);
    d.add("hole_from_frame", hole_from_,
          "frames from this index on have no ground points in 5 ≤ x < 7 m, 3 ≤ y < 5 m (an "
          "occlusion); negative = never")
        .range(-1, 1000);
    d.add("offset_m", offset_m_,
          "[dx, dy] added to every point, as a cloud stored in a map frame would be; empty: none")
        .unit("m");
    d.add("truth_pose", truth_pose_,
          "frame i has the ground-truth pose x = i m (no rotation), as pose and truth_pose "
          "(and '@pose' is declared written)");
    d.add("poses", poses_,
          "every frame has a pose (the identity), and '@pose' is declared written");
    d.add("declared_writes", declared_writes_,
          "declared written besides the pose (tests of the read/write check; nothing is written)");
    d.add("grid_layers", grid_layers_,
          "grid layers every frame brings made (Frame::grid, as a received terrain_grid_t), "
          "declared written; each cell of layer k holds 100·k + the frame index");
    d.add("grid_cell_m", grid_cell_m_, "cell size of that grid; 0 = the run's")
        .unit("m")
        .range(0, 10);
    d.add("gridless_frames", gridless_, "indices of frames that come without that grid");
    d.add("layer_origin", layer_origin_,
          "origin record said of every grid layer (Source::layerOrigins); empty = unknown");
  }
  void configure(const PluginContext& ctx) override { run_grid_ = ctx.grid; }
  std::vector<std::string> writes() const override {
    std::vector<std::string> w = declared_writes_;
    w.insert(w.end(), grid_layers_.begin(), grid_layers_.end());
    if (poses_ || truth_pose_) w.push_back(artefacts::kPose);
    return w;
  }
  std::map<std::string, std::string> layerOrigins() const override {
    std::map<std::string, std::string> o;
    if (!layer_origin_.empty())
      for (const std::string& l : grid_layers_)
        if (l[0] != '@') o[l] = layer_origin_;
    return o;
  }
  std::size_t size() const override { return static_cast<std::size_t>(frames_); }
  std::string frameId(std::size_t i) const override {
    char b[16];
    std::snprintf(b, sizeof b, "%06zu", i);
    return b;
  }
  Frame read(std::size_t i) override {
    for (double b : bad_)
      if (static_cast<std::size_t>(b) == i)
        throw InputError("synthetic/" + frameId(i) + ".bin",
                         "size 13 bytes is not a multiple of 16");
    Frame f;
    f.id = frameId(i);
    f.source_path = "synthetic/" + f.id + ".bin";
    f.dropped_nonfinite_points = static_cast<std::size_t>(nonfinite_);
    f.dropped_no_return_points = static_cast<std::size_t>(no_return_);
    if (poses_) f.pose = Eigen::Isometry3d::Identity();
    if (truth_pose_) {
      f.truth_pose = Eigen::Isometry3d(Eigen::Translation3d(double(i), 0, 0));
      f.pose = f.truth_pose;
    }
    if (!grid_layers_.empty() &&
        std::find(gridless_.begin(), gridless_.end(), double(i)) == gridless_.end()) {
      GridGeometry g = run_grid_;
      if (grid_cell_m_ > 0) g.cell_m = grid_cell_m_;
      auto grid = std::make_shared<TerrainGrid>(g);
      for (std::size_t k = 0; k < grid_layers_.size(); ++k)
        if (grid_layers_[k][0] != '@') grid->add(grid_layers_[k], float(100 * k + i));
      // Undeclared: must not reach the run's grid.
      grid->add("undeclared", 1);
      grid->labels().assign(grid->cells(), labels::kObstacle);
      f.grid = std::move(grid);
    }
    if (mode_ == "empty") return f;
    std::mt19937 rng(static_cast<unsigned>(i));
    std::normal_distribution<float> noise(0.f, 0.005f);
    for (double x = -10; x < 10; x += spacing_m_)
      for (double y = -10; y < 10; y += spacing_m_) {
        const bool in_box = x > 3 && x < 4 && y > -1 && y < 1;
        const bool in_hole =
            hole_from_ >= 0 && int(i) >= hole_from_ && x >= 5 && x < 7 && y >= 3 && y < 5;
        if (in_box || in_hole) continue;
        f.points.push_back(static_cast<float>(x), static_cast<float>(y), -1.7f + noise(rng), 0.5f);
        f.truth.label.push_back(x < 0 ? labels::kRough : labels::kRoad);
        f.truth.raw.push_back(x < 0 ? 2 : 1);
      }
    // Box: 1 m × 2 m × 1.5 m, sampled on its faces.
    for (double z = -1.7; z < -0.2; z += spacing_m_)
      for (double y = -1; y < 1; y += spacing_m_) {
        f.points.push_back(3.f, static_cast<float>(y), static_cast<float>(z), 0.5f);
        f.truth.label.push_back(labels::kObstacle);
        f.truth.raw.push_back(3);
      }
    if (offset_m_.size() == 2)
      for (std::size_t k = 0; k < f.points.size(); ++k) {
        f.points.x[k] += static_cast<float>(offset_m_[0]);
        f.points.y[k] += static_cast<float>(offset_m_[1]);
      }
    return f;
  }

 private:
  int frames_ = 3;
  std::vector<double> bad_;
  double spacing_m_ = 0.1;
  std::string path_;
  std::string mode_ = "plane";
  int nonfinite_ = 0, no_return_ = 0;
  int hole_from_ = -1;
  std::vector<double> offset_m_;
  bool truth_pose_ = false;
  bool poses_ = false;
  std::vector<std::string> declared_writes_;
  std::vector<std::string> grid_layers_;
  std::string layer_origin_;
  double grid_cell_m_ = 0;
  std::vector<double> gridless_;
  GridGeometry run_grid_;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::SyntheticSource, terramrf::PluginKind::kSource, "test_synthetic",
                "test-only synthetic plane + box")
