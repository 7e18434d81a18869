#include "cached_source.hpp"

#include <set>

namespace terramrf::sweep_detail {

std::size_t frameBytes(const Frame& f) {
  const PointCloud& p = f.points;
  std::size_t b = sizeof(Frame) + f.id.size() + f.source_path.size();
  b += (p.x.size() + p.y.size() + p.z.size() + p.intensity.size() + p.time_s.size()) * sizeof(float);
  b += p.ring.size() * sizeof(uint16_t);
  b += f.truth.label.size() * sizeof(LabelId) + f.truth.raw.size() * sizeof(uint32_t);
  b += f.imu.size() * sizeof(ImuSample) + f.gps.size() * sizeof(GpsSample) +
       f.odometry.size() * sizeof(OdometrySample);
  std::set<const Image*> images;  // shared between copies: count each once
  for (const auto& c : f.cameras) {
    b += sizeof(CameraImage);
    for (const Image* im : {c.image.get(), c.truth.get()})
      if (im && images.insert(im).second) b += im->data.size();
  }
  return b;
}

CachedSource::CachedSource(std::unique_ptr<Source> inner, std::shared_ptr<FrameBudget> budget)
    : inner_(std::move(inner)), budget_(std::move(budget)) {
  setIdentity(inner_->name(), inner_->type());
}

Frame CachedSource::read(std::size_t i) {
  {
    std::lock_guard<std::mutex> lock(m_);
    if (auto it = frames_.find(i); it != frames_.end()) {
      ++hits_;
      return it->second;
    }
  }
  Frame f = inner_->read(i);  // unlocked: concurrent reads of other frames go on
  const std::size_t bytes = frameBytes(f);
  std::lock_guard<std::mutex> lock(m_);
  // The budget is shared by the sweep's items, whose runs are sequential: one run reads one item.
  if (budget_ && bytes <= budget_->left && frames_.count(i) == 0) {
    budget_->left -= bytes;
    bytes_ += bytes;
    frames_.emplace(i, f);
  }
  return f;
}

}  // namespace terramrf::sweep_detail
