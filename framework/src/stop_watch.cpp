#include "stop_watch.hpp"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <cerrno>
#include <system_error>

#include "terramrf/stop_request.hpp"

namespace terramrf {

StopWatch::StopWatch(std::function<void()> on_stop) : on_stop_(std::move(on_stop)) {
  if (stopWakeFd() < 0 || ::pipe2(quit_, O_CLOEXEC) != 0)
    throw std::system_error(errno ? errno : EMFILE, std::generic_category(),
                            "no pipe to watch for a stop request");
  try {
    thread_ = std::thread([this] { watch(); });
  } catch (...) {
    ::close(quit_[0]);
    ::close(quit_[1]);
    throw;
  }
}

StopWatch::~StopWatch() {
  const char byte = 1;
  const ssize_t ignored = ::write(quit_[1], &byte, 1);
  (void)ignored;
  thread_.join();
  ::close(quit_[0]);
  ::close(quit_[1]);
}

void StopWatch::watch() {
  const int wake = stopWakeFd();
  for (;;) {
    // The flag, not the pipe, says whether a stop is requested: the pipe was made after it if
    // nothing had made it before, and a cleared request may leave its byte for a moment.
    if (stopRequested()) {
      try {
        on_stop_();
      } catch (...) {  // a source's interrupt() that throws: the run stops between frames anyway
      }
      return;
    }
    pollfd fds[2] = {{wake, POLLIN, 0}, {quit_[0], POLLIN, 0}};
    if (::poll(fds, 2, -1) < 0 && errno != EINTR) return;  // cannot watch: stop between frames
    if (fds[1].revents != 0) return;
  }
}

}  // namespace terramrf
