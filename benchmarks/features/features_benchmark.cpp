// Per-scan cost of the image features (paper 000 §4.3, Table 3 feature sets) on the KITTI object
// frame 000000 (HDL-64E, ~115k points; image_2 1224×370), 40 m grid, 0.5 m cells (80 × 80), one
// thread. Image decoding is done once in the fixture and not timed.
//   BM_L              laser part: grid binning + eigen_preclass + height_difference + roughness
//   BM_L_H / _FH / _C laser part + camera_fusion + haralick / homogeneity / colour (the paper's
//                     feature sets: H = Haralick, FH = homogeneity, C = colour)
//   BM_L_Icm, BM_L_H_Icm / _FH_Icm / _C_Icm
//                     the same + Potts/Gaussian energy (eq. 10–12) + ICM: a whole classification,
//                     the quantity of paper 000's Table 3 and of the targets. The model is
//                     fitted in the fixture to this frame's eq. 1 pre-classification (flat cells
//                     split into road and rough at their median roughness): it sets what the
//                     optimiser has to do, not an accuracy (the sweeps measure that)
//   BM_L_G            laser part + relative_height + height_above_ground (sweep feature set L+G)
//   BM_HeightAboveGround, BM_RelativeHeight, BM_EigenPreclass, BM_HeightDifference, BM_Roughness,
//   BM_Intensity (mean and standard deviation)
//                     one stage alone on an already binned grid
//   BM_Img_*          the image part alone (camera_fusion + the feature) on an already binned grid
//                     (…HomogeneityLocalMean: homogeneity with definition: local_mean)
//   BM_Haralick, BM_Haralick256
//                     haralick alone (levels 16, the default, and 256, the largest allowed) on
//                     cells fused once before timing: the co-occurrence counting and reading
//   BM_RoughnessColumnOrder  roughness alone on a simulator scan (seed 1, HDL-64E-like, ~226k
//                     points) stored in firing order, column after column, as drivers deliver
//                     them: each ring's points lie 64 apart in the cloud
// Run: build/bin/terramrf_bench_features
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <random>
#include <string>
#include <vector>

#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"

namespace terramrf {
namespace {

struct FeatureFixture {
  Frame frame;
  LabelSet labels = LabelSet::defaults();
  GridGeometry geom;  // 40 m, 0.5 m
  TerrainGrid grid;
  PluginRegistry reg{PluginRegistry::defaultSearchDirs()};
  PluginContext pctx;
  std::vector<std::unique_ptr<Plugin>> laser;
  std::vector<std::unique_ptr<Plugin>> ground;  // the G of L+G
  std::unique_ptr<Plugin> intensity;
  std::unique_ptr<Plugin> fusion, haralick, haralick256, homogeneity, homogeneity_local_mean,
      colour_rgb, colour_hsv, colour_lab;
  /// Energy + ICM per feature set ("L", "L+H", "L+FH", "L+C").
  std::map<std::string, std::vector<std::unique_ptr<Plugin>>> mrf;
  std::filesystem::path model_path;

  FeatureFixture() {
    cv::setNumThreads(1);  // one thread, as the per-scan budget assumes
    const char* env = std::getenv("TERRAMRF_DATA_DIR");
    const std::string data = env && *env ? env : TERRAMRF_DATA_DIR;
    pctx.config_dir = std::string(TERRAMRF_SOURCE_DIR) + "/configs";
    pctx.grid = geom;
    pctx.labels = &labels;
    auto source = make("semantickitti", "{path: " + data +
                                            "/kitti_object_fusion/training, use_images: true, "
                                            "use_labels: false, use_poses: false}");
    frame = static_cast<Source&>(*source).read(0);  // 000000: decoding happens here, untimed
    laser.push_back(make("eigen_preclass", "{}"));
    laser.push_back(make("height_difference", "{}"));
    laser.push_back(make("roughness", "{}"));
    ground.push_back(make("relative_height", "{}"));
    ground.push_back(make("height_above_ground", "{}"));
    intensity = make("intensity", "{std_layer: intensity_std}");
    fusion = make("camera_fusion", "{}");
    haralick = make("haralick", "{}");
    haralick256 = make("haralick", "{levels: 256}");
    homogeneity = make("homogeneity", "{}");
    homogeneity_local_mean = make("homogeneity", "{definition: local_mean}");
    colour_rgb = make("colour", "{space: rgb}");
    colour_hsv = make("colour", "{space: hsv}");
    colour_lab = make("colour", "{space: lab}");
    fitModel();
    const std::map<std::string, std::string> sets = {
        {"L", ""},
        {"L+H", ", haralick_asm, haralick_variance, haralick_idm"},
        {"L+FH", ", homogeneity"},
        {"L+C", ", colour_r, colour_g, colour_b"}};
    for (const auto& [set, extra] : sets) {
      mrf[set].push_back(make("potts_gaussian", "{model: " + model_path.string() +
                                                    ", features: [height_diff, roughness" + extra +
                                                    "], preclass_layer: preclass}"));
      mrf[set].push_back(make("icm", "{report_energy: false}"));
    }
  }
  ~FeatureFixture() {
    std::error_code ec;
    if (!model_path.empty()) std::filesystem::remove(model_path, ec);
  }
  /// Per class the mean and standard deviation of every feature layer over this frame's cells,
  /// classes from the eq. 1 pre-classification (flat cells below their median roughness road,
  /// the others rough), written as a model file in the temp directory.
  void fitModel() {
    FrameContext ctx;
    ctx.frame = &frame;
    ctx.grid = &grid;
    ctx.labels = &labels;
    grid.reset(geom);
    grid.binPoints(frame.points);
    for (auto& s : laser) static_cast<Stage&>(*s).process(ctx);
    for (Plugin* s : {fusion.get(), haralick.get(), homogeneity.get(), colour_rgb.get()})
      static_cast<Stage&>(*s).process(ctx);
    const Layer& pre = grid.layer("preclass");
    const Layer& rough = grid.layer("roughness");
    std::vector<float> flat_rough;
    for (std::size_t c = 0; c < grid.cells(); ++c)
      if (pre[c] == 1.f && !std::isnan(rough[c])) flat_rough.push_back(rough[c]);
    std::nth_element(flat_rough.begin(), flat_rough.begin() + flat_rough.size() / 2,
                     flat_rough.end());
    const float median = flat_rough.empty() ? 0.f : flat_rough[flat_rough.size() / 2];
    auto class_of = [&](std::size_t c) -> const char* {
      if (pre[c] == 2.f) return "obstacle";
      if (pre[c] != 1.f || std::isnan(rough[c])) return nullptr;
      return rough[c] < median ? "road" : "rough";
    };
    model_path = std::filesystem::temp_directory_path() /
                 ("terramrf_bench_model_" + std::to_string(std::random_device{}()) + ".yaml");
    std::ofstream out(model_path);
    out << "provenance: \"terramrf_bench_features: eq. 1 pre-classes of KITTI object 000000\"\n"
        << "classes:\n";
    const char* features[] = {"height_diff",       "roughness",    "haralick_asm",
                              "haralick_variance", "haralick_idm", "homogeneity",
                              "colour_r",          "colour_g",     "colour_b"};
    for (const char* cls : {"road", "rough", "obstacle"}) {
      out << "  " << cls << ":\n";
      for (const char* f : features) {
        const Layer& l = grid.layer(f);
        double n = 0, s = 0, s2 = 0;
        for (std::size_t c = 0; c < grid.cells(); ++c) {
          const char* k = class_of(c);
          if (!k || std::string(k) != cls || std::isnan(l[c])) continue;
          n += 1, s += l[c], s2 += double(l[c]) * l[c];
        }
        const double mean = n > 0 ? s / n : 0;
        const double sd = n > 1 ? std::sqrt(std::max(0.0, s2 / n - mean * mean)) : 1;
        out << "    " << f << ": {mean: " << mean << ", sigma: " << std::max(sd, 1e-3) << "}\n";
      }
    }
  }
  std::unique_ptr<Plugin> make(const char* type, const std::string& params) {
    auto p = reg.create(type);
    setParams(*p, params, pctx);
    return p;
  }
};

FeatureFixture& fixture() {
  static FeatureFixture f;
  return f;
}

void run(Plugin& p, FrameContext& ctx) { static_cast<Stage&>(p).process(ctx); }

/// A context on the fixture's frame with its points binned into a fresh grid.
FrameContext binnedContext(FeatureFixture& f) {
  FrameContext ctx;
  ctx.frame = &f.frame;
  ctx.grid = &f.grid;
  ctx.labels = &f.labels;
  f.grid.reset(f.geom);
  f.grid.binPoints(f.frame.points);
  return ctx;
}

/// Laser part (optional) then fusion and `feature` (optional), per iteration.
/// With `mrf` (a feature set of FeatureFixture::mrf), then its energy and ICM.
void bench(benchmark::State& state, bool with_laser, Plugin* feature, bool with_fusion = true,
           bool with_ground = false, const char* mrf = nullptr) {
  FeatureFixture& f = fixture();
  FrameContext ctx = binnedContext(f);
  for (auto _ : state) {
    if (with_laser) {
      f.grid.reset(f.geom);
      f.grid.binPoints(f.frame.points);
      for (auto& s : f.laser) run(*s, ctx);
      if (with_ground)
        for (auto& s : f.ground) run(*s, ctx);
    }
    if (with_fusion) run(*f.fusion, ctx);
    if (feature) run(*feature, ctx);
    if (mrf)
      for (auto& s : f.mrf.at(mrf)) run(*s, ctx);
    benchmark::ClobberMemory();
  }
  state.counters["points"] = double(f.frame.points.size());
  state.counters["cells"] = double(f.grid.cells());
  if (with_fusion && !f.grid.cellPixels().empty())
    state.counters["cell_pixels"] = double(f.grid.cellPixels()[0].pixels.size());
}

/// `stage` alone on cells fused once, untimed.
void benchFused(benchmark::State& state, Plugin& stage) {
  FeatureFixture& f = fixture();
  FrameContext ctx = binnedContext(f);
  run(*f.fusion, ctx);
  for (auto _ : state) {
    run(stage, ctx);
    benchmark::ClobberMemory();
  }
  state.counters["cell_pixels"] = double(f.grid.cellPixels()[0].pixels.size());
}

void BM_RoughnessColumnOrder(benchmark::State& state) {
  struct Sim {
    FeatureFixture& f = fixture();
    Frame frame;
    TerrainGrid grid;
    std::unique_ptr<Plugin> rough = f.make("roughness", "{}");
    Sim() {
      auto source = f.make("simulator", "{seed: 1, frames: 1, point_order: column}");
      frame = static_cast<Source&>(*source).read(0);
      grid.reset(f.geom);
      grid.binPoints(frame.points);
    }
  };
  static Sim sim;
  FrameContext ctx;
  ctx.frame = &sim.frame;
  ctx.grid = &sim.grid;
  ctx.labels = &sim.f.labels;
  for (auto _ : state) {
    run(*sim.rough, ctx);
    benchmark::ClobberMemory();
  }
  state.counters["points"] = double(sim.frame.points.size());
}
void BM_L(benchmark::State& s) { bench(s, true, nullptr, false); }
void BM_L_G(benchmark::State& s) { bench(s, true, nullptr, false, true); }
void BM_HeightAboveGround(benchmark::State& s) { bench(s, false, fixture().ground[1].get(), false); }
void BM_RelativeHeight(benchmark::State& s) { bench(s, false, fixture().ground[0].get(), false); }
void BM_EigenPreclass(benchmark::State& s) { bench(s, false, fixture().laser[0].get(), false); }
void BM_HeightDifference(benchmark::State& s) { bench(s, false, fixture().laser[1].get(), false); }
void BM_Roughness(benchmark::State& s) { bench(s, false, fixture().laser[2].get(), false); }
void BM_Intensity(benchmark::State& s) { bench(s, false, fixture().intensity.get(), false); }
void BM_L_H(benchmark::State& s) { bench(s, true, fixture().haralick.get()); }
void BM_L_FH(benchmark::State& s) { bench(s, true, fixture().homogeneity.get()); }
void BM_L_C(benchmark::State& s) { bench(s, true, fixture().colour_rgb.get()); }
void BM_L_Icm(benchmark::State& s) { bench(s, true, nullptr, false, false, "L"); }
void BM_L_H_Icm(benchmark::State& s) {
  bench(s, true, fixture().haralick.get(), true, false, "L+H");
}
void BM_L_FH_Icm(benchmark::State& s) {
  bench(s, true, fixture().homogeneity.get(), true, false, "L+FH");
}
void BM_L_C_Icm(benchmark::State& s) {
  bench(s, true, fixture().colour_rgb.get(), true, false, "L+C");
}
void BM_Img_Fusion(benchmark::State& s) { bench(s, false, nullptr); }
void BM_Img_FusionHaralick(benchmark::State& s) { bench(s, false, fixture().haralick.get()); }
void BM_Haralick(benchmark::State& s) { benchFused(s, *fixture().haralick); }
void BM_Haralick256(benchmark::State& s) { benchFused(s, *fixture().haralick256); }
void BM_Img_FusionHomogeneity(benchmark::State& s) { bench(s, false, fixture().homogeneity.get()); }
void BM_Img_FusionHomogeneityLocalMean(benchmark::State& s) {
  bench(s, false, fixture().homogeneity_local_mean.get());
}
void BM_Img_FusionColourRgb(benchmark::State& s) { bench(s, false, fixture().colour_rgb.get()); }
void BM_Img_FusionColourHsv(benchmark::State& s) { bench(s, false, fixture().colour_hsv.get()); }
void BM_Img_FusionColourLab(benchmark::State& s) { bench(s, false, fixture().colour_lab.get()); }

#define TERRAMRF_BENCH(fn) \
  BENCHMARK(fn)->Unit(benchmark::kMillisecond)->Repetitions(10)->ReportAggregatesOnly(true)
TERRAMRF_BENCH(BM_L);
TERRAMRF_BENCH(BM_L_G);
TERRAMRF_BENCH(BM_HeightAboveGround);
TERRAMRF_BENCH(BM_RelativeHeight);
TERRAMRF_BENCH(BM_EigenPreclass);
TERRAMRF_BENCH(BM_HeightDifference);
TERRAMRF_BENCH(BM_Roughness);
TERRAMRF_BENCH(BM_Intensity);
TERRAMRF_BENCH(BM_RoughnessColumnOrder);
TERRAMRF_BENCH(BM_L_H);
TERRAMRF_BENCH(BM_L_FH);
TERRAMRF_BENCH(BM_L_C);
TERRAMRF_BENCH(BM_L_Icm);
TERRAMRF_BENCH(BM_L_H_Icm);
TERRAMRF_BENCH(BM_L_FH_Icm);
TERRAMRF_BENCH(BM_L_C_Icm);
TERRAMRF_BENCH(BM_Img_Fusion);
TERRAMRF_BENCH(BM_Img_FusionHaralick);
TERRAMRF_BENCH(BM_Haralick);
TERRAMRF_BENCH(BM_Haralick256);
TERRAMRF_BENCH(BM_Img_FusionHomogeneity);
TERRAMRF_BENCH(BM_Img_FusionHomogeneityLocalMean);
TERRAMRF_BENCH(BM_Img_FusionColourRgb);
TERRAMRF_BENCH(BM_Img_FusionColourHsv);
TERRAMRF_BENCH(BM_Img_FusionColourLab);

}  // namespace
}  // namespace terramrf

BENCHMARK_MAIN();
