#include "frame_reader.hpp"

#include <algorithm>
#include <chrono>
#include <optional>
#include <stdexcept>
#include <system_error>

#include "stop_watch.hpp"
#include "terramrf/atomic_file.hpp"

namespace terramrf {

namespace {
using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}
}  // namespace

FrameReader::FrameReader(Source& source, std::size_t first, std::size_t count, std::size_t depth,
                         std::size_t threads)
    : source_(source),
      stream_(source.streaming()),
      first_(first),
      count_(count),
      depth_(std::max<std::size_t>(depth, 1)) {
  // A stream has one order, its own: next() after next().
  if (stream_ || !source.concurrentReads()) threads = 1;
  threads = std::clamp<std::size_t>(threads, 1, std::max<std::size_t>(1, std::min(depth_, count)));
  try {
    for (std::size_t t = 0; t < threads; ++t) threads_.emplace_back([this] { work(); });
  } catch (...) {  // no thread to be had (std::system_error): stop those that started
    stopAndJoin();
    throw;
  }
}

FrameReader::~FrameReader() { stopAndJoin(); }

void FrameReader::stopAndJoin() {
  bool waiting_stream;
  {
    std::lock_guard<std::mutex> lock(m_);
    stop_ = true;
    // No next() starts once stop_ is set; one under way may wait for a message that never comes.
    waiting_stream = in_next_ > 0;
  }
  cv_.notify_all();
  if (waiting_stream) {
    try {
      source_.interrupt();
    } catch (...) {  // it is up to next() now
    }
  }
  for (auto& t : threads_)
    if (t.joinable()) t.join();
}

void FrameReader::interrupt() {
  {
    std::lock_guard<std::mutex> lock(m_);
    interrupted_ = true;
  }
  cv_.notify_all();
}

void FrameReader::work() {
  // A stream's frames before the run's are read and dropped, in order, here: next() is called
  // on this thread only.
  for (std::size_t s = 0; stream_ && s < first_; ++s) {
    {
      std::lock_guard<std::mutex> lock(m_);
      if (stop_) return;
      if (interrupted_) {
        end_at_ = 0;
        break;
      }
      ++in_next_;
    }
    std::optional<Frame> f;
    bool threw = false;
    try {
      f = source_.next();
    } catch (...) {  // a bad frame among those skipped: skipped as well
      threw = true;
    }
    std::lock_guard<std::mutex> lock(m_);
    --in_next_;
    if (!f && !threw) {
      end_at_ = 0;
      break;
    }
  }
  cv_.notify_all();
  for (;;) {
    std::size_t k;
    {
      std::unique_lock<std::mutex> lock(m_);
      cv_.wait(lock, [&] {
        return stop_ || interrupted_ || next_ >= count_ || next_ >= end_at_ ||
               next_ < taken_ + depth_;
      });
      if (stop_ || next_ >= count_ || next_ >= end_at_) return;
      if (stream_ && interrupted_) {
        end_at_ = next_;
        lock.unlock();
        cv_.notify_all();
        return;
      }
      k = next_++;
      if (stream_) ++in_next_;
    }
    Result r;
    const auto t0 = Clock::now();
    bool ended = false;
    try {
      if (stream_) {
        std::optional<Frame> f = source_.next();
        ended = !f;
        if (f) r.frame = std::move(*f);
      } else {
        r.frame = source_.read(first_ + k);
      }
    } catch (...) {
      r.error = std::current_exception();
    }
    r.read_ms = msSince(t0);
    {
      std::lock_guard<std::mutex> lock(m_);
      if (stream_) --in_next_;
      if (ended)
        end_at_ = std::min(end_at_, k);
      else
        ready_.emplace(k, std::move(r));
    }
    cv_.notify_all();
    if (ended) return;
  }
}

FrameReader::Result FrameReader::take(std::size_t k) {
  std::unique_lock<std::mutex> lock(m_);
  cv_.wait(lock, [&] { return ready_.count(k) != 0 || k >= end_at_ || interrupted_; });
  auto it = ready_.find(k);
  Result r;
  if (it == ready_.end()) {
    r.end = true;
    return r;
  }
  r = std::move(it->second);
  ready_.erase(it);
  taken_ = k + 1;
  lock.unlock();
  cv_.notify_all();
  return r;
}

FrameFeed::FrameFeed(Source& source, std::size_t first, std::size_t count, std::size_t depth,
                     std::size_t threads)
    : source_(source),
      stream_(source.streaming()),
      first_(first),
      count_(stream_ && count == 0 ? static_cast<std::size_t>(-1) : count),
      depth_(depth) {
  if (depth_ > 0 && count_ > 1) {
    try {
      reader_ = std::make_unique<FrameReader>(source_, first_, count_, depth_, threads);
    } catch (const std::system_error& e) {
      notes_.push_back(std::string("no reader thread (") + e.what() +
                       "); frames are read in place");
    }
  }
  if (stream_) {
    try {
      watch_ = std::make_unique<StopWatch>([this] { onStop(); });
    } catch (const std::system_error& e) {
      notes_.push_back(std::string("no thread to watch for a stop request (") + e.what() +
                       "): a stop is seen only when the stream's next frame comes");
    }
  }
}

FrameFeed::~FrameFeed() { close(); }

void FrameFeed::close() {
  watch_.reset();   // first: it calls into the reader
  reader_.reset();  // interrupts a next() under way
}

void FrameFeed::onStop() {
  interrupted_ = true;
  if (reader_) reader_->interrupt();  // the runner waits for no frame that is not read yet
  source_.interrupt();                // and a next() waiting for a message returns
}

FrameFeed::Taken FrameFeed::take(std::size_t k) {
  return stream_ ? takeFromStream(k) : takeFromBatch(k);
}

FrameFeed::Taken FrameFeed::takeFromBatch(std::size_t k) {
  Taken t;
  if (k >= count_) {
    t.end = true;
    return t;
  }
  const std::size_t i = first_ + k;
  try {
    t.id = source_.frameId(i);
  } catch (...) {
    t.error = std::current_exception();
  }
  const auto t0 = Clock::now();
  if (reader_) {
    // Taken even when its id could not be had: the reader hands frames over in order and reads
    // no further than its depth past the last one taken, so a frame left with it would stall.
    FrameReader::Result r = reader_->take(k);
    t.read_ms = r.read_ms;
    if (!t.error) {
      t.error = r.error;
      t.frame = std::move(r.frame);
    }
  } else if (!t.error) {
    try {
      t.frame = source_.read(i);
    } catch (...) {
      t.error = std::current_exception();
    }
    t.read_ms = msSince(t0);
  }
  t.wait_ms = msSince(t0);
  return t;
}

FrameFeed::Taken FrameFeed::takeFromStream(std::size_t k) {
  Taken t;
  if (k >= count_) {
    t.end = true;
    return t;
  }
  const std::size_t position = first_ + k;  // in the stream, the frames skipped included
  const auto t0 = Clock::now();
  if (reader_) {
    FrameReader::Result r = reader_->take(k);
    if (r.end) {
      t.end = true;
      return t;
    }
    t.read_ms = r.read_ms;
    t.error = r.error;
    t.frame = std::move(r.frame);
  } else {
    if (!skipped_) {
      for (std::size_t s = 0; s < first_; ++s) {
        std::optional<Frame> f;
        try {
          if (!interrupted_) f = source_.next();
        } catch (...) {  // a bad frame among those skipped: skipped as well
          continue;
        }
        if (!f) {
          t.end = true;
          return t;
        }
      }
      skipped_ = true;
    }
    std::optional<Frame> f;
    try {
      if (!interrupted_) f = source_.next();
    } catch (...) {
      t.error = std::current_exception();
    }
    if (!f && !t.error) {
      t.end = true;
      return t;
    }
    if (f) t.frame = std::move(*f);
    t.read_ms = msSince(t0);
  }
  t.wait_ms = msSince(t0);
  if (t.error) return t;
  t.id = t.frame.id;
  const std::string where = "frame " + std::to_string(position) + " of the stream";
  if (t.id.empty()) {
    t.frame = Frame{};
    t.error = std::make_exception_ptr(
        std::runtime_error(where + " has no id (Frame::id): source '" + source_.type() +
                           "' must name each frame, its outputs are written under that name"));
    return t;
  }
  // A batch's ids are checked before the run; a stream's only as they come. The first frame to
  // write a name keeps it, whether or not it ran: its outputs, or their absence, are its own.
  const auto [it, fresh] = seen_.emplace(safeFileName(t.id), std::pair{position, t.id});
  if (!fresh) {
    t.frame = Frame{};
    t.id_clash = true;
    t.error = std::make_exception_ptr(std::runtime_error(
        where + " ('" + t.id + "') and frame " + std::to_string(it->second.first) + " ('" +
        it->second.second + "') both write '" + it->first +
        "': skipped, so that it cannot write over that frame's outputs; a stream must give "
        "every frame a distinct id"));
  }
  return t;
}

}  // namespace terramrf
