#pragma once
// Paths every test may need. The real data is required: a test that needs it fails loudly.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "terramrf/simd.hpp"

namespace terramrf::test {

inline std::string dataDir() {
  const char* env = std::getenv("TERRAMRF_DATA_DIR");
  return env && *env ? env : TERRAMRF_DATA_DIR;
}
/// Absolute path of a file under the shared data folder; fails the test if it is missing.
inline std::string dataPath(const std::string& rel) {
  const std::string p = dataDir() + "/" + rel;
  if (!std::filesystem::exists(p)) {
    ADD_FAILURE() << "required real data missing: " << p
                  << " (set TERRAMRF_DATA_DIR or -DTERRAMRF_DATA_DIR to ../shared/data)";
  }
  return p;
}
/// A pid that no process has: a child's, after it has exited and been reaped.
inline pid_t deadPid() {
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  int status = 0;
  ::waitpid(child, &status, 0);
  return child;
}

inline std::string pluginDir() { return TERRAMRF_PLUGIN_DIR; }
inline std::string sourceDir() { return TERRAMRF_SOURCE_DIR; }
inline std::string cli() { return TERRAMRF_CLI; }

/// `text` with the first `from` replaced by `to` (a test failure if `from` is not there).
inline std::string edited(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  if (at == std::string::npos)
    ADD_FAILURE() << "'" << from << "' not in the test text";
  else
    text.replace(at, from.size(), to);
  return text;
}
/// "line:col" (1-based, as diagnostics print them) of the `nth` occurrence of `token` in `text`.
inline std::string positionOf(const std::string& text, const std::string& token, int nth = 1) {
  std::size_t at = std::string::npos;
  for (int k = 0; k < nth; ++k) at = text.find(token, at == std::string::npos ? 0 : at + 1);
  if (at == std::string::npos) {
    ADD_FAILURE() << "'" << token << "' not in the test text";
    return "?";
  }
  const std::size_t nl = text.rfind('\n', at);
  const std::size_t line_start = nl == std::string::npos ? 0 : nl + 1;
  return std::to_string(1 + std::count(text.begin(), text.begin() + at, '\n')) + ":" +
         std::to_string(1 + at - line_start);
}

/// A fresh temporary folder per test, removed at the end.
class TempDir {
 public:
  TempDir() {
    path_ = std::filesystem::temp_directory_path() /
            ("terramrf_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter()++));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  const std::filesystem::path& path() const { return path_; }
  std::string str() const { return path_.string(); }

 private:
  static int& counter() {
    static int c = 0;
    return c;
  }
  std::filesystem::path path_;
};

/// For tests of "the same bits with this CPU's widest vectors as with SSE2". True if the wide
/// path (AVX2, or AVX with `avx2` false) runs now. Fails the test if the CPU has it but it is off
/// before the test switches it (TERRAMRF_SIMD=sse2 already in the environment, dispatch compiled
/// out): the comparison would be of SSE2 with itself and could not fail. On a CPU without it,
/// returns false and says so in the log (nothing to compare there).
inline bool widePathRuns(bool avx2 = true) {
  const bool cpu = avx2 ? __builtin_cpu_supports("avx2") : __builtin_cpu_supports("avx");
  const bool on = avx2 ? terramrf::useAvx2() : terramrf::useAvx();
  if (!cpu) {
    GTEST_LOG_(INFO) << "this CPU has no " << (avx2 ? "AVX2" : "AVX")
                     << ": the SSE2 path is compared with itself";
    return false;
  }
  EXPECT_TRUE(on) << "the CPU has " << (avx2 ? "AVX2" : "AVX")
                  << " but the vector path is off (TERRAMRF_SIMD=sse2 set before the test?): "
                     "SSE2 would be compared with itself";
  return on;
}

/// Sets an environment variable for the scope, restoring its previous value (or absence).
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) had_ = true, old_ = old;
    ::setenv(name, value, 1);
  }
  ~ScopedEnv() {
    if (had_)
      ::setenv(name_.c_str(), old_.c_str(), 1);
    else
      ::unsetenv(name_.c_str());
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  std::string name_, old_;
  bool had_ = false;
};

}  // namespace terramrf::test
