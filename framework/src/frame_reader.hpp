#pragma once
// Internal to the framework: where a run's frames come from. FrameReader reads them ahead of the
// pipeline, on threads of its own. Decoding a scan (KITTI: 1–2 ms with the ring recovery) or
// simulating one (~0.3 s) then overlaps the stages of the frame before, and a source whose reads
// are independent (Source::concurrentReads) reads several frames at once. Frames still reach
// the pipeline one at a time and in order, so results do not depend on it; only the timing does.
// FrameFeed hands the runner its frames from a batch or a stream, read ahead or in place, with
// what the runner needs to know of each (its id, why it cannot run).
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <exception>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "terramrf/plugin.hpp"

namespace terramrf {

class StopWatch;

class FrameReader {
 public:
  struct Result {
    Frame frame;
    std::exception_ptr error;  ///< what read() or next() threw (the frame is then empty)
    double read_ms = 0;        ///< the read's own duration on its thread [ms]
    bool end = false;          ///< a stream: no such frame (it ended, or was interrupted)
  };

  /// Reads frames first … first + count − 1 of a batch `source`, at most `depth` (≥ 1) beyond the
  /// one last taken, on `threads` threads. More than one thread only if the source allows
  /// concurrent reads; with one, read() is called in frame order and never twice at a time.
  /// A stream (Source::streaming()) is read on one thread, next() after next(): its first
  /// `first` frames are skipped, and no more than `count` are read after them.
  /// Throws std::system_error if no thread can be started.
  FrameReader(Source& source, std::size_t first, std::size_t count, std::size_t depth,
              std::size_t threads);
  /// Stops claiming frames and waits for reads in progress, interrupting a stream's next().
  ~FrameReader();
  FrameReader(const FrameReader&) = delete;
  FrameReader& operator=(const FrameReader&) = delete;

  /// The k-th frame of the run (k counts from 0 and must rise by one per call); blocks until it
  /// is read, or, for a stream, until it ended before frame k or interrupt() was called.
  Result take(std::size_t k);
  /// A stream: no frame is read from now on, and take() waits for none that is not read yet.
  /// Does not interrupt the source itself. Thread-safe.
  void interrupt();
  std::size_t threads() const { return threads_.size(); }

 private:
  void work();
  void stopAndJoin();

  Source& source_;
  const bool stream_;
  const std::size_t first_, count_, depth_;
  std::mutex m_;
  std::condition_variable cv_;
  std::size_t next_ = 0;   ///< next frame (run position) to claim
  std::size_t taken_ = 0;  ///< frames handed to the pipeline
  bool stop_ = false;
  /// A stream: frames from this run position on do not exist (it ended, or was interrupted).
  std::size_t end_at_ = static_cast<std::size_t>(-1);
  bool interrupted_ = false;
  int in_next_ = 0;  ///< calls of next() under way (skipping included)
  std::map<std::size_t, Result> ready_;
  std::vector<std::thread> threads_;
};

/// The frames of one run as the runner takes them: frames first … first + count − 1 of a batch,
/// or a stream's frames after its first `first` (skipped), at most `count` (0: until it ends).
/// Read ahead on reader threads when `depth` > 0 (and the run has more than one frame), else in
/// place. For a stream it also watches for a stop request, and interrupts the source (and the
/// wait for it) the moment one comes; a stream's ids are checked against the earlier frames' as
/// they come.
class FrameFeed {
 public:
  struct Taken {
    bool end = false;  ///< no frame k: the run has had its frames
    /// The frame's id (frameId(), or the stream frame's own); "" if it cannot be had.
    std::string id;
    Frame frame;
    /// Why the frame cannot run: what frameId(), read() or next() threw, a stream frame without
    /// an id or with an earlier frame's. The frame is empty then.
    std::exception_ptr error;
    /// The id names an earlier frame's files: they are that frame's, and must stay.
    bool id_clash = false;
    double read_ms = 0;  ///< the read's own duration [ms]
    double wait_ms = 0;  ///< the part of it the run waited for [ms]
  };

  /// Throws nothing for want of threads: reads in place then, with a note (notes()).
  FrameFeed(Source& source, std::size_t first, std::size_t count, std::size_t depth,
            std::size_t threads);
  /// close().
  ~FrameFeed();
  FrameFeed(const FrameFeed&) = delete;
  FrameFeed& operator=(const FrameFeed&) = delete;

  /// Frame k of the run (k counts from 0 and must rise by one per call), or `end`.
  Taken take(std::size_t k);
  /// No frame is read from now on: ends the watch, stops the reader threads (interrupting a
  /// stream's next() under way) and waits for them. take() must not be called after it.
  void close();

  bool stream() const { return stream_; }
  /// A stream was interrupted by a stop request (its end may be the interruption's).
  bool interrupted() const { return interrupted_.load(); }
  std::size_t readAhead() const { return reader_ ? depth_ : 0; }
  std::size_t readThreads() const { return reader_ ? reader_->threads() : 0; }
  /// What the runner should log: reading in place for want of a thread, a stop request that can
  /// only be seen when a frame comes.
  const std::vector<std::string>& notes() const { return notes_; }

 private:
  Taken takeFromBatch(std::size_t k);
  Taken takeFromStream(std::size_t k);
  void onStop();

  Source& source_;
  const bool stream_;
  const std::size_t first_, count_, depth_;
  std::vector<std::string> notes_;
  /// A stream's file names so far (safeFileName of the id) → the frame's run position and id.
  std::map<std::string, std::pair<std::size_t, std::string>> seen_;
  bool skipped_ = false;  ///< a stream read in place: its first `first_` frames are skipped
  std::atomic<bool> interrupted_{false};
  std::unique_ptr<FrameReader> reader_;
  std::unique_ptr<StopWatch> watch_;  ///< after reader_: destroyed first, it calls into it
};

}  // namespace terramrf
