#pragma once
// Internal to the framework: reacting to a stop request (stop_request.hpp) at once rather than
// between frames. The handler only records the signal, and a stream source waiting in next() for
// a message that may never come looks at no flag; the run watches for the request on a thread of
// its own and calls Source::interrupt() from there.
#include <functional>
#include <thread>

namespace terramrf {

/// The read end of a pipe that holds a byte from the moment a stop is requested until
/// clearStopRequest(): poll() it, never read it (other watches share it). −1 if no pipe could be
/// made. Defined in stop_request.cpp, whose handler writes the byte.
int stopWakeFd() noexcept;

class StopWatch {
 public:
  /// Runs `on_stop` once, on a thread of its own, as soon as a stop is requested (at once if one
  /// already was); not at all if none is before the watch ends. Anything it throws is dropped.
  /// Throws std::system_error if no pipe or thread can be had.
  explicit StopWatch(std::function<void()> on_stop);
  /// Ends the watch, waiting for an on_stop under way.
  ~StopWatch();
  StopWatch(const StopWatch&) = delete;
  StopWatch& operator=(const StopWatch&) = delete;

 private:
  void watch();

  std::function<void()> on_stop_;
  int quit_[2] = {-1, -1};  ///< a byte in it ends the watch
  std::thread thread_;
};

}  // namespace terramrf
