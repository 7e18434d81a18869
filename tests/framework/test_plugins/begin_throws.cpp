// Test-only output whose begin() throws what is not a std::exception, as a plugin may: the CLI
// must end with a message and status 1, not std::terminate.
#include "terramrf/plugin.hpp"

namespace terramrf {

class BeginThrows final : public Output {
 public:
  void begin(const RunInfo&) override { throw 42; }
  void write(const FrameContext&) override {}
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::BeginThrows, terramrf::PluginKind::kOutput, "test_begin_throws",
                "test-only output whose begin() throws an int")
