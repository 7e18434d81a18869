// Must not compile: an output declared a source. Built only by the CTest test
// plugin_macro_refuses_a_kind_its_class_is_not, which expects the static_assert's message.
#include "terramrf/plugin.hpp"

namespace terramrf {

class AnOutput final : public Output {
 public:
  void write(const FrameContext&) override {}
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::AnOutput, terramrf::PluginKind::kSource, "test_kind_mismatch",
                "test-only output declared a source")
