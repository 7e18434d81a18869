#include "terramrf/stop_request.hpp"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <csignal>

namespace terramrf {

namespace {
// Set from a signal handler: it must be lock-free to be safe there.
std::atomic<int> g_stop_signal{0};
static_assert(std::atomic<int>::is_always_lock_free);
// The signals whose handler installStopHandlers() installed (written before it installs them).
volatile std::sig_atomic_t g_handled_int = 0, g_handled_term = 0;

extern "C" void onStopSignal(int signo) {
  int none = 0;
  g_stop_signal.compare_exchange_strong(none, signo);
  // A second signal (either) ends the process at once: the user may not want to wait for the
  // frame in hand or an output's end(). sigaction and write are async-signal-safe.
  struct sigaction dfl {};
  dfl.sa_handler = SIG_DFL;
  sigemptyset(&dfl.sa_mask);
  if (g_handled_int) sigaction(SIGINT, &dfl, nullptr);
  if (g_handled_term) sigaction(SIGTERM, &dfl, nullptr);
  static const char msg[] =
      "\nterramrf: stopping after the frame in hand and writing the summaries (signal again to "
      "stop at once)\n";
  const ssize_t ignored = ::write(2, msg, sizeof msg - 1);
  (void)ignored;
}
}  // namespace

void installStopHandlers() {
  struct sigaction sa {};
  sa.sa_handler = onStopSignal;
  sigemptyset(&sa.sa_mask);
  // Restarted, not failed with EINTR: reads and writes in progress (a source's, an output's)
  // complete, and the run stops between frames.
  sa.sa_flags = SA_RESTART;
  // A signal ignored when the program started stays ignored: a shell starts a background job
  // (`terramrf run … &` in a script) with SIGINT ignored, and nohup-like launchers do the same.
  auto install = [&](int signo, volatile std::sig_atomic_t& handled) {
    struct sigaction old {};
    handled = 0;
    if (sigaction(signo, nullptr, &old) != 0 || old.sa_handler == SIG_IGN) return;
    handled = 1;
    sigaction(signo, &sa, nullptr);
  };
  install(SIGINT, g_handled_int);
  install(SIGTERM, g_handled_term);
}

void requestStop(int signo) noexcept {
  if (signo <= 0) return;
  int none = 0;
  g_stop_signal.compare_exchange_strong(none, signo);
}

int stopRequested() noexcept { return g_stop_signal.load(); }

void clearStopRequest() noexcept { g_stop_signal.store(0); }

std::string signalName(int signo) {
  if (signo == SIGINT) return "SIGINT";
  if (signo == SIGTERM) return "SIGTERM";
  return "signal " + std::to_string(signo);
}

std::string interruptionText(const RunSummary& s) {
  if (s.stop_signal == 0) return "";
  return "interrupted (" + signalName(s.stop_signal) + ") after " +
         std::to_string(s.frames_ok + s.failed.size()) + " of " + std::to_string(s.frames_total) +
         " frame(s)";
}

}  // namespace terramrf
