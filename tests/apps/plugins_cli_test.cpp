// `terramrf plugins` and `describe` (apps/terramrf/cmd_run.cpp), and the parameter specs they
// print: the brief promises that the specs are the documentation, so each must be complete.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <set>
#include <thread>

#include "commands.hpp"
#include "terramrf/atomic_file.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {
namespace fs = std::filesystem;

/// Every plugin folder of the source tree, plugins/<kind>/<type>, as {kind, type}.
std::vector<std::pair<std::string, std::string>> pluginFolders() {
  std::vector<std::pair<std::string, std::string>> v;
  for (const auto& kind : fs::directory_iterator(test::sourceDir() + "/plugins"))
    if (kind.is_directory())
      for (const auto& p : fs::directory_iterator(kind.path()))
        if (p.is_directory()) v.emplace_back(kind.path().filename(), p.path().filename());
  std::sort(v.begin(), v.end());
  return v;
}

/// `dir`/c.yaml: the simulator with `sim_params`, height difference, no outputs.
std::string oneStageConfig(const test::TempDir& dir, const std::string& sim_params) {
  const std::string config = dir.str() + "/c.yaml";
  std::ofstream(config) << "version: 1\n"
                           "grid: {size_m: 30, cell_m: 0.5}\n"
                           "source: {type: simulator, params: {" +
                               sim_params +
                               "}}\n"
                               "stages:\n"
                               "  - {name: hdiff, type: height_difference}\n"
                               "outputs: []\n";
  return config;
}

/// `dir`/c.yaml: `source` (a YAML flow map), stages that label every cell (as the core tests'
/// pipeline), and `outputs` (a YAML flow list).
std::string labellingConfig(const test::TempDir& dir, const std::string& source,
                            const std::string& outputs) {
  std::ofstream(dir.str() + "/model.yaml")
      << "provenance: hand-written for tests\nclasses:\n"
         "  road:     {height_diff: {mean: 0.02, sigma: 0.02}}\n"
         "  rough:    {height_diff: {mean: 0.08, sigma: 0.05}}\n"
         "  obstacle: {height_diff: {mean: 1.0, sigma: 0.8}}\n";
  const std::string config = dir.str() + "/c.yaml";
  std::ofstream(config) << "version: 1\ngrid: {size_m: 20, cell_m: 0.5}\nsource: " << source
                        << "\nstages:\n"
                           "  - {name: pre, type: eigen_preclass}\n"
                           "  - {name: hdiff, type: height_difference}\n"
                           "  - {name: mrf, type: potts_gaussian, params: {model: model.yaml, "
                           "features: [height_diff], preclass_layer: preclass}}\n"
                           "  - {name: solve, type: icm}\n"
                           "outputs: "
                        << outputs << "\n";
  return config;
}

double asNumber(const ParamValue& v) {
  if (const auto* i = std::get_if<int64_t>(&v)) return static_cast<double>(*i);
  return std::get<double>(v);
}
}  // namespace

TEST(PluginsCli, ListsEveryPluginOfTheSourceTreeUnderItsKind) {
  testing::internal::CaptureStdout();
  const int rc = cli::cmdPlugins({});
  const std::string out = testing::internal::GetCapturedStdout();
  ASSERT_EQ(rc, cli::kOk);
  const auto folders = pluginFolders();
  ASSERT_GE(folders.size(), 27u) << out;  // as many as were shipped when this was written
  for (const auto& [kind, type] : folders) {
    const std::size_t section = out.find("\n" + kind + ":\n");
    ASSERT_NE(section, std::string::npos) << kind << "\n" << out;
    const std::size_t next = out.find(":\n", section + kind.size() + 3);
    const std::size_t at = out.find("\n  " + type + " ", section);
    EXPECT_TRUE(at != std::string::npos && (next == std::string::npos || at < next))
        << type << " is not listed under " << kind << ":\n"
        << out;
  }
}

TEST(PluginsCli, EveryParameterSpecIsComplete) {
  // Units for every number ("1" when dimensionless), a doc, a range, and a default inside its
  // own range and choices: `describe` is the parameter documentation.
  PluginRegistry reg(PluginRegistry::defaultSearchDirs());
  const std::regex snake("[a-z][a-z0-9_]*");
  std::size_t checked = 0;
  for (const auto& [kind, type] : pluginFolders()) {
    SCOPED_TRACE(type);
    const PluginInfo* info = reg.find(type);
    ASSERT_NE(info, nullptr);
    EXPECT_EQ(toString(info->kind), kind);
    EXPECT_FALSE(info->summary.empty());
    auto plugin = reg.create(type);
    std::set<std::string> names;
    for (const ParamSpec& s : declaredParams(*plugin)) {
      SCOPED_TRACE(s.name);
      ++checked;
      EXPECT_TRUE(std::regex_match(s.name, snake));
      EXPECT_TRUE(names.insert(s.name).second) << "declared twice";
      EXPECT_GE(s.doc.size(), 10u) << "no doc";
      const bool number = s.type == ParamType::kInt || s.type == ParamType::kDouble;
      if (number || s.type == ParamType::kDoubleList) EXPECT_FALSE(s.unit.empty()) << "no unit";
      if (number) {
        EXPECT_TRUE(s.min || s.max) << "no range";
        if (!s.required) {
          const double v = asNumber(s.default_value);
          if (s.min) EXPECT_GE(v, *s.min) << "default below its range";
          if (s.max) EXPECT_LE(v, *s.max) << "default above its range";
        }
      }
      if (s.type == ParamType::kString && !s.choices.empty() && !s.required) {
        const std::string& v = std::get<std::string>(s.default_value);
        EXPECT_NE(std::find(s.choices.begin(), s.choices.end(), v), s.choices.end())
            << "default '" << v << "' is not one of its choices";
      }
    }
    testing::internal::CaptureStdout();
    EXPECT_EQ(cli::cmdDescribe({type}), cli::kOk);
    const std::string out = testing::internal::GetCapturedStdout();
    EXPECT_EQ(out.rfind(type + " (" + kind + "): ", 0), 0u) << out;
    for (const auto& n : names) EXPECT_NE(out.find("\n  " + n + " ("), std::string::npos) << n;
  }
  EXPECT_GE(checked, 200u);
}

// An output's `subdir` must stay inside the run's output folder: '..' or an absolute path would
// let one run write over another's results.
TEST(PluginsCli, EveryOutputsSubdirStaysInsideTheRunsFolder) {
  PluginRegistry reg(PluginRegistry::defaultSearchDirs());
  const LabelSet labels = LabelSet::defaults();
  PluginContext ctx;
  ctx.labels = &labels;
  ctx.output_dir = test::TempDir().str();
  int outputs_with_subdir = 0;
  for (const PluginInfo& info : reg.list()) {
    if (info.kind != PluginKind::kOutput) continue;
    auto probe = reg.create(info.type);
    bool has_subdir = false;
    for (const ParamSpec& s : declaredParams(*probe)) has_subdir |= s.name == "subdir";
    if (!has_subdir) continue;
    ++outputs_with_subdir;
    for (const std::string bad : {"../elsewhere", "a/../../elsewhere", "/tmp/elsewhere", "''"}) {
      SCOPED_TRACE(info.type + " subdir " + bad);
      auto plugin = reg.create(info.type);
      try {
        setParams(*plugin, "{subdir: " + bad + "}", ctx);
        ADD_FAILURE() << "accepted";
      } catch (const std::runtime_error& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("parameter 'subdir': "), std::string::npos) << m;
        EXPECT_TRUE(m.find("leaves the run's output folder ('..')") != std::string::npos ||
                    m.find("is absolute") != std::string::npos ||
                    m.find("is empty") != std::string::npos)
            << m;
      }
    }
    auto ok = reg.create(info.type);
    EXPECT_NO_THROW(setParams(*ok, "{subdir: a/b}", ctx)) << info.type;
  }
  EXPECT_GE(outputs_with_subdir, 6);
}

TEST(PluginsCli, DescribeOfAnUnknownTypeIsAUsageError) {
  testing::internal::CaptureStderr();
  EXPECT_EQ(cli::cmdDescribe({"no_such_plugin"}), cli::kUsage);
  EXPECT_EQ(cli::cmdDescribe({}), cli::kUsage);
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("unknown plugin type 'no_such_plugin'; run 'terramrf plugins'"),
            std::string::npos)
      << err;
  EXPECT_NE(err.find("usage: terramrf describe TYPE"), std::string::npos) << err;
}

TEST(RunCli, BadArgumentsAreUsageErrorsAndRunNothing) {
  test::TempDir dir;
  const std::string config = oneStageConfig(dir, "frames: 1, enable_camera: false");
  const std::string out = dir.str() + "/out";
  struct Case {
    cli::Args args;
    std::string message;
  };
  const std::vector<Case> cases = {
      {{config, "--out", out, "--bogus"}, "terramrf run: unexpected argument '--bogus'"},
      {{config, "--out", out, "--read-ahead", "99"},
       "terramrf run: --read-ahead: expected 0 to 64 frames, got 99"},
      {{"--out", out}, "usage: terramrf run CONFIG"},
      // The simulator reads no folder: --data has nothing to replace.
      {{config, "--out", out, "--data", dir.str()},
       "c.yaml:3:9: stage 'simulator' (simulator): cannot set 'path' from the command line "
       "(--data sets 'path'): this plugin has no such parameter"},
      // Past the end it would run nothing, exit 0 and replace the summaries with empty ones.
      {{config, "--out", out, "--first", "1"},
       "terramrf run: --first 1: the source (simulator) has 1 frame(s), numbered 0 to 0"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.message);
    testing::internal::CaptureStderr();
    EXPECT_EQ(cli::cmdRun(c.args), cli::kUsage);
    const std::string err = testing::internal::GetCapturedStderr();
    EXPECT_NE(err.find(c.message), std::string::npos) << err;
    EXPECT_FALSE(fs::exists(out + "/resolved_config.yaml"));
  }
  // An option with an empty value is no option left out: `--out=` would write to ./out.
  for (const cli::Args& args : std::vector<cli::Args>{
           {config, "--out="}, {config, "--out", ""}, {config, "--out", out, "--data="}}) {
    try {
      cli::cmdRun(args);
      ADD_FAILURE() << "no error for " << args.back();
    } catch (const cli::UsageError& e) {
      const std::string option = args.back().rfind("--data", 0) == 0 ? "--data" : "--out";
      EXPECT_EQ(std::string(e.what()), "option " + option + " needs a value, got an empty one");
    }
  }
  EXPECT_FALSE(fs::exists(out + "/resolved_config.yaml"));
}

// A plugin file in the config's plugin_path that does not load: run and validate say why, not
// only that the type is unknown (before, only `terramrf plugins` with the environment's path did).
TEST(RunCli, PluginFilesThatDoNotLoadAreNamedWithTheirReason) {
  test::TempDir dir;
  fs::create_directories(dir.str() + "/plugins");
  std::ofstream(dir.str() + "/plugins/libmyfeat.so") << "not a library";
  const std::string config = dir.str() + "/c.yaml";
  std::ofstream(config) << "version: 1\nplugin_path: [plugins]\ngrid: {size_m: 30, cell_m: 0.5}\n"
                           "source: {type: simulator, params: {frames: 1}}\n"
                           "stages:\n  - {name: a, type: myfeat}\noutputs: []\n";
  for (auto* cmd : {&cli::cmdRun, &cli::cmdValidate}) {
    testing::internal::CaptureStderr();
    EXPECT_EQ((*cmd)(cli::Args{config}), cli::kUsage);  // a config error: nothing runs
    const std::string err = testing::internal::GetCapturedStderr();
    EXPECT_NE(
        err.find("warning: " + dir.str() + "/plugins/libmyfeat.so: not a loadable shared library"),
        std::string::npos)
        << err;
    EXPECT_NE(err.find("unknown plugin type 'myfeat'"), std::string::npos) << err;
  }
}

// Frame "a" fails on a rerun: its output files from the earlier run go, but not those of frame
// "a_b", whose name only begins with "a_" (before, grid_png removed every a_*.png).
TEST(RunCli, AFailedFramesFilesAreRemovedButNotThoseOfAFrameItsIdBegins) {
  test::TempDir dir;
  fs::create_directories(dir.str() + "/pcd");
  auto writeScan = [&](const std::string& name) {
    std::ofstream(dir.str() + "/pcd/" + name)
        << "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3\n"
           "HEIGHT 1\nPOINTS 3\nDATA ascii\n1 0 -1.7\n2 1 -1.7\n3 -1 -1.7\n";
  };
  writeScan("a.pcd");
  writeScan("a_b.pcd");
  const std::string config =
      labellingConfig(dir, "{type: pointcloud_file, params: {path: pcd}}", "[{type: grid_png}]");
  const std::string out = dir.str() + "/out";
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  ASSERT_EQ(cli::cmdRun({config, "--out", out, "--no-progress"}), cli::kOk)
      << testing::internal::GetCapturedStderr();
  testing::internal::GetCapturedStdout();
  testing::internal::GetCapturedStderr();
  ASSERT_TRUE(fs::exists(out + "/grid/a.png"));
  ASSERT_TRUE(fs::exists(out + "/grid/a_b.png"));
  // An earlier run's camera image of frame a (a camera named "b" would be a_b.png itself).
  std::ofstream(out + "/grid/a_camera0.png") << "earlier run";

  std::ofstream(dir.str() + "/pcd/a.pcd") << "VERSION 0.7\nbroken";
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  const int rc = cli::cmdRun({config, "--out", out, "--no-progress", "--limit", "1"});
  testing::internal::GetCapturedStdout();
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_EQ(rc, cli::kFailed) << err;  // no frame ok
  EXPECT_FALSE(fs::exists(out + "/grid/a.png")) << err;
  EXPECT_TRUE(fs::exists(out + "/grid/a_b.png")) << "frame a_b's own image was removed\n" << err;
  // Not a camera this run knows of: left, as it cannot be told from another frame's file.
  EXPECT_TRUE(fs::exists(out + "/grid/a_camera0.png")) << err;
}

// Every frame ok but an output failing at its end: the run's summary says which and why (before,
// "1 of 1 frame(s) ok" and exit 4, the reason only on stderr).
TEST(RunCli, AnOutputFailingAtTheEndIsNamedInTheSummary) {
  test::TempDir dir;
  const std::string config = labellingConfig(
      dir, "{type: simulator, params: {frames: 1, enable_camera: false}}", "[{type: evaluation}]");
  const std::string out = dir.str() + "/out";
  // A folder where evaluation/summary.json goes: the runner cannot remove it, end() cannot
  // replace it.
  fs::create_directories(out + "/evaluation/summary.json/held");
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  const int rc = cli::cmdRun({config, "--out", out, "--no-progress"});
  const std::string said = testing::internal::GetCapturedStdout();
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_EQ(rc, cli::kFailed) << said << err;
  EXPECT_NE(said.find("1 of 1 frame(s) ok\nerror: output 'evaluation': cannot replace output '" +
                      out + "/evaluation/summary.json'"),
            std::string::npos)
      << said << err;
}

// The run's own reports failing at the end (a full disk; here a folder where timing.md goes):
// before, the command ended with status 1 and "terramrf run: cannot replace output …" only,
// without the "N of M frame(s) ok" summary and the frames' errors. Now the summary is printed
// with the error in it, and the status is the run's error status, 4.
TEST(RunCli, ReportsThatCannotBeWrittenStillLeaveTheSummary) {
  test::TempDir dir;
  const std::string config = labellingConfig(
      dir, "{type: simulator, params: {frames: 1, enable_camera: false}}", "[{type: evaluation}]");
  const std::string out = dir.str() + "/out";
  fs::create_directories(out + "/timing.md/held");
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  int rc = -1;
  EXPECT_NO_THROW(rc = cli::cmdRun({config, "--out", out, "--no-progress"}));
  const std::string said = testing::internal::GetCapturedStdout();
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_EQ(rc, cli::kFailed) << said << err;
  EXPECT_NE(said.find("1 of 1 frame(s) ok\nerror: the run's reports (timing.md, metrics.csv): "
                      "cannot replace output '" +
                      out + "/timing.md'"),
            std::string::npos)
      << said << err;
  EXPECT_NE(said.find("outputs: " + out), std::string::npos) << said;
  EXPECT_TRUE(fs::exists(out + "/evaluation/summary.json"));
}

namespace {
/// Starts `command` (a shell command line) as a child with SIGINT and SIGTERM at their defaults
/// (a test started in the background has SIGINT ignored, which the child would inherit).
pid_t startShell(const std::string& command) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::signal(SIGINT, SIG_DFL);
    ::signal(SIGTERM, SIG_DFL);
    ::execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  return pid;
}

/// Waits up to `seconds` for `path` to exist; false if it did not.
bool waitForFile(const std::string& path, int seconds) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(seconds);
  while (std::chrono::steady_clock::now() < until) {
    if (fs::exists(path)) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

/// The child's wait status, killing it (and failing) if it has not ended within `seconds`.
int waitOrKill(pid_t pid, int seconds) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(seconds);
  int status = 0;
  while (std::chrono::steady_clock::now() < until) {
    if (::waitpid(pid, &status, WNOHANG) == pid) return status;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, &status, 0);
  ADD_FAILURE() << "the child did not end within " << seconds << " s of the signal";
  return status;
}

/// Entries under `dir` (recursively) whose names are our temporaries: `.x.tmp.…`, `x.tmp-…`,
/// `x.old-…`, `.write_probe_…`, `x.overlays-new`.
std::vector<std::string> temporariesUnder(const std::string& dir) {
  std::vector<std::string> found;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    const std::string n = e.path().filename().string();
    if (n.find(".tmp") != std::string::npos || n.find(".old-") != std::string::npos ||
        n.rfind(".write_probe_", 0) == 0 || n.find("overlays-new") != std::string::npos)
      found.push_back(e.path().string());
  }
  return found;
}

std::string fileText(const std::string& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}
}  // namespace

// SIGTERM to a long `terramrf run` (the reviewer's case: grid_png, grid_csv, evaluation, roc).
// Before: the process died at once with every summary lost (timing.md, metrics.csv,
// evaluation/summary.*, roc/*), sometimes a temporary left in grid/. Now the frame in hand
// completes, the outputs end, the reports are written, all saying the run was interrupted;
// no temporary is left and the status is 143.
TEST(MainCli, SigtermDuringARunLeavesEverySummaryAndExits143) {
  test::TempDir dir;
  const std::string config =
      labellingConfig(dir, "{type: simulator, params: {frames: 400, enable_camera: false}}",
                      "[{type: grid_png}, {type: grid_csv}, {type: evaluation}, {type: roc}]");
  const std::string out = dir.str() + "/out";
  const pid_t pid =
      startShell("exec " + test::cli() + " run " + config + " --out " + out + " --no-progress > " +
                 dir.str() + "/stdout 2> " + dir.str() + "/stderr");
  ASSERT_GT(pid, 0);
  const bool started = waitForFile(out + "/grid_csv/000002.csv", 120);
  ::kill(pid, SIGTERM);
  const int status = waitOrKill(pid, 120);
  const std::string said = fileText(dir.str() + "/stdout"), err = fileText(dir.str() + "/stderr");
  ASSERT_TRUE(started) << err;
  ASSERT_TRUE(WIFEXITED(status)) << "ended by signal " << WTERMSIG(status) << "\n" << err;
  EXPECT_EQ(WEXITSTATUS(status), 143) << said << err;
  EXPECT_NE(said.find("run interrupted (SIGTERM) after "), std::string::npos) << said << err;
  EXPECT_NE(said.find(" of 400 frame(s): the outputs' summaries and timing.md cover those "
                      "frames only (exit status 143)"),
            std::string::npos)
      << said;
  EXPECT_EQ(fileText(out + "/timing.md").rfind("Run interrupted (SIGTERM) after ", 0), 0u);
  EXPECT_TRUE(fs::exists(out + "/metrics.csv"));
  EXPECT_NE(fileText(out + "/evaluation/summary.json")
                .find("\"interrupted\": \"run interrupted (SIGTERM) after "),
            std::string::npos);
  EXPECT_EQ(fileText(out + "/evaluation/summary.md").rfind("**Run interrupted (SIGTERM) after ", 0),
            0u);
  EXPECT_NE(fileText(out + "/roc/summary.json").find("run interrupted (SIGTERM) after "),
            std::string::npos);
  EXPECT_TRUE(fs::exists(out + "/roc/roc.csv"));
  EXPECT_TRUE(fs::exists(out + "/roc/roc.svg"));
  EXPECT_EQ(temporariesUnder(out), std::vector<std::string>{});
}

// SIGINT (Ctrl-C) during `terramrf mesh`: before, the mesh was lost entirely (it is exported at
// the end). Now it is exported from the frames done, its report says so, status 130.
TEST(MainCli, SigintDuringMeshExportsTheMeshOfTheFramesDoneAndExits130) {
  test::TempDir dir;
  const std::string config =
      oneStageConfig(dir, "frames: 400, azimuth_step_deg: 0.4, enable_camera: false");
  const std::string out = dir.str() + "/out";
  const std::string log = dir.str() + "/stderr";
  const pid_t pid = startShell("exec " + test::cli() + " mesh " + config + " --out " + out +
                               " --no-progress > " + dir.str() + "/stdout 2> " + log);
  ASSERT_GT(pid, 0);
  // The mesh output notes each frame it adds on stderr.
  bool started = false;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (!started && std::chrono::steady_clock::now() < until) {
    started = fileText(log).find("frame 000001") != std::string::npos;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ::kill(pid, SIGINT);
  const int status = waitOrKill(pid, 120);
  const std::string said = fileText(dir.str() + "/stdout"), err = fileText(log);
  ASSERT_TRUE(started) << err;
  ASSERT_TRUE(WIFEXITED(status)) << "ended by signal " << WTERMSIG(status) << "\n" << err;
  EXPECT_EQ(WEXITSTATUS(status), 130) << said << err;
  EXPECT_TRUE(fs::exists(out + "/mesh/terrain.obj")) << said << err;
  EXPECT_EQ(fileText(out + "/mesh/report.md").rfind("**Run interrupted (SIGINT) after ", 0), 0u)
      << fileText(out + "/mesh/report.md");
  EXPECT_NE(said.find("run interrupted (SIGINT) after "), std::string::npos) << said;
  EXPECT_TRUE(fs::exists(out + "/timing.md"));
  EXPECT_EQ(temporariesUnder(out), std::vector<std::string>{});
}

namespace {
/// labellingConfig on the test-only stream source (test_plugins/synthetic_stream.cpp) with
/// `params` (a YAML flow map).
std::string streamConfig(const test::TempDir& dir, const std::string& params,
                         const std::string& outputs) {
  const std::string config =
      labellingConfig(dir, "{type: test_synthetic_stream, params: " + params + "}", outputs);
  std::string text = fileText(config);
  text.replace(0, std::string("version: 1\n").size(),
               "version: 1\nplugin_path: [" + std::string(TERRAMRF_TEST_PLUGIN_DIR) +
                   "/synthetic_stream]\n");
  std::ofstream(config) << text;
  return config;
}
}  // namespace

// SIGINT to `terramrf run` while its stream source waits for a message that never comes (a live
// LCM channel gone quiet). Before, the wait had no stop condition: the first SIGINT changed
// nothing and the second killed the process, losing every summary. Now the source is
// interrupted at once, the outputs end, the reports are written, all saying "after 3 frame(s)"
// with no total, and the status is 130. The stream would wait 60 s were it not interrupted.
TEST(MainCli, SigintWhileAStreamWaitsEndsTheRunWithEverySummaryAndExits130) {
  test::TempDir dir;
  const std::string waiting = dir.str() + "/waiting";
  const std::string config = streamConfig(
      dir, "{frames: 3, after: wait, wait_limit_s: 60, waiting_marker: " + waiting + "}",
      "[{type: grid_csv}, {type: evaluation}]");
  const std::string out = dir.str() + "/out";
  const pid_t pid =
      startShell("exec " + test::cli() + " run " + config + " --out " + out + " --no-progress > " +
                 dir.str() + "/stdout 2> " + dir.str() + "/stderr");
  ASSERT_GT(pid, 0);
  const bool started = waitForFile(waiting, 120);  // the stream has given its 3 frames
  const auto t_signal = std::chrono::steady_clock::now();
  ::kill(pid, SIGINT);
  const int status = waitOrKill(pid, 120);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_signal).count();
  const std::string said = fileText(dir.str() + "/stdout"), err = fileText(dir.str() + "/stderr");
  ASSERT_TRUE(started) << err;
  ASSERT_TRUE(WIFEXITED(status)) << "ended by signal " << WTERMSIG(status) << "\n" << err;
  EXPECT_EQ(WEXITSTATUS(status), 130) << said << err;
  EXPECT_LT(seconds, 30.0);  // not the stream's own 60 s
  EXPECT_NE(err.find("terramrf: frames from the stream of test_synthetic_stream (until it ends; "
                     "Ctrl-C stops it), outputs in " +
                     out),
            std::string::npos)
      << err;
  EXPECT_NE(said.find("\n3 frame(s) ok\n"), std::string::npos) << said;
  EXPECT_NE(said.find("run interrupted (SIGINT) after 3 frame(s): the outputs' summaries and "
                      "timing.md cover those frames only (exit status 130)"),
            std::string::npos)
      << said;
  EXPECT_EQ(fileText(out + "/timing.md").rfind("Run interrupted (SIGINT) after 3 frame(s):", 0),
            0u);
  EXPECT_TRUE(fs::exists(out + "/metrics.csv"));
  EXPECT_TRUE(fs::exists(out + "/grid_csv/s000002.csv"));
  const std::string json = fileText(out + "/evaluation/summary.json");
  EXPECT_NE(json.find("\"interrupted\": \"run interrupted (SIGINT) after 3 frame(s)\",\n  "
                      "\"frames_planned\": null,"),
            std::string::npos)
      << json;
  EXPECT_EQ(temporariesUnder(out), std::vector<std::string>{});
}

// A stream through `run` and `validate`: --limit stops after N frames, --first skips the first N
// (no range check: the length is unknown), and the summary counts frames without a total.
TEST(RunCli, AStreamRunsUntilItEndsOrItsLimitAndSaysNoTotal) {
  test::TempDir dir;
  const std::string config = streamConfig(dir, "{frames: 5}", "[{type: grid_csv}]");
  const std::string out = dir.str() + "/out";
  struct Case {
    std::vector<std::string> extra;
    std::string said;
    std::size_t count;                ///< frames written
    std::vector<std::string> frames;  ///< the first and last written
  };
  for (const Case& c :
       {Case{{}, "5 frame(s) ok", 5, {"s000000", "s000004"}},
        Case{{"--limit", "2"}, "2 frame(s) ok", 2, {"s000000", "s000001"}},
        Case{{"--first", "3", "--limit", "9"}, "2 frame(s) ok", 2, {"s000003", "s000004"}},
        Case{{"--first", "7"}, "0 frame(s) ok", 0, {}}}) {
    fs::remove_all(out);
    cli::Args args = {config, "--out", out, "--no-progress"};
    args.insert(args.end(), c.extra.begin(), c.extra.end());
    testing::internal::CaptureStdout();
    testing::internal::CaptureStderr();
    const int rc = cli::cmdRun(args);
    const std::string said = testing::internal::GetCapturedStdout();
    const std::string err = testing::internal::GetCapturedStderr();
    EXPECT_EQ(rc, cli::kOk) << said << err;
    EXPECT_NE(said.find("\n" + c.said + "\n"), std::string::npos) << said;
    EXPECT_FALSE(std::regex_search(said, std::regex("of [0-9]+ frame"))) << said;  // no total
    std::size_t csv = 0;
    if (fs::exists(out + "/grid_csv"))
      for (const auto& e : fs::directory_iterator(out + "/grid_csv")) csv += e.is_regular_file();
    EXPECT_EQ(csv, c.count) << said;
    for (const auto& id : c.frames) EXPECT_TRUE(fs::exists(out + "/grid_csv/" + id + ".csv")) << id;
  }
  testing::internal::CaptureStdout();
  EXPECT_EQ(cli::cmdValidate({config}), cli::kOk);
  const std::string said = testing::internal::GetCapturedStdout();
  EXPECT_NE(said.find(": ok (4 stages, 1 outputs, a stream of frames)"), std::string::npos) << said;
}

// `mesh` on a config that lists no textured_mesh output adds one with its defaults; an output
// folder that cannot be made is an error before anything runs.
TEST(MeshCli, AddsTheMeshOutputAndRefusesAFolderThatIsAFile) {
  test::TempDir dir;
  const std::string config = oneStageConfig(dir, "frames: 1, azimuth_step_deg: 0.4");
  const std::string out = dir.str() + "/out";
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  const int rc = cli::cmdMesh({config, "--out", out, "--no-progress"});
  const std::string said = testing::internal::GetCapturedStdout();
  testing::internal::GetCapturedStderr();
  EXPECT_EQ(rc, cli::kOk) << said;
  EXPECT_TRUE(std::filesystem::exists(out + "/mesh/terrain.obj")) << said;
  EXPECT_NE(said.find("mesh: " + out + "/mesh (report.md)"), std::string::npos) << said;

  const std::string file = dir.str() + "/a_file";
  std::ofstream(file) << "x";
  testing::internal::CaptureStderr();
  EXPECT_EQ(cli::cmdMesh({config, "--out", file, "--no-progress"}), cli::kError);
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("terramrf mesh: output folder '" + file + "' cannot be created"),
            std::string::npos)
      << err;
}

TEST(SimulateCli, WritesFramesAndRefusesWhatItCannotSimulate) {
  test::TempDir dir;
  const std::string config = oneStageConfig(dir, "frames: 3, enable_camera: false");
  const std::string out = dir.str() + "/sim";
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  EXPECT_EQ(cli::cmdSimulate({"--out", out, "--config", config, "--frames", "1", "--seed", "4"}),
            cli::kOk);
  testing::internal::GetCapturedStderr();
  const std::string said = testing::internal::GetCapturedStdout();
  EXPECT_NE(said.find("wrote 1 frame(s)"), std::string::npos) << said;  // --frames over the config
  EXPECT_TRUE(fs::exists(out + "/velodyne/000000.bin"));
  EXPECT_FALSE(fs::exists(out + "/velodyne/000001.bin"));

  const std::string kitti = dir.str() + "/kitti.yaml";
  std::ofstream(kitti) << "version: 1\n"
                          "grid: {size_m: 30, cell_m: 0.5}\n"
                          "source: {type: semantickitti, params: {path: "
                       << test::dataPath("semantickitti_mmdet3d_fixture/sequences/00")
                       << "}}\nstages: []\noutputs: []\n";
  struct Case {
    cli::Args args;
    std::string message;
  };
  const std::vector<Case> cases = {
      {{"--frames", "2"}, "usage: terramrf simulate --out DIR"},
      {{"--out", out, "--frames", "two"}, "terramrf simulate: --frames: expected"},
      {{"--out", out, "--seed", "-3"}, "terramrf simulate: --seed: expected"},
      {{"--out", out, "--config", kitti},
       kitti + ": the source is 'semantickitti', but simulate needs a simulator source"},
      {{"--out", out, "--config", dir.str() + "/none.yaml"}, "none.yaml"},
      // Another world into the same folder would leave the first run's frames beside it.
      {{"--out", out, "--frames", "2", "--seed", "5"},
       "terramrf simulate: " + out +
           " already holds a sequence (velodyne); frames of this run "
           "would mix with it: give an empty or new folder"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.message);
    testing::internal::CaptureStderr();
    EXPECT_EQ(cli::cmdSimulate(c.args), cli::kUsage);
    const std::string err = testing::internal::GetCapturedStderr();
    EXPECT_NE(err.find(c.message), std::string::npos) << err;
  }
}

/// `config` with a label set of its own in front, which renumbers road, rough and obstacle.
std::string withOwnLabelSet(test::TempDir& dir, const std::string& config) {
  const std::string own = dir.str() + "/own.yaml";
  std::ofstream(own) << "labels:\n  - {name: unknown, color: [0, 0, 0]}\n"
                        "  - {name: obstacle, color: [1, 1, 1]}\n"
                        "  - {name: rough, color: [2, 2, 2]}\n"
                        "  - {name: road, color: [3, 3, 3]}\n"
                     << readFile(config);
  return own;
}

// The labels simulate writes are the simulation's own ids (configs/label_maps/simulator.yaml),
// whatever classes the config lists: with a label set of its own, which renumbers road, rough
// and obstacle in the frames' truth, the files are the same as without one.
TEST(SimulateCli, LabelsAreTheSameWhateverTheConfigsLabelSet) {
  test::TempDir dir;
  const std::string plain = oneStageConfig(dir, "frames: 1, seed: 4, enable_camera: false");
  const std::string own = withOwnLabelSet(dir, plain);
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  const int a = cli::cmdSimulate({"--out", dir.str() + "/a", "--config", plain});
  const int b = cli::cmdSimulate({"--out", dir.str() + "/b", "--config", own});
  testing::internal::GetCapturedStderr();
  testing::internal::GetCapturedStdout();
  ASSERT_EQ(a, cli::kOk);
  ASSERT_EQ(b, cli::kOk);
  const std::string la = readFile(dir.str() + "/a/labels/000000.label");
  EXPECT_FALSE(la.empty());
  EXPECT_TRUE(la == readFile(dir.str() + "/b/labels/000000.label"));
}

// The same for the camera's pixel truth, which holds project classes: the default ids whatever
// the config lists (a config's own set renumbered it unless --frames or --seed was given too).
TEST(SimulateCli, PixelTruthIsInTheDefaultClassesWhateverTheConfigsLabelSet) {
  test::TempDir dir;
  const std::string plain = oneStageConfig(dir, "frames: 1, seed: 4");
  const std::string own = withOwnLabelSet(dir, plain);
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  const int a = cli::cmdSimulate({"--out", dir.str() + "/a", "--config", plain});
  const int b = cli::cmdSimulate({"--out", dir.str() + "/b", "--config", own});
  const int c = cli::cmdSimulate({"--out", dir.str() + "/c", "--config", own, "--frames", "1"});
  testing::internal::GetCapturedStderr();
  testing::internal::GetCapturedStdout();
  ASSERT_EQ(a, cli::kOk);
  ASSERT_EQ(b, cli::kOk);
  ASSERT_EQ(c, cli::kOk);
  const std::string truth = "/image_2_truth/000000.png";
  const std::string ta = readFile(dir.str() + "/a" + truth);
  EXPECT_FALSE(ta.empty());
  EXPECT_TRUE(ta == readFile(dir.str() + "/b" + truth));
  EXPECT_TRUE(ta == readFile(dir.str() + "/c" + truth));
}

// main() itself: an unknown command is a usage error that lists the commands.
TEST(MainCli, UnknownCommandIsAUsageErrorListingTheCommands) {
  test::TempDir dir;
  const std::string err = dir.str() + "/err.txt";
  const int status = std::system((test::cli() + " frobnicate 2> " + err).c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), cli::kUsage);
  std::ifstream in(err);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("terramrf: unknown command 'frobnicate'"), std::string::npos) << text;
  EXPECT_NE(text.find("commands:"), std::string::npos) << text;
}

// A plugin that throws what is not a std::exception (here an output's begin(), which the runner
// does not catch) ends the command with a message and status 1 (before: std::terminate, 134).
TEST(MainCli, AnExceptionThatIsNotAStdExceptionEndsTheCommandWithAMessage) {
  test::TempDir dir;
  const std::string config = dir.str() + "/c.yaml";
  std::ofstream(config) << "version: 1\nplugin_path: [" << TERRAMRF_TEST_PLUGIN_DIR
                        << "/begin_throws]\ngrid: {size_m: 30, cell_m: 0.5}\n"
                           "source: {type: simulator, params: {frames: 1, enable_camera: false}}\n"
                           "stages:\n  - {name: hdiff, type: height_difference}\n"
                           "outputs: [{type: test_begin_throws}]\n";
  const std::string err = dir.str() + "/err.txt";
  const int status = std::system((test::cli() + " run " + config + " --out " + dir.str() +
                                  "/out --no-progress > /dev/null 2> " + err)
                                     .c_str());
  std::ifstream in(err);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_TRUE(WIFEXITED(status)) << text;
  EXPECT_EQ(WEXITSTATUS(status), cli::kError) << text;
  EXPECT_NE(text.find("terramrf run: unknown exception (not a std::exception)"), std::string::npos)
      << text;
}

// `terramrf <command> --help` prints that command's synopsis and exits 0 (it used to be read as
// a config or plugin named --help: a usage error, or "unknown plugin type '--help'").
TEST(MainCli, EveryCommandsHelpPrintsItsSynopsis) {
  test::TempDir dir;
  const std::string out = dir.str() + "/out.txt";
  for (const std::string cmd :
       {"run", "validate", "plugins", "describe", "simulate", "train", "compare", "mesh"}) {
    for (const char* flag : {"--help", "-h"}) {
      const int status = std::system((test::cli() + " " + cmd + " " + flag + " > " + out).c_str());
      ASSERT_TRUE(WIFEXITED(status));
      EXPECT_EQ(WEXITSTATUS(status), cli::kOk) << cmd << " " << flag;
      std::ifstream in(out);
      const std::string text((std::istreambuf_iterator<char>(in)),
                             std::istreambuf_iterator<char>());
      EXPECT_EQ(text.rfind("usage: terramrf " + cmd + " ", 0), 0u) << cmd << ": " << text;
      EXPECT_NE(text.find("Exit status:"), std::string::npos) << text;
      EXPECT_EQ(text.find("commands:"), std::string::npos) << text;  // that command's only
    }
  }
}

}  // namespace terramrf
