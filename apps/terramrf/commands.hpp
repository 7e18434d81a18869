#pragma once
// One function per CLI command; each returns the process exit status.
#include <stdexcept>
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
/// Interrupted runs end with 128 + the signal (RunResult::exitCode): 130 SIGINT, 143 SIGTERM.
enum Exit { kOk = 0, kError = 1, kUsage = 2, kSomeFramesFailed = 3, kFailed = 4 };

/// A command line that cannot mean anything (exit status kUsage).
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Value of `--name VALUE` (or "--name=VALUE") in args; "" if absent. Removes it from args. An
/// option given without a value, or with an empty one, is a UsageError: `--out=` would otherwise
/// read as "not given" and write to the default folder.
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

/// --first within the source's frames; otherwise prints what the source holds and returns false
/// (a run past the end would run nothing, exit 0 and overwrite the summaries with empty ones).
/// A stream's length is unknown: any --first is taken (its frames before are skipped).
bool firstFrameInRange(const Pipeline& p, const RunOptions& ro, const char* command);

/// What the run will read, for the line before it: "6 frame(s) from simulator", or for a stream
/// "frames from the stream of lcm_scan (until it ends; Ctrl-C stops it)".
std::string framesToRead(const Source& source);

/// "5 of 6 frame(s) ok", or "5 frame(s) ok" for a stream (its total is unknown).
std::string framesOk(const RunResult& r, const Source& source);

/// writeRunReports, whose failure (a full disk) becomes one of the run's errors (exit 4, printed
/// with the summary) instead of ending the command before it prints what did run.
void writeReportsOf(const std::string& output_dir, RunResult& r);

/// "run interrupted (SIGINT) after 41 of 600 frame(s): …" on stdout, for a run that was; the
/// exit status is then r.exitCode(): 130 or 143.
void printInterruption(const RunResult& r);

/// Loads and validates a config; on failure prints every diagnostic and returns false.
bool loadOrReport(const std::string& config, const LoadOptions& options, PluginRegistry& registry,
                  Pipeline& out);

}  // namespace terramrf::cli
