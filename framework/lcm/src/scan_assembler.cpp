#include "terramrf/lcm/scan_assembler.hpp"

#include <algorithm>
#include <limits>

#include "terramrf/lcm/message_peek.hpp"

namespace terramrf {
namespace {
constexpr std::size_t kRecentIds = 256;  // scans remembered after they left, to tell late messages
}

ScanAssembler::ScanAssembler(Options options) : o_(std::move(options)) {}

bool ScanAssembler::complete(const Waiting& w) const {
  for (const std::string& c : o_.cameras)
    if (!w.cameras.image_of.count(c) || !w.cameras.info_of.count(c)) return false;
  return (o_.channels.labels.empty() || w.scan.labels) &&
         (o_.channels.pose.empty() || w.scan.pose) &&
         (o_.channels.truth_pose.empty() || w.scan.truth_pose) &&
         (o_.channels.grid.empty() || w.scan.grid);
}

void ScanAssembler::placeCamera(int kind, const std::string& id, const std::string& camera,
                                ScanMessage m) {
  if (std::find(o_.cameras.begin(), o_.cameras.end(), camera) == o_.cameras.end()) {
    ++counts_.unlisted;
    return;
  }
  const char* what[] = {"image_t", "camera_info_t", "truth image"};
  const auto put = [&](Cameras& c, bool held) {
    std::vector<ScanMessage>& to = kind == 0 ? c.images : kind == 1 ? c.infos : c.truths;
    std::set<std::string>& of = kind == 0 ? c.image_of : kind == 1 ? c.info_of : c.truth_of;
    if (!of.insert(camera).second) {
      // Kept once: a sender repeating a scan's image must not grow memory without bound.
      if (c.error.empty())
        c.error = std::string("two ") + what[kind] + " messages of camera '" + camera +
                  "' for scan '" + id + "' (the second: " + m.source + "); expected one";
      return;
    }
    if (held) held_bytes_ += m.bytes.size();
    to.push_back(std::move(m));
  };
  if (Waiting* w = waitingScan(id)) return put(w->cameras, false);
  if (Held* h = heldFor(id)) {
    put(h->cameras, true);
    evictHeld();
  }
}

ScanAssembler::Waiting* ScanAssembler::waitingScan(const std::string& id) {
  for (auto w = waiting_.rbegin(); w != waiting_.rend(); ++w)
    if (w->scan.id == id) return &*w;
  return nullptr;
}

ScanAssembler::Held* ScanAssembler::heldFor(const std::string& id) {
  if (std::find(recent_.begin(), recent_.end(), id) != recent_.end()) {
    ++counts_.late;
    return nullptr;
  }
  auto [it, fresh] = held_.try_emplace(id);
  if (fresh) held_order_.push_back(id);
  return &it->second;
}

void ScanAssembler::evictHeld() {
  while ((held_.size() > o_.max_held || held_bytes_ > o_.max_held_bytes) && !held_order_.empty()) {
    const auto oldest = held_.find(held_order_.front());
    if (oldest != held_.end()) {
      counts_.unclaimed += messages(oldest->second);
      held_bytes_ -= bytes(oldest->second);
      held_.erase(oldest);
    }
    held_order_.pop_front();
  }
}

std::size_t ScanAssembler::bytes(const Held& h) {
  std::size_t n = 0;
  for (const auto* m : {&h.labels, &h.pose, &h.truth_pose, &h.grid, &h.grid_origins})
    if (*m) n += (*m)->bytes.size();
  for (const auto* v : {&h.cameras.images, &h.cameras.infos, &h.cameras.truths})
    for (const ScanMessage& m : *v) n += m.bytes.size();
  return n;
}

void ScanAssembler::place(std::optional<ScanMessage> Held::*held_slot,
                          std::optional<ScanMessage> ScanMessages::*slot, const std::string& type,
                          const std::string& id, ScanMessage m) {
  const auto twice = [&](const ScanMessage& first) {
    return "two " + type + " messages for scan '" + id + "' (" + first.source + ", then " +
           m.source + "); expected one per scan";
  };
  if (Waiting* w = waitingScan(id)) {
    if (w->scan.*slot) {
      if (w->error.empty()) w->error = twice(*(w->scan.*slot));
    } else {
      w->scan.*slot = std::move(m);
    }
    return;
  }
  Held* h = heldFor(id);
  if (!h) return;
  if (h->*held_slot) {
    if (h->error.empty()) h->error = twice(*(h->*held_slot));
  } else {
    held_bytes_ += m.bytes.size();
    h->*held_slot = std::move(m);
  }
  evictHeld();
}

std::size_t ScanAssembler::messages(const Held& h) {
  return std::size_t(h.labels.has_value()) + h.pose.has_value() + h.truth_pose.has_value() +
         h.grid.has_value() + h.grid_origins.has_value() + h.cameras.images.size() +
         h.cameras.infos.size() + h.cameras.truths.size();
}

void ScanAssembler::add(const std::string& channel, const std::uint8_t* data, std::size_t size,
                        double now_s) {
  const LogChannels& ch = o_.channels;
  const bool read = channel == ch.points || channel == ch.labels || channel == ch.pose ||
                    channel == ch.truth_pose || channel == ch.imu || channel == ch.gps ||
                    channel == ch.odometry || channel == ch.images || channel == ch.camera_info ||
                    channel == ch.image_truth || channel == ch.grid || channel == ch.grid_origins;
  if (channel.empty() || !read) return;
  const std::optional<MessageStamp> stamp = peekMessageStamp(data, size);
  const std::string type = stamp ? stamp->type : "";
  ScanMessage m{"channel " + channel, std::vector<std::uint8_t>(data, data + size)};

  if (channel == ch.points && type == "point_cloud_t") {
    Waiting w;
    w.scan.id = stamp->frame_id.empty() ? "scan" + std::to_string(clouds_) : stamp->frame_id;
    ++clouds_;
    m.source += " (scan '" + w.scan.id + "')";
    w.scan.points = std::move(m);
    const auto held = held_.find(w.scan.id);
    if (held != held_.end()) {
      w.scan.labels = std::move(held->second.labels);
      w.scan.pose = std::move(held->second.pose);
      w.scan.truth_pose = std::move(held->second.truth_pose);
      w.scan.grid = std::move(held->second.grid);
      w.scan.grid_origins = std::move(held->second.grid_origins);
      w.error = held->second.error;
      held_bytes_ -= bytes(held->second);
      w.cameras = std::move(held->second.cameras);
      held_.erase(held);
      held_order_.erase(std::find(held_order_.begin(), held_order_.end(), w.scan.id));
    }
    // The samples up to the cloud's time; later ones wait for the next cloud.
    for (auto s = samples_.begin(); s != samples_.end();) {
      if (s->utime > stamp->utime) {
        ++s;
        continue;
      }
      (s->kind == 0 ? w.scan.imu : s->kind == 1 ? w.scan.gps : w.scan.odometry)
          .push_back(std::move(s->message));
      s = samples_.erase(s);
    }
    w.deadline_s = now_s + o_.wait_s;
    waiting_.push_back(std::move(w));
    if (waiting_.size() > o_.max_waiting) {
      waiting_.pop_front();
      ++counts_.scans_dropped;
    }
    return;
  }
  const bool labels = type == "point_labels_t" && channel == ch.labels;
  const bool pose = type == "pose_t" && channel == ch.pose;
  const bool truth = type == "pose_t" && channel == ch.truth_pose;
  const bool grid = type == "terrain_grid_t" && channel == ch.grid;
  const bool origins = type == "layer_origins_t" && channel == ch.grid_origins;
  if ((labels || pose || truth || grid || origins) && stamp->frame_id.empty()) {
    ++counts_.unnamed;
    return;
  }
  const bool image = type == "image_t" && channel == ch.images;
  const bool info = type == "camera_info_t" && channel == ch.camera_info;
  const bool truth_image = type == "image_t" && channel == ch.image_truth;
  if ((image || info || truth_image) && !stamp->frame_id.empty())
    return placeCamera(image ? 0 : info ? 1 : 2, stamp->frame_id, stamp->camera, std::move(m));
  if (image || info || truth_image) {
    ++counts_.unnamed;
    return;
  }
  if (labels)
    return place(&Held::labels, &ScanMessages::labels, type, stamp->frame_id, std::move(m));
  if (pose) return place(&Held::pose, &ScanMessages::pose, type, stamp->frame_id, std::move(m));
  if (truth)
    return place(&Held::truth_pose, &ScanMessages::truth_pose, type, stamp->frame_id,
                 std::move(m));
  if (grid) return place(&Held::grid, &ScanMessages::grid, type, stamp->frame_id, std::move(m));
  // Not waited for: lcm_publish sends them before the grid, so they are there when it is.
  if (origins)
    return place(&Held::grid_origins, &ScanMessages::grid_origins, type, stamp->frame_id,
                 std::move(m));
  const int kind = type == "imu_t" && channel == ch.imu           ? 0
                   : type == "gps_t" && channel == ch.gps         ? 1
                   : type == "odometry_t" && channel == ch.odometry ? 2
                                                                  : -1;
  if (kind >= 0) {
    samples_.push_back({stamp->utime, kind, std::move(m)});
    if (samples_.size() > o_.max_samples) {
      samples_.pop_front();
      ++counts_.samples_dropped;
    }
    return;
  }
  if (channel == ch.points) {
    // What should have been a scan cannot be read: said as the failure of a scan, so that the
    // run lists it, rather than counted and forgotten.
    ready_.push_back({std::nullopt, m.source,
                      "not a terramrf_msgs point_cloud_t (" + std::to_string(size) + " bytes" +
                          (stamp ? ", a " + stamp->type : "") + ")"});
    return;
  }
  ++counts_.foreign;
}

std::optional<ScanAssembler::Ready> ScanAssembler::pop(double now_s) {
  if (!ready_.empty()) {
    Ready r = std::move(ready_.front());
    ready_.pop_front();
    return r;
  }
  if (waiting_.empty()) return std::nullopt;
  Waiting& w = waiting_.front();
  if (!complete(w) && now_s < w.deadline_s) return std::nullopt;
  Ready r;
  if (!complete(w)) ++counts_.incomplete;
  if (w.error.empty()) w.error = w.cameras.error;
  w.scan.images = std::move(w.cameras.images);
  w.scan.camera_infos = std::move(w.cameras.infos);
  w.scan.image_truths = std::move(w.cameras.truths);
  recent_.push_back(w.scan.id);
  if (recent_.size() > kRecentIds) recent_.pop_front();
  if (w.error.empty()) {
    r.scan = std::move(w.scan);
  } else {
    r.error_source = w.scan.points.source;
    r.error = w.error;
  }
  waiting_.pop_front();
  return r;
}

std::optional<double> ScanAssembler::nextDeadline() const {
  if (!ready_.empty()) return -std::numeric_limits<double>::infinity();
  if (waiting_.empty()) return std::nullopt;
  return waiting_.front().deadline_s;
}

void ScanAssembler::flush() {
  for (Waiting& w : waiting_) w.deadline_s = -std::numeric_limits<double>::infinity();
  for (const auto& [id, h] : held_) counts_.unclaimed += messages(h);
  held_.clear();
  held_bytes_ = 0;
  held_order_.clear();
  counts_.samples_dropped += samples_.size();
  samples_.clear();
}

}  // namespace terramrf
