// Source plugin "simulator": a seeded, deterministic procedural world seen by an HDL-64E-like
// LiDAR and a forward camera from a vehicle driving along a road, with IMU, GPS and odometry.
// All the work is in terramrf_sim (sim::Simulation); this is the Source adapter.
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

#include "terramrf/plugin.hpp"
#include "terramrf/sim/simulation.hpp"

namespace terramrf {
namespace {

class SimulatorSource : public Source {
 public:
  void declare(ParamDecl& d) override { sim::declareSimulationParams(d, config_); }

  void configure(const PluginContext&) override {
    sim_ = std::make_unique<sim::Simulation>(config_);  // throws ParamError
  }

  std::size_t size() const override { return std::size_t(config_.frames); }

  std::string frameId(std::size_t i) const override {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%06zu", i);
    return buf;
  }

  Frame read(std::size_t i) override {
    if (!sim_) throw std::logic_error("simulator: read() before configure()");
    return sim_->frame(i);
  }

  /// Simulation::frame is const and seeds all noise from the frame index.
  bool concurrentReads() const override { return true; }

 private:
  sim::SimulationConfig config_;
  std::unique_ptr<sim::Simulation> sim_;
};

}  // namespace
}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::SimulatorSource, terramrf::PluginKind::kSource, "simulator",
                "procedural world (road, rough ground, ditch, buildings, trees, rocks, cars) seen "
                "by an HDL-64E-like LiDAR and a camera, with IMU/GPS/odometry; seeded")
