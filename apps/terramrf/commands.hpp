#pragma once
// One function per CLI command; each returns the process exit status.
#include <string>
#include <vector>

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

}  // namespace terramrf::cli
