// A plugin whose static initialisation throws: nothing can catch it through dlopen, and the
// process ends; the loader must have named the library first.
#include <stdexcept>

#include "terramrf/plugin.hpp"

namespace terramrf {
namespace {

class ThrowingInit final : public Stage {
 public:
  void process(FrameContext&) override {}
};

int throwAtLoad() { throw std::runtime_error("no licence file (test)"); }
[[maybe_unused]] const int kThrown = throwAtLoad();

}  // namespace
}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::ThrowingInit, terramrf::PluginKind::kFeature, "test_throwing_init",
                "test-only stage whose static initialiser throws")
