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
  const std::string frames = takeOption(a, "--frames");
  const std::string seed = takeOption(a, "--seed");
  const std::string config = takeOption(a, "--config");
  if (out.empty() || !a.empty()) {
    std::cerr << "usage: terramrf simulate --out DIR [--frames N] [--seed S] [--config CONFIG]\n"
                 "  --config takes the simulator parameters from a config whose source is the "
                 "simulator\n";
    return kUsage;
  }
  PluginRegistry reg(PluginRegistry::defaultSearchDirs());
  std::unique_ptr<Source> source;
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
    if (!frames.empty() || !seed.empty()) {
      std::ostringstream ov;
      ov << "{" << (frames.empty() ? "" : "frames: " + frames)
         << (frames.empty() || seed.empty() ? "" : ", ") << (seed.empty() ? "" : "seed: " + seed)
         << "}";
      setParams(*source, ov.str(), PluginContext{});
    }
  } else {
    auto plugin = reg.create("simulator");
    std::ostringstream params;
    params << "{" << (frames.empty() ? "" : "frames: " + frames)
           << (frames.empty() || seed.empty() ? "" : ", ") << (seed.empty() ? "" : "seed: " + seed)
           << "}";
    PluginContext ctx;
    LabelSet labels = LabelSet::defaults();
    ctx.labels = &labels;
    setParams(*plugin, params.str(), ctx);
    source.reset(static_cast<Source*>(plugin.release()));
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
