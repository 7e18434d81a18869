// The vertical slice per scan, through the real plugins as the pipeline runs them:
//   BM_GridPreclassHeightDiff: binning + eq. 1 pre-classification + height difference
//   BM_Slice:                  the above + Potts/Gaussian energy + ICM
// Data: SemanticKITTI sequence 00 frame 000000 (HDL-64E, 124668 points), 40 m grid, 0.5 m cells.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <iostream>

#include "terramrf/io/kitti.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"

namespace terramrf {
namespace {

struct SliceFixture {
  Frame frame;
  LabelSet labels = LabelSet::defaults();
  GridGeometry geom;
  TerrainGrid grid;
  PluginRegistry reg{PluginRegistry::defaultSearchDirs()};
  std::vector<std::unique_ptr<Plugin>> stages;

  SliceFixture() {
    const char* env = std::getenv("TERRAMRF_DATA_DIR");
    const std::string data = env ? env : TERRAMRF_DATA_DIR;
    const std::string scan = data + "/semantickitti_seq00_000000-000005/sequences/00/velodyne/000000.bin";
    readKittiScan(scan, frame.points);
    PluginContext ctx;
    ctx.config_dir = std::string(TERRAMRF_SOURCE_DIR) + "/configs";
    ctx.grid = geom;
    ctx.labels = &labels;
    auto add = [&](const char* type, const std::string& params) {
      auto p = reg.create(type);
      setParams(*p, params, ctx);
      stages.push_back(std::move(p));
    };
    add("eigen_preclass", "{}");
    add("height_difference", "{}");
    add("potts_gaussian",
        "{model: models/laser_simulator.yaml, features: [height_diff, normal_eigenvalue], "
        "preclass_layer: preclass}");
    add("icm", "{report_energy: false}");
  }
  void run(FrameContext& ctx, std::size_t n_stages) {
    grid.reset(geom);
    grid.binPoints(frame.points);
    for (std::size_t s = 0; s < n_stages; ++s) static_cast<Stage&>(*stages[s]).process(ctx);
  }
};

SliceFixture& fixture() {
  static SliceFixture f;
  return f;
}

void runStages(benchmark::State& state, std::size_t n_stages) {
  SliceFixture& f = fixture();
  FrameContext ctx;
  ctx.frame = &f.frame;
  ctx.grid = &f.grid;
  ctx.labels = &f.labels;
  for (auto _ : state) {
    f.run(ctx, n_stages);
    benchmark::DoNotOptimize(f.grid.labels().data());
  }
  state.counters["points"] = static_cast<double>(f.frame.points.size());
  state.counters["cells"] = static_cast<double>(f.grid.cells());
}

void BM_GridPreclassHeightDiff(benchmark::State& state) { runStages(state, 2); }
void BM_Slice(benchmark::State& state) { runStages(state, 4); }

BENCHMARK(BM_GridPreclassHeightDiff)->Unit(benchmark::kMillisecond)->Repetitions(10)->ReportAggregatesOnly(true);
BENCHMARK(BM_Slice)->Unit(benchmark::kMillisecond)->Repetitions(10)->ReportAggregatesOnly(true);

}  // namespace
}  // namespace terramrf

BENCHMARK_MAIN();
