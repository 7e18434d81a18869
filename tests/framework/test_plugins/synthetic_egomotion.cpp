// Test-only egomotion stage. The egomotion issue's EKF and ICP plugins will slot in where this
// one does, so the runner's side of the contract is tested now: an egomotion stage runs before
// the grid is binned (it may move the points, e.g. to undo the sweep's motion), sets the frame's
// pose, and sees the previous frame's result for temporal fusion.
#include <cmath>

#include "terramrf/plugin.hpp"

namespace terramrf {

class SyntheticEgomotion final : public Stage {
 public:
  void declare(ParamDecl& d) override {
    d.add("step_m", step_m_, "pose: x advances this far per frame index").unit("m");
    d.add("shift_x_m", shift_x_m_, "subtracted from every point's x before binning").unit("m");
    d.add("yaw_deg", yaw_deg_, "pose: turned this far about z per frame index").unit("deg");
    d.add("overwrite_truth", overwrite_truth_,
          "also sets truth_pose, which egomotion must not (the runner fails the frame)");
    d.add("set_pose", set_pose_, "sets the frame's pose (and declares '@pose' written)");
    d.add("declared_reads", declared_reads_,
          "declared read (tests of the read/write check; nothing is read)");
    d.add("declared_writes", declared_writes_,
          "declared written besides the pose (tests of the read/write check; nothing is written)");
  }
  std::vector<std::string> reads() const override { return declared_reads_; }
  std::vector<std::string> writes() const override {
    std::vector<std::string> w = declared_writes_;
    if (set_pose_) w.push_back(artefacts::kPose);
    return w;
  }
  void process(FrameContext& ctx) override {
    Frame& f = *ctx.frame;
    const double i = double(ctx.index);
    if (set_pose_)
      f.pose = Eigen::Translation3d(step_m_ * i, 0, 0) *
               Eigen::AngleAxisd(yaw_deg_ * i * M_PI / 180, Eigen::Vector3d::UnitZ());
    if (overwrite_truth_) f.truth_pose = f.pose;
    for (float& x : f.points.x) x -= static_cast<float>(shift_x_m_);
    const bool prev = ctx.previous && ctx.previous->frame && ctx.previous->frame->pose;
    ctx.metrics[name() + ".previous_pose_x_m"] =
        prev ? ctx.previous->frame->pose->translation().x() : -1.0;
    // What the grid holds when it runs: it is built after this stage, so nothing of any frame.
    ctx.metrics[name() + ".grid_layers_and_points"] =
        ctx.grid ? double(ctx.grid->layerNames().size() + ctx.grid->pointsInside()) : -1.0;
  }

 private:
  double step_m_ = 1.0;
  double shift_x_m_ = 0.0;
  double yaw_deg_ = 0.0;
  bool overwrite_truth_ = false;
  bool set_pose_ = true;
  std::vector<std::string> declared_reads_, declared_writes_;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::SyntheticEgomotion, terramrf::PluginKind::kEgomotion, "test_egomotion",
                "test-only egomotion: a pose per frame and a shift of the points")
