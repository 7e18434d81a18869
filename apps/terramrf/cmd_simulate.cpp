// terramrf simulate: runs the simulator source and writes every frame in SemanticKITTI/KITTI
// layout, so the real-data readers (and other tools) see exactly the scenes the demo classifies.
#include <filesystem>
#include <iostream>
#include <sstream>

#include "commands.hpp"
#include "terramrf/config.hpp"
#include "terramrf/io/kitti_writer.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"

namespace terramrf::cli {

int cmdSimulate(const Args& args) {
  Args a = args;
  const std::string out = takeOption(a, "--out");
  const std::string config = takeOption(a, "--config");
  constexpr std::size_t kUnset = static_cast<std::size_t>(-1);
  std::size_t frames = kUnset, seed = kUnset;
  if (!takeCount(a, "--frames", "simulate", 1, frames) ||
      !takeCount(a, "--seed", "simulate", 0, seed))
    return kUsage;
  if (out.empty() || !a.empty()) {
    std::cerr << "usage: terramrf simulate --out DIR [--frames N] [--seed S] [--config CONFIG]\n"
                 "  --config takes the simulator parameters from a config whose source is the "
                 "simulator\n";
    return kUsage;
  }
  // --frames and --seed replace the config's (or the defaults).
  std::ostringstream overrides;
  overrides << "{";
  if (frames != kUnset) overrides << "frames: " << frames << (seed != kUnset ? ", " : "");
  if (seed != kUnset) overrides << "seed: " << seed;
  overrides << "}";
  PluginRegistry reg(PluginRegistry::defaultSearchDirs());
  std::unique_ptr<Source> source;
  LabelSet labels = LabelSet::defaults();
  PluginContext ctx;
  ctx.labels = &labels;
  if (!config.empty()) {
    Pipeline p;
    try {
      p = loadPipeline(config, LoadOptions{}, reg);
    } catch (const ConfigError& e) {
      for (const auto& d : e.diagnostics()) std::cerr << d.str() << "\n";
      return kUsage;
    }
    if (p.source->type() != "simulator") {
      std::cerr << config << ": the source is '" << p.source->type()
                << "', but simulate needs a simulator source\n";
      return kUsage;
    }
    source = std::move(p.source);
  } else {
    source.reset(static_cast<Source*>(reg.create("simulator").release()));
  }
  // Configured (again) with the default label set whatever the config lists: the files hold
  // the default project classes (docs/plugins/simulator.md), and a config's own set renumbered
  // the pixel truth only when no --frames or --seed configured it once more.
  try {
    setParams(*source, overrides.str(), ctx);
  } catch (const std::exception& e) {  // e.g. --seed beyond the simulator's range
    std::cerr << "terramrf simulate: " << e.what() << "\n";
    return kUsage;
  }
  // Frames of another run (another seed, more frames) would stay beside these and be read as
  // one sequence; nothing is overwritten, the folder is refused.
  for (const char* held : {"velodyne", "labels", "rings", "image_2", "image_3", "image_2_truth",
                           "calib.txt", "times.txt", "poses.txt"}) {
    std::error_code ec;
    if (std::filesystem::exists(std::filesystem::path(out) / held, ec)) {
      std::cerr << "terramrf simulate: " << out << " already holds a sequence (" << held
                << "); frames of this run would mix with it: give an empty or new folder\n";
      return kUsage;
    }
  }
  KittiSequenceWriter writer(out);
  const std::size_t n = source->size();
  for (std::size_t i = 0; i < n; ++i) {
    writer.write(source->read(i));
    std::fprintf(stderr, "\rsimulate: %zu/%zu", i + 1, n);
  }
  writer.finish();
  std::fprintf(stderr, "\n");
  std::cout << "wrote " << n << " frame(s) to " << std::filesystem::absolute(out).string()
            << " (SemanticKITTI layout; labels use configs/label_maps/simulator.yaml)\n";
  return kOk;
}

}  // namespace terramrf::cli
