// Test-only temporal fusion: the previous frame's labels, carried over by the two frames' poses,
// as evidence layers for potts_gaussian. The temporal-fusion issue's plugin will slot in where
// this one does; the core's side (the previous frame's grid and pose stay readable, the energy
// takes evidence and classifies cells without points from it) is tested with it now.
#include <cmath>
#include <stdexcept>

#include "terramrf/grid_warp.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {

class SyntheticCarryOver final : public Stage {
 public:
  void declare(ParamDecl& d) override {
    d.add("penalty", penalty_, "energy of every class but the one carried over").unit("energy");
  }
  void configure(const PluginContext& ctx) override {
    layers_.clear();
    for (std::size_t id = 1; id < ctx.labels->size(); ++id)
      layers_.push_back("evidence." + ctx.labels->name(static_cast<LabelId>(id)));
  }
  /// The two frames' poses: declared, so a config whose source and stages give none is refused
  /// (a carry-over by the identity would put the previous labels in the wrong cells once the
  /// vehicle moves).
  std::vector<std::string> reads() const override { return {artefacts::kPose}; }
  std::vector<std::string> writes() const override { return layers_; }

  void process(FrameContext& ctx) override {
    TerrainGrid& g = *ctx.grid;
    std::vector<Layer*> out;
    for (const auto& l : layers_) out.push_back(&g.add(l));
    const FrameContext* prev = ctx.previous;
    ctx.metrics[name() + ".chain_depth"] = chainDepth(ctx);
    if (!prev || !prev->grid || prev->grid->labels().empty()) return;
    // Current cell centre → world (this frame's pose) → the previous frame's grid. The poses
    // were checked to be written (reads()); a missing one is a writer's broken promise.
    if (!ctx.frame->pose || !prev->frame || !prev->frame->pose)
      throw std::logic_error(name() + ": a frame without its pose ('@pose' was declared written)");
    const Eigen::Isometry3d to_prev = prev->frame->pose->inverse() * *ctx.frame->pose;
    const std::vector<LabelId> carried_labels = resampleLabels(
        prev->grid->labels(), cellsUnder(g.geometry(), prev->grid->geometry(), to_prev));
    std::size_t carried = 0;
    for (std::size_t cell = 0; cell < carried_labels.size(); ++cell) {
      const LabelId l = carried_labels[cell];
      if (l == labels::kUnknown) continue;
      for (std::size_t k = 0; k < out.size(); ++k)
        (*out[k])[cell] = (k + 1 == l) ? 0.f : float(penalty_);
      ++carried;
    }
    ctx.metrics[name() + ".cells_carried"] = double(carried);
  }

 private:
  /// How many frames back `previous` reaches (bounded: a cycle would be a runner bug).
  static double chainDepth(const FrameContext& ctx) {
    int n = 0;
    for (const FrameContext* p = ctx.previous; p && n < 100; p = p->previous) ++n;
    return n;
  }

  double penalty_ = 20.0;
  std::vector<std::string> layers_;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::SyntheticCarryOver, terramrf::PluginKind::kFeature, "test_carry_over",
                "test-only temporal fusion: the previous labels as evidence")
