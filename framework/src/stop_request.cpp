#include "terramrf/stop_request.hpp"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <mutex>

#include "stop_watch.hpp"

namespace terramrf {

namespace {
// Set from a signal handler: it must be lock-free to be safe there.
std::atomic<int> g_stop_signal{0};
static_assert(std::atomic<int>::is_always_lock_free);
// The signals whose handler installStopHandlers() installed (written before it installs them).
volatile std::sig_atomic_t g_handled_int = 0, g_handled_term = 0;
// A self-pipe that holds a byte while a stop is requested. A signal handler may write() but not
// notify a condition variable, and a thread waiting inside a stream's next() looks at no flag:
// StopWatch poll()s the pipe's read end to call Source::interrupt() at once.
std::atomic<int> g_wake_read{-1}, g_wake_write{-1};
static_assert(std::atomic<int>::is_always_lock_free);

void makeWakePipe() noexcept {
  static std::once_flag once;
  try {
    std::call_once(once, [] {
      int fds[2];
      // Non-blocking: a handler must never wait on a full pipe; close-on-exec: children (a
      // test's `terramrf`) get none of it.
      if (::pipe2(fds, O_CLOEXEC | O_NONBLOCK) != 0) return;
      g_wake_read.store(fds[0]);
      g_wake_write.store(fds[1]);
    });
  } catch (...) {  // std::call_once could not run (std::system_error): no pipe, no watch
  }
}

/// Async-signal-safe: one byte, written once per recorded request.
void wakeWatchers() noexcept {
  const int fd = g_wake_write.load();
  if (fd < 0) return;
  const char byte = 1;
  const ssize_t ignored = ::write(fd, &byte, 1);
  (void)ignored;
}

extern "C" void onStopSignal(int signo) {
  const int saved_errno = errno;  // write() may change it under the interrupted code
  int none = 0;
  if (g_stop_signal.compare_exchange_strong(none, signo)) wakeWatchers();
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
  errno = saved_errno;
}
}  // namespace

int stopWakeFd() noexcept {
  makeWakePipe();
  return g_wake_read.load();
}

void installStopHandlers() {
  makeWakePipe();  // before any handler can run: the handler makes nothing
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
  makeWakePipe();
  int none = 0;
  if (g_stop_signal.compare_exchange_strong(none, signo)) wakeWatchers();
}

int stopRequested() noexcept { return g_stop_signal.load(); }

void clearStopRequest() noexcept {
  g_stop_signal.store(0);
  const int fd = g_wake_read.load();
  if (fd < 0) return;
  char drain[64];
  while (::read(fd, drain, sizeof drain) > 0) {
  }
}

std::string signalName(int signo) {
  if (signo == SIGINT) return "SIGINT";
  if (signo == SIGTERM) return "SIGTERM";
  return "signal " + std::to_string(signo);
}

std::string interruptionText(const RunSummary& s) {
  if (s.stop_signal == 0) return "";
  // A stream has no total (frames_total 0).
  return "interrupted (" + signalName(s.stop_signal) + ") after " +
         std::to_string(s.frames_ok + s.failed.size()) +
         (s.frames_total ? " of " + std::to_string(s.frames_total) : std::string()) + " frame(s)";
}

}  // namespace terramrf
