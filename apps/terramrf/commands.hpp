#pragma once
// One function per CLI command; each returns the process exit status.
#include <string>
#include <vector>

#include "terramrf/config.hpp"
#include "terramrf/pipeline.hpp"

namespace terramrf::cli {

using Args = std::vector<std::string>;

int cmdRun(const Args& args);
int cmdValidate(const Args& args);
int cmdPlugins(const Args& args);
int cmdDescribe(const Args& args);
int cmdSimulate(const Args& args);
int cmdTrain(const Args& args);
int cmdCompare(const Args& args);
int cmdMesh(const Args& args);

/// Exit statuses shared by all commands.
enum Exit { kOk = 0, kError = 1, kUsage = 2, kSomeFramesFailed = 3, kFailed = 4 };

/// Value of `--name VALUE` (or "--name=VALUE") in args; "" if absent. Removes it from args.
std::string takeOption(Args& args, const std::string& name);
bool takeFlag(Args& args, const std::string& name);
/// `--name N` as a whole number >= `min` into `out` (left alone if the option is absent). Prints
/// "terramrf <command>: --name: expected …, got '…'" and returns false for anything else
/// ("5x", "-1", "abc"), so a typo is never read as a different number.
bool takeCount(Args& args, const std::string& name, const char* command, std::size_t min,
               std::size_t& out);

/// CONFIG [--data DIR] [--out DIR] [--first N] [--limit N] [--no-progress], shared by the
/// commands that run a pipeline. Returns kOk, or kUsage after printing what is wrong.
struct RunArgs {
  std::string config;
  LoadOptions load;
  RunOptions run;
};
int parseRunArgs(const Args& args, const char* command, RunArgs& out);

/// Loads and validates a config; on failure prints every diagnostic and returns false.
bool loadOrReport(const std::string& config, const LoadOptions& options, PluginRegistry& registry,
                  Pipeline& out);

}  // namespace terramrf::cli
