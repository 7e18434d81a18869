// Source plugin "simulator": a seeded, deterministic procedural world seen by an HDL-64E-like
// LiDAR and a forward camera from a vehicle driving along a road, with IMU, GPS and odometry.
// All the work is in terramrf_sim (sim::Simulation); this is the Source adapter.
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "terramrf/plugin.hpp"
#include "terramrf/sim/simulation.hpp"

namespace terramrf {
namespace {

class SimulatorSource : public Source {
 public:
  void declare(ParamDecl& d) override { sim::declareSimulationParams(d, config_); }

  void configure(const PluginContext& ctx) override {
    sim_ = std::make_unique<sim::Simulation>(config_);  // throws ParamError
    truth_ids_ = ctx.labels ? truthIds(*ctx.labels) : std::vector<LabelId>{};
  }

  std::size_t size() const override { return std::size_t(config_.frames); }

  std::string frameId(std::size_t i) const override {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%06zu", i);
    return buf;
  }

  Frame read(std::size_t i) override {
    if (!sim_) throw std::logic_error("simulator: read() before configure()");
    Frame f = sim_->frame(i);
    if (!truth_ids_.empty()) {
      for (LabelId& l : f.truth.label) l = truth_ids_[l];
      for (CameraImage& cam : f.cameras) {
        if (!cam.truth) continue;
        auto t = std::make_shared<Image>(*cam.truth);
        for (uint8_t& l : t->data) l = truth_ids_[l];
        cam.truth = std::move(t);
      }
    }
    return f;
  }

  /// Every frame has the vehicle's pose on its trajectory (Simulation::frame). Stages that read
  /// the pose are checked against this.
  std::vector<std::string> writes() const override { return {artefacts::kPose}; }

  /// Simulation::frame is const and seeds all noise from the frame index.
  bool concurrentReads() const override { return true; }

  /// The simulation's own camera names (image_2, image_3: one per camera_yaws_deg entry).
  std::vector<std::string> cameraNames() const override {
    std::vector<std::string> names;
    if (sim_)
      for (const auto& cam : sim_->cameras()) names.push_back(cam->params().name);
    return names;
  }

 private:
  /// The simulation's truth is in the default classes' ids; a config's own label set numbers
  /// its classes otherwise, so they are matched by name. Empty: the ids already agree.
  static std::vector<LabelId> truthIds(const LabelSet& set) {
    // Indexed by any byte (pixel truth is one); ids the simulation never writes map to themselves.
    std::vector<LabelId> ids(256);
    for (std::size_t id = 0; id < ids.size(); ++id) ids[id] = static_cast<LabelId>(id);
    const LabelSet sim = LabelSet::defaults();
    std::string missing;
    bool same = true;
    for (LabelId id = 0; id < sim.size(); ++id) {
      const int to = set.find(sim.name(id));
      if (to < 0) missing += std::string(missing.empty() ? "" : ", ") + "'" + sim.name(id) + "'";
      else
        ids[id] = static_cast<LabelId>(to);
      same = same && to == id;
    }
    if (!missing.empty())
      throw ParamError("",
                       "its ground truth is in the classes road, rough and obstacle, and the "
                       "config's label set has no " +
                           missing + "; list them under labels: (other classes may be added)");
    return same ? std::vector<LabelId>{} : ids;
  }

  sim::SimulationConfig config_;
  std::unique_ptr<sim::Simulation> sim_;
  std::vector<LabelId> truth_ids_;  ///< simulation class id -> the run's label set's id
};

}  // namespace
}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::SimulatorSource, terramrf::PluginKind::kSource, "simulator",
                "procedural world (road, rough ground, ditch, buildings, trees, rocks, cars) seen "
                "by an HDL-64E-like LiDAR and a camera, with IMU/GPS/odometry; seeded")
