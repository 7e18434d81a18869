// Test-only map stage: builds a grid over the whole run in the run's state (RunState), as the
// global semantic map will, and takes a frame back out when the frame fails later. The core's
// side of the lifecycle (begin, frameFailed, end, RunState shared with in-process outputs) is
// tested with it through a library of its own, as a real map plugin would be loaded.
#include <algorithm>
#include <stdexcept>

#include "terramrf/plugin.hpp"

namespace terramrf {

class RunMap final : public Stage {
 public:
  void declare(ParamDecl& d) override {
    d.add("map", map_, "name of the map in the run's state");
    d.add("fail_in", fail_in_, "hook that throws")
        .choices({"none", "begin", "frame_failed", "end"});
    d.add("fail_runs_of", fail_runs_of_,
          "throw only in runs of this many frames (RunInfo::frames; 0: every run)")
        .range(0, 1000000);
  }
  std::vector<std::string> reads() const override { return {artefacts::kPoints}; }

  void begin(const RunInfo& info) override {
    failing_ = fail_runs_of_ == 0 || info.frames == std::size_t(fail_runs_of_);
    if (fail_in_ == "begin" && failing_) throw std::runtime_error("cannot open the map store");
    if (!info.run) throw std::logic_error("no run state at begin()");
    // A run's state starts empty: a map already there would be another run's.
    if (info.run->findMap(map_))
      throw std::logic_error("map '" + map_ + "' is in the run's state before its begin()");
    info.run->map(map_, info.grid).add("hits", 0.f);
    frames_in_map_ = 0;
  }

  void process(FrameContext& ctx) override {
    if (!ctx.run) throw std::logic_error("no run state in the frame's context");
    TerrainGrid* map = ctx.run->findMap(map_);
    if (!map) throw std::logic_error("map '" + map_ + "' is gone from the run's state");
    Layer& hits = map->layer("hits");
    last_cells_.clear();
    for (int c = 0; c < int(ctx.grid->cells()); ++c)
      if (ctx.grid->count(c) > 0) {
        hits[c] += 1.f;
        last_cells_.push_back(c);
      }
    last_index_ = ctx.index;
    ctx.metrics[name() + ".frames_in_map"] = double(++frames_in_map_);
  }

  void frameFailed(const FrameContext& ctx) override {
    if (fail_in_ == "frame_failed" && failing_) throw std::runtime_error("map store is read-only");
    if (ctx.index != last_index_)
      throw std::logic_error("told frame " + std::to_string(ctx.index) + " failed, processed " +
                             std::to_string(last_index_) + " last");
    Layer& hits = ctx.run->findMap(map_)->layer("hits");
    for (int c : last_cells_) hits[c] -= 1.f;
    last_cells_.clear();
    --frames_in_map_;
  }

  void end(const RunSummary&) override {
    if (fail_in_ == "end" && failing_) throw std::runtime_error("disk full while saving the map");
  }

 private:
  std::string map_ = "map.test";
  std::string fail_in_ = "none";
  int fail_runs_of_ = 0;
  bool failing_ = false;
  int frames_in_map_ = 0;
  std::size_t last_index_ = 0;
  std::vector<int> last_cells_;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::RunMap, terramrf::PluginKind::kFeature, "test_run_map",
                "test-only stage that builds a map over the run in its RunState")
