// A plugin built with Eigen's static alignment raised to 32 bytes, as -mavx or -march=native on an
// AVX machine do (CMakeLists.txt sets it directly, so the test needs no AVX CPU): the core types
// holding fixed-size Eigen members then differ in size (Frame 1056 bytes instead of 976).
#include "terramrf/plugin.hpp"

namespace terramrf {

class LayoutMismatch final : public Stage {
 public:
  void process(FrameContext&) override {}
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::LayoutMismatch, terramrf::PluginKind::kFeature, "test_layout_mismatch",
                "test-only stage built with another Eigen alignment")
