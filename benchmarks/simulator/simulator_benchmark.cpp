// Time per simulated frame through the simulator plugin, as a run reads it: the LiDAR alone and
// with the default 640 x 256 camera. Frames 0–4 in turn (the scene changes along the drive).
#include <benchmark/benchmark.h>

#include <memory>
#include <string>

#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"

namespace {

using namespace terramrf;

std::unique_ptr<Plugin> makeSimulator(const std::string& params) {
  static PluginRegistry reg{PluginRegistry::defaultSearchDirs()};
  std::unique_ptr<Plugin> p = reg.create("simulator");
  setParams(*p, params, PluginContext{});
  return p;
}

void readFrames(benchmark::State& state, const std::string& params) {
  const std::unique_ptr<Plugin> p = makeSimulator(params);
  auto& source = static_cast<Source&>(*p);
  std::size_t i = 0, points = 0;
  for (auto _ : state) {
    const Frame f = source.read(i++ % source.size());
    points = f.points.size();
    benchmark::DoNotOptimize(points);
  }
  state.counters["points"] = double(points);
}

void BM_SimulatorLidarFrame(benchmark::State& state) {
  readFrames(state, "{frames: 5, enable_camera: false}");
}
void BM_SimulatorLidarAndCameraFrame(benchmark::State& state) { readFrames(state, "{frames: 5}"); }

BENCHMARK(BM_SimulatorLidarFrame)->Unit(benchmark::kMillisecond)->Iterations(5)->Repetitions(5)
    ->ReportAggregatesOnly(true);
BENCHMARK(BM_SimulatorLidarAndCameraFrame)->Unit(benchmark::kMillisecond)->Iterations(5)
    ->Repetitions(5)->ReportAggregatesOnly(true);

}  // namespace

BENCHMARK_MAIN();
