#pragma once
// Internal to the framework: reads a run's frames ahead of the pipeline, on threads of its own.
// Decoding a scan (KITTI: 1–2 ms with the ring recovery) or simulating one (~0.3 s) then
// overlaps the stages of the frame before, and a source whose reads are independent
// (Source::concurrentReads) reads several frames at once. Frames still reach the pipeline one
// at a time and in order, so results do not depend on it; only the timing does.
#include <condition_variable>
#include <cstddef>
#include <exception>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

#include "terramrf/plugin.hpp"

namespace terramrf {

class FrameReader {
 public:
  struct Result {
    Frame frame;
    std::exception_ptr error;  ///< what read() threw (the frame is then empty)
    double read_ms = 0;        ///< the read's own duration on its thread [ms]
  };

  /// Reads frames first … first + count − 1 of `source`, at most `depth` (≥ 1) beyond the one
  /// last taken, on `threads` threads. More than one thread only if the source allows
  /// concurrent reads; with one, read() is called in frame order and never twice at a time.
  /// Throws std::system_error if no thread can be started.
  FrameReader(Source& source, std::size_t first, std::size_t count, std::size_t depth,
              std::size_t threads);
  /// Stops claiming frames and waits for reads in progress.
  ~FrameReader();
  FrameReader(const FrameReader&) = delete;
  FrameReader& operator=(const FrameReader&) = delete;

  /// The k-th frame of the run (k counts from 0 and must rise by one per call); blocks until it
  /// is read.
  Result take(std::size_t k);
  std::size_t threads() const { return threads_.size(); }

 private:
  void work();
  void stopAndJoin();

  Source& source_;
  const std::size_t first_, count_, depth_;
  std::mutex m_;
  std::condition_variable cv_;
  std::size_t next_ = 0;   ///< next frame (run position) to claim
  std::size_t taken_ = 0;  ///< frames handed to the pipeline
  bool stop_ = false;
  std::map<std::size_t, Result> ready_;
  std::vector<std::thread> threads_;
};

}  // namespace terramrf
