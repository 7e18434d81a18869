// terramrf mesh CONFIG [--out DIR] [--data DIR] [--first N] [--limit N] [--read-ahead N]
// [--no-progress]:
// runs the config with the textured_mesh output (paper 004) ensured — added with its defaults
// when the config does not list one — and prints where the mesh went.
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <variant>

#include "commands.hpp"
#include "terramrf/atomic_file.hpp"
#include "terramrf/config.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/pipeline.hpp"

namespace terramrf::cli {

int cmdMesh(const Args& args) {
  RunArgs ra;
  if (parseRunArgs(args, "mesh", ra) != kOk) return kUsage;
  const std::string& config = ra.config;
  const RunOptions& ro = ra.run;
  PluginRegistry reg(PluginRegistry::defaultSearchDirs());
  Pipeline p;
  if (!loadOrReport(config, ra.load, reg, p)) return kUsage;
  if (!firstFrameInRange(p, ro, "mesh")) return kUsage;
  bool have = false;
  for (const auto& o : p.outputs) have = have || o->type() == "textured_mesh";
  if (!have) {
    if (!reg.find("textured_mesh")) {
      std::cerr << "terramrf mesh: the textured_mesh output plugin is not installed; run "
                   "'terramrf plugins'\n";
      return kError;
    }
    std::unique_ptr<Plugin> pl = reg.create("textured_mesh");
    PluginContext ctx;
    ctx.config_dir = std::filesystem::path(config).parent_path().string();
    ctx.output_dir = p.output_dir;
    ctx.grid = p.grid;
    ctx.labels = p.labels.get();
    setParams(*pl, "{}", ctx);
    pl->setIdentity("textured_mesh", "textured_mesh");
    if (!dynamic_cast<Output*>(pl.get())) {
      std::cerr << "terramrf mesh: plugin 'textured_mesh' is not an output\n";
      return kError;
    }
    p.outputs.emplace_back(static_cast<Output*>(pl.release()));
  }
  // Where each textured_mesh output exports: its own `subdir` (default "mesh"), not a fixed name.
  std::string mesh_dirs;
  for (const auto& o : p.outputs) {
    if (o->type() != "textured_mesh") continue;
    std::string subdir = "mesh";
    for (const auto& spec : declaredParams(*o)) {
      if (spec.name != "subdir" || !spec.get) continue;
      const ParamValue v = spec.get();
      if (const auto* s = std::get_if<std::string>(&v)) subdir = *s;
    }
    mesh_dirs +=
        (mesh_dirs.empty() ? "" : ", ") + (std::filesystem::path(p.output_dir) / subdir).string();
  }
  std::error_code ec;
  std::filesystem::create_directories(p.output_dir, ec);
  if (ec || !std::filesystem::is_directory(p.output_dir)) {
    std::cerr << "terramrf mesh: output folder '" << p.output_dir << "' cannot be created ("
              << (ec ? ec.message() : "a file of that name exists") << ")\n";
    return kError;
  }
  std::cerr << "terramrf: " << framesToRead(*p.source) << ", mesh in " << mesh_dirs << "\n";
  RunResult r;
  RunOptions streamed = ro;  // metrics to metrics.csv as the frames complete
  streamed.metrics_csv = p.output_dir + "/metrics.csv";
  try {
    r = runPipeline(p, streamed);
  } catch (const std::exception& e) {
    std::cerr << "terramrf mesh: " << e.what() << "\n";
    return kError;
  }
  // Before the reports add theirs; a stage's end() error ("stage '…'") exports nothing less.
  const bool exported =
      std::none_of(r.output_errors.begin(), r.output_errors.end(),
                   [](const std::string& e) { return e.rfind("output '", 0) == 0; });
  writeReportsOf(p.output_dir, r);
  std::cout << framesOk(r, *p.source) << "\n";
  for (const auto& [id, why] : r.summary.failed) std::cout << "  " << id << ": " << why << "\n";
  for (const auto& e : r.output_errors) std::cout << "error: " << e << "\n";
  if (const std::string ego = egomotionErrorText(r); !ego.empty())
    std::cout << ego << " (per frame in metrics.csv)\n";
  printInterruption(r);
  if (exported) std::cout << "mesh: " << mesh_dirs << " (report.md)\n";
  return r.exitCode();
}

}  // namespace terramrf::cli
