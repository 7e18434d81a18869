#pragma once
// Helpers shared by the grid_png, grid_csv and lcm_publish output tests.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>

#include <memory>
#include <string>

#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"
#include "test_support.hpp"

namespace terramrf::test {

/// 4 × 4 cells of 1 m centred on the sensor (origin (−2, −2)). Labels: (3,0) obstacle
/// (forward-right), (0,3) road (back-left), (0,0) rough (back-right), rest unknown.
inline GridGeometry outputTestGeometry() {
  GridGeometry g;
  g.size_m = 4.0;
  g.cell_m = 1.0;
  return g;
}

inline std::unique_ptr<Output> makeOutput(const std::string& type, const std::string& params,
                                          const PluginContext& ctx) {
  PluginRegistry reg({pluginDir()});
  std::unique_ptr<Plugin> p = reg.create(type);
  setParams(*p, params, ctx);
  auto* out = dynamic_cast<Output*>(p.get());
  EXPECT_NE(out, nullptr);
  if (!out) return nullptr;
  p.release();
  return std::unique_ptr<Output>(out);
}

/// Lowers the soft file-size limit for its lifetime so any file write beyond `bytes` fails with
/// EFBIG. Works for root too (unlike chmod), so atomicity can be tested anywhere.
class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) {
    ::signal(SIGXFSZ, SIG_IGN);
    ::getrlimit(RLIMIT_FSIZE, &saved_);
    rlimit l = saved_;
    l.rlim_cur = bytes;
    ok_ = ::setrlimit(RLIMIT_FSIZE, &l) == 0;
  }
  ~FileSizeLimit() { ::setrlimit(RLIMIT_FSIZE, &saved_); }
  bool ok() const { return ok_; }

 private:
  rlimit saved_{};
  bool ok_ = false;
};

}  // namespace terramrf::test
