// Test-only output that asks the run to stop (as the SIGINT handler does) while writing the
// `after`-th frame of its run: drives a stop through code that only a config reaches (a sweep's
// test runs), without a signal.
#include <csignal>

#include "terramrf/plugin.hpp"
#include "terramrf/stop_request.hpp"

namespace terramrf {

class RequestsStop final : public Output {
 public:
  void declare(ParamDecl& d) override {
    d.add("after", after_, "frame of the run (1 = its first) during which the stop is asked for")
        .range(1, 1000000);
  }
  void write(const FrameContext&) override {
    if (++frames_ == after_) requestStop(SIGINT);
  }

 private:
  int after_ = 1;
  int frames_ = 0;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::RequestsStop, terramrf::PluginKind::kOutput, "test_requests_stop",
                "test-only output that asks the run to stop (SIGINT) during a given frame")
