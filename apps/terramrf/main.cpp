// terramrf: command-line entry point. Commands live in their own files (cmd_*.cpp).
#include <cstdio>
#include <exception>
#include <iostream>
#include <string>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "commands.hpp"
#include "terramrf/stop_request.hpp"

namespace {

using terramrf::cli::Args;

/// One entry per command, the only place a command is named: a new command (e.g. an LCM node)
/// is its cmd_*.cpp file and one line here.
struct Command {
  const char* name;
  int (*run)(const Args&);
  /// Runs pipelines: stops between frames on SIGINT/SIGTERM and still writes its summaries. The
  /// others are short and keep the default (end at once).
  bool stops_between_frames;
  /// Synopsis and what it does, as `--help` and the overview print it.
  const char* text;
};
const Command kCommands[] = {
    {"run", terramrf::cli::cmdRun, true,
     "run CONFIG [--data DIR] [--out DIR] [--first N] [--limit N] [--read-ahead N]\n"
     "             [--no-progress]\n"
     "                         classify every frame of the config's source (a stream's until it\n"
     "                         ends: --first skips its first N, --limit stops after N);\n"
     "                         --read-ahead: frames read on other threads while one is\n"
     "                         classified (0: none)\n"},
    {"validate", terramrf::cli::cmdValidate, false,
     "validate CONFIG|SWEEP [--data DIR]\n"
     "                         check a config or a sweep (all errors at once) without running "
     "it\n"},
    {"plugins", terramrf::cli::cmdPlugins, false,
     "plugins                list the plugins found (and libraries that failed to load)\n"},
    {"describe", terramrf::cli::cmdDescribe, false,
     "describe TYPE          parameters of one plugin (name, type, default, range, unit, doc)\n"},
    {"simulate", terramrf::cli::cmdSimulate, false,
     "simulate --out DIR [--frames N] [--seed S] [--config CONFIG]\n"
     "                         write simulated scans in SemanticKITTI/KITTI layout\n"},
    {"train", terramrf::cli::cmdTrain, true,
     "train CONFIG --out MODEL [--data DIR]... [--features a,b] [--limit N] [--no-progress]\n"
     "                         learn per-class feature mean/sigma from annotated cells\n"},
    {"compare", terramrf::cli::cmdCompare, true,
     "compare SWEEP [--out DIR] [--limit N] [--dry-run] [--no-progress]\n"
     "                         feature sets x optimisers x datasets: paper-shaped tables, ROC\n"},
    {"mesh", terramrf::cli::cmdMesh, true,
     "mesh CONFIG [--out DIR] (and the options of run)\n"
     "                         textured terrain mesh (paper 004): OBJ/MTL/PNG, PLY, glTF\n"},
};
const char* kFooter =
    "Plugins are searched in the install's plugin folder, $TERRAMRF_PLUGIN_PATH and the\n"
    "config's plugin_path. Exit status: 0 ok, 1 error, 2 usage/config error,\n"
    "3 some frames failed (reported and skipped), 4 every frame failed or an output failed at\n"
    "the end, 130/143 run, mesh, compare or train stopped by SIGINT/SIGTERM after the frame in\n"
    "hand, with what was done written (a second signal stops at once).\n";

std::string usageText() {
  std::string t = "usage: terramrf <command> [options]\n\ncommands:\n";
  for (const auto& c : kCommands) t += std::string("  ") + c.text;
  return t + "\n" + kFooter;
}

bool asksForHelp(int argc, char** argv) {
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") return true;
  }
  return false;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace terramrf::cli;
#if defined(__GLIBC__)
  // Each scan's arrays are megabytes: glibc serves them by mmap and gives them back to the kernel
  // when freed, so the next scan's arrays page-fault in afresh (~1 ms per SemanticKITTI read,
  // docs/plugins/readers.md). Kept in the heap instead, they are reused scan after scan.
  mallopt(M_MMAP_THRESHOLD, 64 << 20);
  mallopt(M_TRIM_THRESHOLD, 256 << 20);
#endif
  if (argc < 2 || std::string(argv[1]) == "-h" || std::string(argv[1]) == "--help" ||
      std::string(argv[1]) == "help") {
    std::fputs(usageText().c_str(), argc < 2 ? stderr : stdout);
    return argc < 2 ? kUsage : kOk;
  }
  const std::string cmd = argv[1];
  const Command* it = nullptr;
  for (const auto& c : kCommands)
    if (cmd == c.name) it = &c;
  if (!it) {
    std::cerr << "terramrf: unknown command '" << cmd << "'\n\n" << usageText();
    return kUsage;
  }
  // `terramrf run --help`: that command's synopsis, not a run of a config named --help.
  if (asksForHelp(argc, argv)) {
    std::cout << "usage: terramrf " << it->text << "\n" << kFooter;
    return kOk;
  }
  if (it->stops_between_frames) terramrf::installStopHandlers();
  try {
    return it->run(Args(argv + 2, argv + argc));
  } catch (const UsageError& e) {
    std::cerr << "terramrf " << cmd << ": " << e.what() << "\n";
    return kUsage;
  } catch (const std::exception& e) {
    std::cerr << "terramrf " << cmd << ": " << e.what() << "\n";
    return kError;
  } catch (...) {  // thrown by a plugin: not a std::exception, so nothing more to say of it
    std::cerr << "terramrf " << cmd << ": unknown exception (not a std::exception)\n";
    return kError;
  }
}
