// Per-frame cost of each optimiser plugin alone (icm, alpha_expansion, gibbs with 100 annealing
// sweeps and its default marginal sweeps, and without them) on a
// synthetic 200 × 200 grid with 4 labels and Potts β = β_diagonal = 0.8, one thread.
//
// The unaries come from a blocky ground truth (20 × 20-cell blocks of random labels):
// unary_k = −[k = truth] + σ·N(0, 1), σ calibrated so that about a quarter of the cells are wrong
// under the unary argmin, which is also the initial labelling. Counters: final energy and the
// fraction of cells still wrong. Targets: ICM ≤ 5 ms, α-expansion ≤ 100 ms, Gibbs ≤ 100 ms.
// Each optimiser instance lives for the whole run, as in a pipeline (first frame untimed).
// Run: build/bin/terramrf_bench_optimisers (medians over 10 repetitions; on a shared machine
// read the CPU column, wall time includes waiting for the core).
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"

namespace terramrf {
namespace {

constexpr int kSide = 200, kLabels = 4, kBlock = 20;
constexpr float kBeta = 0.8f;
constexpr double kTargetWrong = 0.25;

struct Problem {
  EnergyModel em;
  std::vector<uint8_t> truth;
  double sigma = 0, wrong_initial = 0;
};

double wrongFraction(const std::vector<uint8_t>& lab, const std::vector<uint8_t>& truth) {
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < lab.size(); ++i) wrong += lab[i] != truth[i];
  return double(wrong) / lab.size();
}

std::vector<uint8_t> unaryArgmin(const Problem& p, const std::vector<float>& noise, double sigma) {
  std::vector<uint8_t> lab(p.truth.size());
  for (std::size_t i = 0; i < lab.size(); ++i) {
    int best = 0;
    float e_best = 0;
    for (int k = 0; k < kLabels; ++k) {
      const float e = (k == p.truth[i] ? -1.f : 0.f) + float(sigma) * noise[i * kLabels + k];
      if (k == 0 || e < e_best) best = k, e_best = e;
    }
    lab[i] = static_cast<uint8_t>(best);
  }
  return lab;
}

const Problem& problem() {
  static const Problem p = [] {
    Problem p;
    std::mt19937 rng(20240611);
    std::uniform_int_distribution<int> block_label(0, kLabels - 1);
    const int nb = kSide / kBlock;
    std::vector<int> blocks(nb * nb);
    for (int& b : blocks) b = block_label(rng);
    p.truth.resize(std::size_t(kSide) * kSide);
    for (int r = 0; r < kSide; ++r)
      for (int c = 0; c < kSide; ++c)
        p.truth[r * kSide + c] = blocks[(r / kBlock) * nb + c / kBlock];
    std::normal_distribution<float> gauss(0.f, 1.f);
    std::vector<float> noise(p.truth.size() * kLabels);
    for (float& n : noise) n = gauss(rng);
    // The wrong fraction grows with σ: bisect on these very draws.
    double lo = 0.0, hi = 5.0;
    for (int it = 0; it < 40; ++it) {
      const double mid = 0.5 * (lo + hi);
      (wrongFraction(unaryArgmin(p, noise, mid), p.truth) < kTargetWrong ? lo : hi) = mid;
    }
    p.sigma = 0.5 * (lo + hi);
    EnergyModel& em = p.em;
    em.resize(kSide, kSide, kLabels);
    for (int k = 0; k < kLabels; ++k) em.active[k] = static_cast<LabelId>(k + 1);
    for (std::size_t i = 0; i < p.truth.size(); ++i)
      for (int k = 0; k < kLabels; ++k)
        em.unary[i * kLabels + k] =
            (k == p.truth[i] ? -1.f : 0.f) + float(p.sigma) * noise[i * kLabels + k];
    em.initial = unaryArgmin(p, noise, p.sigma);
    em.beta = em.beta_diagonal = kBeta;
    p.wrong_initial = wrongFraction(em.initial, p.truth);
    std::printf(
        "optimiser benchmark: %dx%d cells, %d labels, beta %.2f, noise sigma %.4f, "
        "%.2f%% of cells wrong under the unary argmin (target %.0f%%)\n",
        kSide, kSide, kLabels, kBeta, p.sigma, 100 * p.wrong_initial, 100 * kTargetWrong);
    if (std::abs(p.wrong_initial - kTargetWrong) > 0.01) {
      std::fprintf(stderr, "noise calibration failed: %.4f wrong\n", p.wrong_initial);
      std::abort();
    }
    return p;
  }();
  return p;
}

LabelSet benchLabels() {
  return LabelSet({{"unknown", {0, 0, 0}},
                   {"road", {128, 128, 128}},
                   {"rough", {139, 90, 43}},
                   {"obstacle", {220, 30, 30}},
                   {"vegetation", {30, 160, 30}}});
}

/// One optimiser instance per type for the whole run, as in a pipeline: buffers it keeps between
/// frames are allocated once, by an untimed first frame.
struct Harness {
  LabelSet labels = benchLabels();
  GridGeometry geom;
  std::unique_ptr<Plugin> plugin;
  Frame frame;
  std::unique_ptr<TerrainGrid> grid;
  FrameContext ctx;
};

Harness& harness(const std::string& type, const std::string& params) {
  static std::map<std::string, std::unique_ptr<Harness>> all;
  auto& h = all[type + params];
  if (h) return *h;
  h = std::make_unique<Harness>();
  h->geom.cell_m = 0.5;
  h->geom.size_m = kSide * h->geom.cell_m;
  PluginContext pctx;
  pctx.grid = h->geom;
  pctx.labels = &h->labels;
  PluginRegistry reg({TERRAMRF_PLUGIN_DIR});
  h->plugin = reg.create(type);
  h->plugin->setIdentity(type, type);
  setParams(*h->plugin, params, pctx);
  h->grid = std::make_unique<TerrainGrid>(h->geom);
  h->ctx.frame = &h->frame;
  h->ctx.grid = h->grid.get();
  h->ctx.labels = &h->labels;
  h->ctx.energy = problem().em;
  dynamic_cast<Stage&>(*h->plugin).process(h->ctx);
  return *h;
}

void runOptimiser(benchmark::State& state, const std::string& type, const std::string& params) {
  const Problem& p = problem();
  Harness& h = harness(type, params);
  auto& stage = dynamic_cast<Stage&>(*h.plugin);
  FrameContext& ctx = h.ctx;
  TerrainGrid& grid = *h.grid;
  for (auto _ : state) {
    stage.process(ctx);
    benchmark::DoNotOptimize(grid.labels().data());
    benchmark::ClobberMemory();
  }
  std::vector<uint8_t> lab(grid.cells());
  for (std::size_t i = 0; i < lab.size(); ++i) lab[i] = static_cast<uint8_t>(grid.labels()[i] - 1);
  state.counters["energy"] = p.em.energy(lab);
  state.counters["initial_energy"] = p.em.energy(p.em.initial);
  state.counters["wrong_initial"] = p.wrong_initial;
  state.counters["wrong_final"] = wrongFraction(lab, p.truth);
  state.counters["iterations"] = ctx.optimiser.iterations;
  for (const auto& [key, value] : ctx.metrics)
    if (key.rfind(type + ".", 0) == 0 && key.find("energy") == std::string::npos)
      state.counters[key.substr(type.size() + 1)] = value;
}

void BM_Icm(benchmark::State& s) { runOptimiser(s, "icm", "{}"); }
void BM_AlphaExpansion(benchmark::State& s) { runOptimiser(s, "alpha_expansion", "{}"); }
void BM_AlphaExpansionNoPreIcm(benchmark::State& s) {
  runOptimiser(s, "alpha_expansion", "{pre_icm: false}");
}
// The expansions alone, and the expansions with 2×2 block moves: the differences to
// BM_AlphaExpansion are what the block and strip moves cost (their passes and the expansions
// after the moves they take).
void BM_AlphaExpansionNoBlockMoves(benchmark::State& s) {
  runOptimiser(s, "alpha_expansion", "{block_moves: false, strip_moves: false}");
}
void BM_AlphaExpansionNoStripMoves(benchmark::State& s) {
  runOptimiser(s, "alpha_expansion", "{strip_moves: false}");
}
void BM_Gibbs100Sweeps(benchmark::State& s) { runOptimiser(s, "gibbs", "{sweeps: 100, seed: 1}"); }
// The annealing alone: the scores averaged over its sweeps instead of the marginal sweeps, so the
// difference to BM_Gibbs100Sweeps is what the marginals at marginal_temperature cost.
void BM_Gibbs100SweepsNoMarginalSweeps(benchmark::State& s) {
  runOptimiser(s, "gibbs", "{sweeps: 100, burn_in: 20, marginal_sweeps: 0, seed: 1}");
}

BENCHMARK(BM_Icm)->Unit(benchmark::kMillisecond)->Repetitions(10)->ReportAggregatesOnly(true);
BENCHMARK(BM_AlphaExpansion)
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(10)
    ->ReportAggregatesOnly(true);
BENCHMARK(BM_AlphaExpansionNoPreIcm)
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(10)
    ->ReportAggregatesOnly(true);
BENCHMARK(BM_AlphaExpansionNoBlockMoves)
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(10)
    ->ReportAggregatesOnly(true);
BENCHMARK(BM_AlphaExpansionNoStripMoves)
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(10)
    ->ReportAggregatesOnly(true);
BENCHMARK(BM_Gibbs100Sweeps)
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(10)
    ->ReportAggregatesOnly(true);
BENCHMARK(BM_Gibbs100SweepsNoMarginalSweeps)
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(10)
    ->ReportAggregatesOnly(true);

}  // namespace
}  // namespace terramrf

BENCHMARK_MAIN();
