#include "frame_reader.hpp"

#include <algorithm>
#include <chrono>

namespace terramrf {

FrameReader::FrameReader(Source& source, std::size_t first, std::size_t count, std::size_t depth,
                         std::size_t threads)
    : source_(source), first_(first), count_(count), depth_(std::max<std::size_t>(depth, 1)) {
  if (!source.concurrentReads()) threads = 1;
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
  {
    std::lock_guard<std::mutex> lock(m_);
    stop_ = true;
  }
  cv_.notify_all();
  for (auto& t : threads_)
    if (t.joinable()) t.join();
}

void FrameReader::work() {
  for (;;) {
    std::size_t k;
    {
      std::unique_lock<std::mutex> lock(m_);
      cv_.wait(lock, [&] { return stop_ || next_ >= count_ || next_ < taken_ + depth_; });
      if (stop_ || next_ >= count_) return;
      k = next_++;
    }
    Result r;
    const auto t0 = std::chrono::steady_clock::now();
    try {
      r.frame = source_.read(first_ + k);
    } catch (...) {
      r.error = std::current_exception();
    }
    r.read_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    {
      std::lock_guard<std::mutex> lock(m_);
      ready_.emplace(k, std::move(r));
    }
    cv_.notify_all();
  }
}

FrameReader::Result FrameReader::take(std::size_t k) {
  std::unique_lock<std::mutex> lock(m_);
  cv_.wait(lock, [&] { return ready_.count(k) != 0; });
  auto it = ready_.find(k);
  Result r = std::move(it->second);
  ready_.erase(it);
  taken_ = k + 1;
  lock.unlock();
  cv_.notify_all();
  return r;
}

}  // namespace terramrf
