#pragma once
// Internal to the framework: a Source that keeps the frames it has read, for `terramrf compare`.
// A sweep reads every split item many times — once per training candidate, validation candidate
// and test run — and reading (decoding a scan, or simulating one: ~0.2 s for a simulator frame)
// costs more than the features and the MRF together. Frames are kept until the sweep ends, within
// a byte budget shared by all items; past it they are read again as before.
#include <cstddef>
#include <map>
#include <memory>
#include <mutex>

#include "terramrf/plugin.hpp"

namespace terramrf::sweep_detail {

/// Bytes the caches of one sweep may still take.
struct FrameBudget {
  std::size_t left = 0;
};

/// Approximate bytes a frame holds (points, labels, images, samples).
std::size_t frameBytes(const Frame& f);

class CachedSource final : public Source {
 public:
  CachedSource(std::unique_ptr<Source> inner, std::shared_ptr<FrameBudget> budget);
  /// The inner source's parameters: resolved configs and provenance name the real source.
  void declare(ParamDecl& d) override { inner_->declare(d); }
  void configure(const PluginContext& ctx) override { inner_->configure(ctx); }
  std::vector<std::string> reads() const override { return inner_->reads(); }
  std::vector<std::string> writes() const override { return inner_->writes(); }
  std::size_t size() const override { return inner_->size(); }
  std::string frameId(std::size_t i) const override { return inner_->frameId(i); }
  /// A copy of the kept frame, or the inner source's (kept if the budget allows). A frame that
  /// fails to read is not kept: it fails again, with the same error, on every run.
  Frame read(std::size_t i) override;
  /// As the inner source: the cache itself is locked.
  bool concurrentReads() const override { return inner_->concurrentReads(); }
  std::vector<std::string> cameraNames() const override { return inner_->cameraNames(); }
  std::map<std::string, std::string> layerOrigins() const override {
    return inner_->layerOrigins();
  }

  /// Counts once the sweep's runs are over (not locked).
  std::size_t hits() const { return hits_; }
  std::size_t kept() const { return frames_.size(); }
  std::size_t keptBytes() const { return bytes_; }

 private:
  std::unique_ptr<Source> inner_;
  std::shared_ptr<FrameBudget> budget_;
  std::mutex m_;  ///< guards frames_, the counts and the budget
  std::map<std::size_t, Frame> frames_;
  std::size_t hits_ = 0, bytes_ = 0;
};

}  // namespace terramrf::sweep_detail
