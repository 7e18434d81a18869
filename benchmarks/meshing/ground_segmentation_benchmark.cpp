// Ground segmentation per image (seeds, colour model, MRF), flood fill vs plain Gibbs. Frames are
// rendered once by the simulator before timing (512 x 256 camera, HDL-64E-like LiDAR).
#include <benchmark/benchmark.h>

#include <vector>

#include "terramrf/meshing/ground_segmentation.hpp"
#include "terramrf/sim/camera.hpp"
#include "terramrf/sim/lidar.hpp"
#include "terramrf/sim/random.hpp"
#include "terramrf/sim/trajectory.hpp"
#include "terramrf/sim/world.hpp"

namespace {

using namespace terramrf;

const std::vector<Frame>& frames() {
  static const std::vector<Frame> f = [] {
    sim::WorldParams wp;
    wp.seed = 3;
    wp.x_min_m = -130;
    wp.x_max_m = 260;
    wp.terrain_half_width_m = 140;
    const sim::World world(wp);
    const sim::Trajectory traj(world, {});
    const sim::LidarModel lidar(world, {});
    sim::CameraParams cp;
    cp.width = 512;
    cp.height = 256;
    cp.fx = 296;
    const sim::CameraRenderer cam(world, cp);
    std::vector<Frame> v;
    for (std::size_t i = 0; i < 80; i += 10) {
      Frame fr;
      const double t = 0.1 * i;
      lidar.scan([&](double tau) { return traj.pose(t + tau); }, sim::hashKeys(3, 2, i), fr);
      fr.pose = traj.pose(t);
      fr.cameras.push_back(cam.render(*fr.pose, sim::hashKeys(3, 3, i)));
      v.push_back(std::move(fr));
    }
    return v;
  }();
  return f;
}

void run(benchmark::State& state, meshing::MrfMode mode) {
  const auto& f = frames();
  meshing::GroundSegParams p;
  p.mrf.mode = mode;
  std::size_t k = 0, evaluated = 0;
  for (auto _ : state) {
    const Frame& fr = f[k++ % f.size()];
    const auto g = meshing::segmentGround(*fr.cameras[0].image, fr.cameras[0].model, fr.points, p);
    evaluated += g.evaluated;
    benchmark::DoNotOptimize(g.ground.data());
  }
  state.counters["fps"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["evaluations"] = double(evaluated) / double(state.iterations());
}

void BM_GroundSegmentation_FloodFill(benchmark::State& s) { run(s, meshing::MrfMode::kFloodFill); }
void BM_GroundSegmentation_Gibbs(benchmark::State& s) { run(s, meshing::MrfMode::kGibbs); }
BENCHMARK(BM_GroundSegmentation_FloodFill)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_GroundSegmentation_Gibbs)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
