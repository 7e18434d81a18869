#include <filesystem>
#include <iostream>
#include <sstream>

#include "commands.hpp"
#include "terramrf/atomic_file.hpp"
#include "terramrf/config.hpp"
#include "terramrf/pipeline.hpp"
#include "terramrf/stop_request.hpp"
#include "terramrf/sweep.hpp"

namespace terramrf::cli {

namespace {
bool parseConfigArgs(Args& a, const char* cmd, std::string& config) {
  if (a.empty() || a[0].rfind("--", 0) == 0) {
    std::cerr << "usage: terramrf " << cmd << " CONFIG ...\n";
    return false;
  }
  config = a[0];
  a.erase(a.begin());
  return true;
}
void printProblems(const PluginRegistry& reg) {
  for (const auto& p : reg.problems()) std::cerr << "warning: " << p << "\n";
}
}  // namespace

int cmdValidate(const Args& args) {
  Args a = args;
  std::string config;
  if (!parseConfigArgs(a, "validate", config)) return kUsage;
  LoadOptions lo;
  lo.data_override = takeOption(a, "--data");
  if (!a.empty()) {
    std::cerr << "terramrf validate: unexpected argument '" << a[0] << "'\n";
    return kUsage;
  }
  PluginRegistry reg(PluginRegistry::defaultSearchDirs());
  try {
    if (isSweepFile(config)) {
      if (!lo.data_override.empty()) {
        std::cerr << "terramrf validate: --data is for pipeline configs; a sweep names its "
                     "datasets' folders itself\n";
        return kUsage;
      }
      const SweepPlan plan = planSweep(config);
      std::cout << config << ": ok (sweep '" << plan.name << "': " << plan.runs.size()
                << " run(s), " << plan.skipped.size() << " skipped, " << plan.selection_runs.size()
                << " validation run(s) of select:)\n";
      for (const auto& [run, why] : plan.skipped)
        std::cout << "  skip " << run << ": " << why << "\n";
      for (const auto& n : plan.notes) std::cout << "note: " << n << "\n";
      return kOk;
    }
    Pipeline p = loadPipeline(config, lo, reg);
    printProblems(reg);
    // What `train` will check of its split: section.
    const std::vector<std::string> notes = checkTrainSplit(config);
    std::cout << config << ": ok (" << p.stages.size() << " stages, " << p.outputs.size()
              << " outputs, "
              << (p.source->streaming() ? "a stream of frames"
                                        : std::to_string(p.source->size()) + " frames")
              << ")\n";
    for (const auto& n : notes) std::cout << "note: " << n << "\n";
    return kOk;
  } catch (const ConfigError& e) {
    printProblems(reg);
    for (const auto& d : e.diagnostics()) std::cerr << d.str() << "\n";
    std::cerr << e.diagnostics().size() << " error(s) in " << config << "\n";
    return kUsage;
  }
}

int parseRunArgs(const Args& args, const char* command, RunArgs& out) {
  Args a = args;
  if (!parseConfigArgs(a, command, out.config)) return kUsage;
  out.load.data_override = takeOption(a, "--data");
  out.load.output_dir = takeOption(a, "--out");
  if (!takeCount(a, "--first", command, 0, out.run.first) ||
      !takeCount(a, "--limit", command, 1, out.run.limit))
    return kUsage;
  if (!takeCount(a, "--read-ahead", command, 0, out.run.read_ahead)) return kUsage;
  if (out.run.read_ahead != RunOptions::kAutoReadAhead && out.run.read_ahead > 64) {
    // Each frame read ahead is held in memory (a KITTI scan with its image: ~3 MB).
    std::cerr << "terramrf " << command << ": --read-ahead: expected 0 to 64 frames, got "
              << out.run.read_ahead << "\n";
    return kUsage;
  }
  out.run.progress = !takeFlag(a, "--no-progress");
  if (!a.empty()) {
    std::cerr << "terramrf " << command << ": unexpected argument '" << a[0] << "'\n";
    return kUsage;
  }
  return kOk;
}

bool loadOrReport(const std::string& config, const LoadOptions& options, PluginRegistry& registry,
                  Pipeline& out) {
  // Plugin files that did not load (or a config's plugin_path copy that shadows a built-in):
  // without them an "unknown plugin type" would not say why.
  try {
    out = loadPipeline(config, options, registry);
    printProblems(registry);
    return true;
  } catch (const ConfigError& e) {
    printProblems(registry);
    for (const auto& d : e.diagnostics()) std::cerr << d.str() << "\n";
    std::cerr << e.diagnostics().size() << " error(s) in " << config << "; nothing was run\n";
    return false;
  }
}

bool firstFrameInRange(const Pipeline& p, const RunOptions& ro, const char* command) {
  if (p.source->streaming()) return true;
  const std::size_t n = p.source->size();
  if (ro.first == 0 || ro.first < n) return true;
  std::cerr << "terramrf " << command << ": --first " << ro.first << ": the source ("
            << p.source->type() << ") has " << n << " frame(s)"
            << (n ? ", numbered 0 to " + std::to_string(n - 1) : std::string()) << "\n";
  return false;
}

std::string framesToRead(const Source& source) {
  if (source.streaming())
    return "frames from the stream of " + source.type() + " (until it ends; Ctrl-C stops it)";
  return std::to_string(source.size()) + " frame(s) from " + source.type();
}

std::string framesOk(const RunResult& r, const Source& source) {
  return std::to_string(r.summary.frames_ok) +
         (source.streaming() ? std::string() : " of " + std::to_string(r.frames_total)) +
         " frame(s) ok";
}

int cmdRun(const Args& args) {
  RunArgs ra;
  if (parseRunArgs(args, "run", ra) != kOk) return kUsage;
  const std::string& config = ra.config;
  const RunOptions& ro = ra.run;
  PluginRegistry reg(PluginRegistry::defaultSearchDirs());
  Pipeline p;
  if (!loadOrReport(config, ra.load, reg, p)) return kUsage;
  if (!firstFrameInRange(p, ro, "run")) return kUsage;
  std::cerr << "terramrf: " << framesToRead(*p.source) << ", outputs in " << p.output_dir << "\n";
  // Streamed as the frames complete: a long run or a stream keeps none of them in memory.
  RunOptions streamed = ro;
  streamed.metrics_csv = p.output_dir + "/metrics.csv";
  RunResult r = runPipeline(p, streamed);
  const std::string table = timingTable(r);
  writeReportsOf(p.output_dir, r);
  std::cout << "\nPer-stage timing over " << r.summary.frames_ok << " scan(s):\n" << table;
  std::cout << "\n" << framesOk(r, *p.source);
  if (!r.summary.failed.empty()) {
    std::cout << ", " << r.summary.failed.size() << " failed and skipped:\n";
    for (const auto& [id, why] : r.summary.failed) std::cout << "  " << id << ": " << why << "\n";
  } else {
    std::cout << "\n";
  }
  // Every frame may be ok and the run still fail (exit 4): the summary says why, not only stderr.
  for (const auto& e : r.output_errors) std::cout << "error: " << e << "\n";
  if (r.points_dropped_nonfinite + r.points_dropped_no_return > 0)
    std::cout << "points dropped while reading: " << r.points_dropped_nonfinite
              << " with NaN/inf values, " << r.points_dropped_no_return
              << " no-returns at the origin\n";
  if (!r.empty_frames.empty())
    std::cout << r.empty_frames.size() << " frame(s) had no usable point (all cells unknown)\n";
  if (!r.frames_outside_grid.empty())
    std::cout << r.frames_outside_grid.size()
              << " frame(s) had under 1 % of their points inside the grid (nearly all cells "
                 "unknown; is the cloud in the sensor frame?)\n";
  if (const std::string ego = egomotionErrorText(r); !ego.empty())
    std::cout << ego << " (per frame in metrics.csv)\n";
  printInterruption(r);
  std::cout << "outputs: " << p.output_dir << "\n";
  return r.exitCode();
}

void writeReportsOf(const std::string& output_dir, RunResult& r) {
  try {
    writeRunReports(output_dir, r);
  } catch (const std::exception& e) {
    const std::string why = std::string("the run's reports (timing.md, metrics.csv): ") + e.what();
    std::cerr << "terramrf: writing " << why << "\n";
    r.output_errors.push_back(why);
  }
}

void printInterruption(const RunResult& r) {
  const std::string stopped = interruptionText(r.summary);
  if (stopped.empty()) return;
  std::cout << "run " << stopped
            << ": the outputs' summaries and timing.md cover those frames only (exit status "
            << r.exitCode() << ")\n";
}

int cmdPlugins(const Args&) {
  PluginRegistry reg(PluginRegistry::defaultSearchDirs());
  std::cout << "Plugin folders:\n";
  for (const auto& d : reg.dirs()) std::cout << "  " << d << "\n";
  std::cout << "\n";
  std::string kind;
  for (const auto& info : reg.list()) {
    if (kind != toString(info.kind)) {
      kind = toString(info.kind);
      std::cout << kind << ":\n";
    }
    std::printf("  %-22s %s\n", info.type.c_str(), info.summary.c_str());
  }
  std::fflush(stdout);
  printProblems(reg);
  return kOk;
}

int cmdDescribe(const Args& args) {
  if (args.size() != 1) {
    std::cerr << "usage: terramrf describe TYPE\n";
    return kUsage;
  }
  PluginRegistry reg(PluginRegistry::defaultSearchDirs());
  const PluginInfo* info = reg.find(args[0]);
  if (!info) {
    std::cerr << "terramrf describe: unknown plugin type '" << args[0]
              << "'; run 'terramrf plugins'\n";
    return kUsage;
  }
  auto plugin = reg.create(args[0]);
  ParamDecl d;
  plugin->declare(d);
  std::cout << info->type << " (" << toString(info->kind) << "): " << info->summary << "\n";
  std::cout << "library: " << info->library << "\n\nparameters:\n";
  if (d.specs().empty()) std::cout << "  (none)\n";
  for (const auto& s : d.specs()) {
    std::cout << "  " << s.name << " (" << toString(s.type) << ")";
    if (s.required) std::cout << ", required";
    else std::cout << ", default " << toYaml(s.default_value);
    if (s.min || s.max) {
      // Exact, as the validator's messages: 1e-09 stays 1e-09, 4194304 is not 4.1943e+06.
      auto bound = [](const auto& b, const char* none) {
        return b ? numberText(double(*b)) : std::string(none);
      };
      std::cout << ", range [" << bound(s.min, "-inf") << ", " << bound(s.max, "inf") << "]";
    }
    if (!s.unit.empty()) std::cout << ", unit " << s.unit;
    if (!s.choices.empty()) {
      std::cout << ", one of {";
      for (std::size_t k = 0; k < s.choices.size(); ++k) std::cout << (k ? ", " : "") << s.choices[k];
      std::cout << "}";
    }
    if (s.existing_path) std::cout << ", must exist";
    if (s.unique) std::cout << ", each entry once";
    std::cout << "\n      " << s.doc << "\n";
  }
  return kOk;
}

}  // namespace terramrf::cli
