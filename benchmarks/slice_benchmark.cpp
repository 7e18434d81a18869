// Per-scan classification through the real plugins as the pipeline runs them, grid binning
// included, reading excluded (except in BM_ReadScan and BM_FileToLabels_LG_Icm):
//   BM_Grid:                   grid binning alone (cell of every point, per-cell point lists)
//   BM_GridPreclassHeightDiff: binning + eq. 1 pre-classification + height difference
//   BM_Slice:                  the above + Potts/Gaussian energy + ICM (the foundation slice)
//   BM_L_Icm / BM_L_AlphaExpansion:
//       paper 000's laser set L: pre-class + height difference + roughness + energy + optimiser
//   BM_LG_Icm / BM_LG_AlphaExpansion:
//       configs/semantickitti.yaml: height difference, roughness on a log scale, relative height,
//       height above ground (no eq. 1 pre-classification), + energy + optimiser;
//       BM_LG_AlphaExpansionNoBlockMoves with the expansions alone, and
//       BM_LG_AlphaExpansionNoStripMoves without the strip moves (expansions and 2×2 blocks)
//   BM_ReadScan: the semantickitti reader alone (.bin read + ring recovery), as the CLI runs it
//   BM_RecoverRings: ring recovery alone on that scan's points
//   BM_FileToLabels_LG_Icm: BM_ReadScan + BM_LG_Icm, file to labelled grid (what a ground
//       segmenter that reads the same file is held against, docs/benchmarks.md)
//   BM_FileToLabels_LG_Icm_RingsGiven: the same from a copy of the scan whose rings come with it
//       (rings/000000.bin, as the simulator writes them and a driver's ring field delivers them):
//       the reader skips ring recovery
// Data: SemanticKITTI sequence 00 frame 000000 (HDL-64E, 124668 points; rings recovered by the
// reader), 40 m grid, 0.5 m cells (80 × 80), one thread.
#include <benchmark/benchmark.h>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "terramrf/io/kitti_writer.hpp"
#include "terramrf/io/ring_recovery.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"

namespace terramrf {
namespace {

using Chain = std::vector<std::unique_ptr<Plugin>>;

struct SliceFixture {
  Frame frame;
  LabelSet labels = LabelSet::defaults();
  GridGeometry geom;
  TerrainGrid grid;
  PluginRegistry reg{PluginRegistry::defaultSearchDirs()};
  PluginContext ctx;
  std::map<std::string, Chain> chains;
  std::unique_ptr<Plugin> source;
  std::unique_ptr<Plugin> source_with_rings;  // a copy of the scan with its rings (see above)
  std::filesystem::path rings_dir;

  SliceFixture() {
    const char* env = std::getenv("TERRAMRF_DATA_DIR");
    const std::string data = env && *env ? env : TERRAMRF_DATA_DIR;
    ctx.config_dir = std::string(TERRAMRF_SOURCE_DIR) + "/configs";
    ctx.grid = geom;
    ctx.labels = &labels;
    source = make("semantickitti",
                  "{path: " + data + "/semantickitti_seq00_000000-000005, use_labels: false}");
    frame = static_cast<Source&>(*source).read(0);
    makeSourceWithRings();
    const std::string l_energy =
        "{model: models/laser_semantickitti.yaml, features: [height_diff, roughness], "
        "preclass_layer: preclass}";
    const std::string lg_energy =
        "{model: models/laser_semantickitti.yaml, features: [height_diff, log_roughness, "
        "relative_height, height_above_ground], preclass_layer: ''}";
    chains["slice"] = chain({{"eigen_preclass", "{}"},
                             {"height_difference", "{}"},
                             {"potts_gaussian",
                              "{model: models/laser_simulator.yaml, features: [height_diff, "
                              "normal_eigenvalue], preclass_layer: preclass}"},
                             {"icm", "{report_energy: false}"}});
    // configs/semantickitti.yaml's stages, then the optimiser `opt` with `params`.
    auto lg = [&](const std::string& opt, const std::string& params) {
      return chain({{"height_difference", "{}"},
                    {"roughness", "{}"},
                    {"relative_height", "{}"},
                    {"height_above_ground", "{}"},
                    {"log_transform", "{input: roughness}"},
                    {"potts_gaussian", lg_energy},
                    {opt, params}});
    };
    for (const char* opt : {"icm", "alpha_expansion"}) {
      const std::string params = std::string(opt) == "icm" ? "{report_energy: false}" : "{}";
      chains[std::string("L_") + opt] = chain({{"eigen_preclass", "{}"},
                                               {"height_difference", "{}"},
                                               {"roughness", "{}"},
                                               {"potts_gaussian", l_energy},
                                               {opt, params}});
      chains[std::string("LG_") + opt] = lg(opt, params);
    }
    // The block and strip moves' share of α-expansion on a real scan.
    chains["LG_alpha_expansion_no_block_moves"] =
        lg("alpha_expansion", "{block_moves: false, strip_moves: false}");
    chains["LG_alpha_expansion_no_strip_moves"] = lg("alpha_expansion", "{strip_moves: false}");
  }
  ~SliceFixture() {
    std::error_code ec;
    if (!rings_dir.empty()) std::filesystem::remove_all(rings_dir, ec);
  }
  /// Frame 0 with the rings the reader recovered for it, written as a sequence in the temp
  /// directory (velodyne/ and rings/, as simulated sequences are written).
  void makeSourceWithRings() {
    namespace fs = std::filesystem;
    rings_dir = fs::temp_directory_path() /
                ("terramrf_bench_rings_" + std::to_string(std::random_device{}()));
    KittiSequenceWriter writer(rings_dir.string());
    writer.write(frame);
    writer.finish();
    source_with_rings =
        make("semantickitti", "{path: " + rings_dir.string() + ", use_labels: false}");
  }
  std::unique_ptr<Plugin> make(const std::string& type, const std::string& params) {
    auto p = reg.create(type);
    setParams(*p, params, ctx);
    return p;
  }
  Chain chain(const std::vector<std::pair<std::string, std::string>>& stages) {
    Chain c;
    for (const auto& [type, params] : stages) c.push_back(make(type, params));
    return c;
  }
  void run(FrameContext& fc, const Chain& c, std::size_t n_stages) {
    grid.reset(geom);
    grid.binPoints(frame.points);
    for (std::size_t s = 0; s < n_stages && s < c.size(); ++s)
      static_cast<Stage&>(*c[s]).process(fc);
  }
};

SliceFixture& fixture() {
  static SliceFixture f;
  return f;
}

/// Runs the first n_stages of chain `name` on frame 0; with `from` set, each run reads the frame
/// from that source first.
void runChain(benchmark::State& state, const std::string& name, std::size_t n_stages = 100,
              Plugin* from = nullptr) {
  SliceFixture& f = fixture();
  const Chain& c = f.chains.at(name);
  FrameContext fc;
  fc.frame = &f.frame;
  fc.grid = &f.grid;
  fc.labels = &f.labels;
  for (auto _ : state) {
    if (from) f.frame = static_cast<Source&>(*from).read(0);
    f.run(fc, c, n_stages);
    benchmark::DoNotOptimize(f.grid.labels().data());
  }
  state.counters["points"] = static_cast<double>(f.frame.points.size());
  state.counters["cells"] = static_cast<double>(f.grid.cells());
}

void BM_GridPreclassHeightDiff(benchmark::State& s) { runChain(s, "slice", 2); }
void BM_Slice(benchmark::State& s) { runChain(s, "slice"); }
void BM_Grid(benchmark::State& s) { runChain(s, "slice", 0); }
void BM_L_Icm(benchmark::State& s) { runChain(s, "L_icm"); }
void BM_L_AlphaExpansion(benchmark::State& s) { runChain(s, "L_alpha_expansion"); }
void BM_LG_Icm(benchmark::State& s) { runChain(s, "LG_icm"); }
void BM_LG_AlphaExpansion(benchmark::State& s) { runChain(s, "LG_alpha_expansion"); }
void BM_FileToLabels_LG_Icm(benchmark::State& s) {
  runChain(s, "LG_icm", 100, fixture().source.get());
}
void BM_FileToLabels_LG_Icm_RingsGiven(benchmark::State& s) {
  SliceFixture& f = fixture();
  runChain(s, "LG_icm", 100, f.source_with_rings.get());
  // Restore frame 0 as read with recovered rings, for the benchmarks that run after this one.
  f.frame = static_cast<Source&>(*f.source).read(0);
}
void BM_ReadScan(benchmark::State& state) {
  SliceFixture& f = fixture();
  for (auto _ : state) {
    f.frame = static_cast<Source&>(*f.source).read(0);
    benchmark::DoNotOptimize(f.frame.points.size());
  }
  state.counters["points"] = static_cast<double>(f.frame.points.size());
}
// Ring recovery alone (scan order), on the points of frame 0 without their rings.
void BM_RecoverRings(benchmark::State& state) {
  SliceFixture& f = fixture();
  PointCloud bare = f.frame.points;
  bare.ring.clear();
  PointCloud c;
  for (auto _ : state) {
    state.PauseTiming();
    c = bare;
    state.ResumeTiming();
    benchmark::DoNotOptimize(recoverRings(c).rings_found);
  }
  state.counters["points"] = static_cast<double>(bare.size());
}
void BM_LG_AlphaExpansionNoBlockMoves(benchmark::State& s) {
  runChain(s, "LG_alpha_expansion_no_block_moves");
}
void BM_LG_AlphaExpansionNoStripMoves(benchmark::State& s) {
  runChain(s, "LG_alpha_expansion_no_strip_moves");
}

#define TERRAMRF_BENCH(fn) \
  BENCHMARK(fn)->Unit(benchmark::kMillisecond)->Repetitions(10)->ReportAggregatesOnly(true)
TERRAMRF_BENCH(BM_GridPreclassHeightDiff);
TERRAMRF_BENCH(BM_Slice);
TERRAMRF_BENCH(BM_Grid);
TERRAMRF_BENCH(BM_L_Icm);
TERRAMRF_BENCH(BM_L_AlphaExpansion);
TERRAMRF_BENCH(BM_LG_Icm);
TERRAMRF_BENCH(BM_LG_AlphaExpansion);
TERRAMRF_BENCH(BM_LG_AlphaExpansionNoBlockMoves);
TERRAMRF_BENCH(BM_LG_AlphaExpansionNoStripMoves);
TERRAMRF_BENCH(BM_ReadScan);
TERRAMRF_BENCH(BM_RecoverRings);
TERRAMRF_BENCH(BM_FileToLabels_LG_Icm);
TERRAMRF_BENCH(BM_FileToLabels_LG_Icm_RingsGiven);

}  // namespace
}  // namespace terramrf

int main(int argc, char** argv) {
#if defined(__GLIBC__)
  // As the terramrf CLI does (apps/terramrf/main.cpp): a scan's arrays stay in the heap between
  // reads instead of page-faulting in afresh from mmap.
  mallopt(M_MMAP_THRESHOLD, 64 << 20);
  mallopt(M_TRIM_THRESHOLD, 256 << 20);
#endif
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
