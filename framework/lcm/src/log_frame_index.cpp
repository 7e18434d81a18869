#include "terramrf/lcm/log_frame_index.hpp"

#include <algorithm>
#include <limits>
#include <map>
#include <unordered_map>

#include "terramrf/errors.hpp"
#include "terramrf/lcm/log_reader.hpp"
#include "terramrf/lcm/message_peek.hpp"

namespace terramrf {
namespace {

struct Keyed {
  std::int64_t offset = 0;
  std::int64_t eventnum = 0;
};

// Event numbers restart at 0 in a log appended to (mode=a), so errors give the byte too.
std::string eventName(std::int64_t eventnum, std::int64_t offset) {
  return "event " + std::to_string(eventnum) + " (byte " + std::to_string(offset) + ")";
}

// Why some messages of one channel were not used, one line per reason (LogFrameIndex::notes).
void unusedNotes(std::vector<std::string>& out, const std::string& channel,
                 const std::string& type, std::size_t foreign, std::size_t unnamed,
                 std::size_t unclaimed, const std::string& example) {
  if (foreign)
    out.push_back(std::to_string(foreign) + " event(s) on " + channel + " are not " + type +
                  " and were ignored");
  if (unnamed)
    out.push_back(std::to_string(unnamed) + " " + type + " message(s) on " + channel +
                  " name no scan (empty frame_id) and were ignored");
  if (unclaimed)
    out.push_back(std::to_string(unclaimed) + " " + type + " message(s) on " + channel +
                  " name a scan with no point cloud (e.g. '" + example + "') and were ignored");
}

// How much of each message the index reads: a message's time and scan id (and a camera's name)
// sit in its first bytes (message_peek.hpp). A message whose stamp lies further in is read whole.
constexpr std::size_t kPeekBytes = 4096;

// The stamp of `e`, read with kPeekBytes of its message: read whole when the prefix was too
// short to tell (a scan id or camera name longer than the prefix) in a message of a known type;
// a foreign message is never read whole (no length of it would make it ours).
std::optional<MessageStamp> stampOf(LcmLogReader& reader, LcmLogEvent& e) {
  std::optional<MessageStamp> s = peekMessageStamp(e.data.data(), e.data.size());
  const bool cut = static_cast<std::int64_t>(e.data.size()) < e.data_size;
  const bool camera_cut = s && s->camera.empty() && (s->type == "image_t" || s->type == "camera_info_t");
  if (cut && (!s || camera_cut) && knownMessageType(e.data.data(), e.data.size())) {
    e = reader.readAt(e.offset);
    s = peekMessageStamp(e.data.data(), e.data.size());
  }
  return s;
}

struct Sample {
  std::int64_t utime = 0;
  std::int64_t offset = 0;
};

// Messages of one channel that name their scan: frame_id → event. Two for one scan are refused:
// which one the sender meant cannot be told.
class ByScan {
 public:
  ByScan(std::string channel, std::string type, std::string path)
      : channel_(std::move(channel)), type_(std::move(type)), path_(std::move(path)) {}
  const std::string& channel() const { return channel_; }

  void add(const LcmLogEvent& e, const std::optional<MessageStamp>& stamp) {
    if (!stamp || stamp->type != type_) {
      ++foreign_;
      return;
    }
    if (stamp->frame_id.empty()) {
      ++unnamed_;
      return;
    }
    const auto [it, fresh] = events_.emplace(stamp->frame_id, Keyed{e.offset, e.eventnum});
    if (!fresh && !conflicts_.count(stamp->frame_id)) {
      conflicts_[stamp->frame_id] = eventName(it->second.eventnum, it->second.offset) + " and " +
                                    eventName(e.eventnum, e.offset) + " on channel " + channel_ +
                                    " both carry " + type_ + " for scan '" + stamp->frame_id +
                                    "'; expected one per scan";
    }
  }

  /// Why the scan cannot be read ("" if it can): two messages for it, of which the one meant
  /// cannot be told. Only that scan fails.
  std::string conflict(const std::string& id) const {
    const auto it = conflicts_.find(id);
    return it == conflicts_.end() ? "" : it->second;
  }

  std::optional<std::int64_t> take(const std::string& id) {
    const auto it = events_.find(id);
    if (it == events_.end()) return std::nullopt;
    const std::int64_t offset = it->second.offset;
    events_.erase(it);
    return offset;
  }

  void notes(std::vector<std::string>& out) const {
    std::size_t unclaimed = events_.size();
    unusedNotes(out, channel_, type_, foreign_, unnamed_, unclaimed,
                unclaimed ? events_.begin()->first : "");
  }

 private:
  std::string channel_, type_, path_;
  std::map<std::string, Keyed> events_;  // ordered: the notes' example is the same every run
  std::map<std::string, std::string> conflicts_;
  std::size_t foreign_ = 0, unnamed_ = 0;
};

// Messages of one channel of which a scan has several, one per camera: frame_id → events.
class PerCamera {
 public:
  PerCamera(std::string channel, std::string type)
      : channel_(std::move(channel)), type_(std::move(type)) {}
  const std::string& channel() const { return channel_; }
  void add(const LcmLogEvent& e, const std::optional<MessageStamp>& stamp) {
    if (!stamp || stamp->type != type_) {
      ++foreign_;
      return;
    }
    if (stamp->frame_id.empty()) {
      ++unnamed_;
      return;
    }
    events_[stamp->frame_id].push_back(e.offset);
  }
  std::vector<std::int64_t> take(const std::string& id) {
    const auto it = events_.find(id);
    if (it == events_.end()) return {};
    std::vector<std::int64_t> out = std::move(it->second);
    events_.erase(it);
    return out;
  }
  void notes(std::vector<std::string>& out) const {
    std::size_t unclaimed = 0;
    for (const auto& [id, offsets] : events_) unclaimed += offsets.size();
    unusedNotes(out, channel_, type_, foreign_, unnamed_, unclaimed,
                unclaimed ? events_.begin()->first : "");
  }

 private:
  std::string channel_, type_;
  std::map<std::string, std::vector<std::int64_t>> events_;
  std::size_t foreign_ = 0, unnamed_ = 0;
};

// Samples of one channel, attached by time once every cloud is known.
struct Samples {
  std::string channel, type;
  std::vector<Sample> samples;
  std::size_t foreign = 0;

  void add(const LcmLogEvent& e, const std::optional<MessageStamp>& stamp) {
    if (!stamp || stamp->type != type) {
      ++foreign;
      return;
    }
    samples.push_back({stamp->utime, e.offset});
  }
};

}  // namespace

LogFrameIndex indexLogFrames(const std::string& path, const LogChannels& ch) {
  if (ch.points.empty()) throw std::invalid_argument("indexLogFrames: no points channel");
  LcmLogReader reader(path);
  LogFrameIndex index;
  ByScan labels(ch.labels, "point_labels_t", path), pose(ch.pose, "pose_t", path),
      truth(ch.truth_pose, "pose_t", path), grid(ch.grid, "terrain_grid_t", path),
      origins(ch.grid_origins, "layer_origins_t", path);
  Samples imu{ch.imu, "imu_t"}, gps{ch.gps, "gps_t"}, odometry{ch.odometry, "odometry_t"};
  PerCamera images(ch.images, "image_t"), infos(ch.camera_info, "camera_info_t"),
      truths(ch.image_truth, "image_t");
  std::unordered_map<std::string, std::string> cloud_event;  // scan id → its event, named

  const std::string* ours[] = {&ch.points,      &ch.labels,      &ch.pose,     &ch.truth_pose,
                               &ch.imu,         &ch.gps,         &ch.odometry, &ch.images,
                               &ch.camera_info, &ch.image_truth, &ch.grid,     &ch.grid_origins};
  while (std::optional<LcmLogEvent> e = reader.next(kPeekBytes)) {
    ++index.channel_events[e->channel];
    const std::string& c = e->channel;
    if (std::none_of(std::begin(ours), std::end(ours),
                     [&](const std::string* o) { return !o->empty() && *o == c; }))
      continue;
    const std::optional<MessageStamp> stamp = stampOf(reader, *e);
    if (c == ch.points) {
      LogFrame f;
      f.points = e->offset;
      f.eventnum = e->eventnum;
      // A cloud that cannot be peeked stays a scan of its own: its read fails, naming the event,
      // and the run reports it and goes on, as for a damaged file in a folder.
      const bool cloud = stamp && stamp->type == "point_cloud_t";
      f.id = cloud && !stamp->frame_id.empty() ? stamp->frame_id
                                               : "event" + std::to_string(e->eventnum);
      // A cloud of unknown time takes its predecessor's, so that it neither breaks the time
      // order that samples need nor draws samples to itself.
      f.utime = cloud ? stamp->utime
                      : (index.frames.empty() ? std::numeric_limits<std::int64_t>::min()
                                              : index.frames.back().utime);
      const auto [it, fresh] = cloud_event.emplace(f.id, eventName(e->eventnum, e->offset));
      if (!fresh) {
        // Which of the two is the scan cannot be told, and both cannot run (one id, one set of
        // output files): the log is refused.
        throw InputError(path, it->second + " and " + eventName(e->eventnum, e->offset) +
                                   " on channel " + ch.points +
                                   " both carry the point cloud of scan '" + f.id +
                                   "'; expected one cloud per scan");
      }
      index.frames.push_back(std::move(f));
    }
    // One channel may carry several kinds (a pose and a truth pose on the same channel would be
    // ambiguous, but a sender may put samples wherever it likes): test each.
    if (!ch.labels.empty() && c == ch.labels) labels.add(*e, stamp);
    if (!ch.pose.empty() && c == ch.pose) pose.add(*e, stamp);
    if (!ch.truth_pose.empty() && c == ch.truth_pose) truth.add(*e, stamp);
    if (!ch.imu.empty() && c == ch.imu) imu.add(*e, stamp);
    if (!ch.gps.empty() && c == ch.gps) gps.add(*e, stamp);
    if (!ch.odometry.empty() && c == ch.odometry) odometry.add(*e, stamp);
    if (!ch.images.empty() && c == ch.images) images.add(*e, stamp);
    if (!ch.camera_info.empty() && c == ch.camera_info) infos.add(*e, stamp);
    if (!ch.image_truth.empty() && c == ch.image_truth) truths.add(*e, stamp);
    if (!ch.grid.empty() && c == ch.grid) grid.add(*e, stamp);
    if (!ch.grid_origins.empty() && c == ch.grid_origins) origins.add(*e, stamp);
  }
  index.skipped_bytes = reader.skippedBytes();

  for (LogFrame& f : index.frames) {
    for (const ByScan* b : {&labels, &pose, &truth, &grid, &origins})
      if (f.error.empty()) f.error = b->conflict(f.id);
    f.labels = labels.take(f.id);
    f.pose = pose.take(f.id);
    f.truth_pose = truth.take(f.id);
    f.grid = grid.take(f.id);
    f.grid_origins = origins.take(f.id);
    f.images = images.take(f.id);
    f.camera_infos = infos.take(f.id);
    f.image_truths = truths.take(f.id);
  }
  for (const ByScan* b : {&labels, &pose, &truth, &grid, &origins})
    if (!b->channel().empty()) b->notes(index.notes);
  for (const PerCamera* p : {&images, &infos, &truths})
    if (!p->channel().empty()) p->notes(index.notes);

  const bool any_samples = !imu.samples.empty() || !gps.samples.empty() ||
                           !odometry.samples.empty();
  for (std::size_t i = 1; any_samples && i < index.frames.size(); ++i) {
    if (index.frames[i].utime < index.frames[i - 1].utime) {
      throw InputError(path, "the point clouds on " + ch.points + " are not in time order (event " +
                                 std::to_string(index.frames[i].eventnum) + ", scan '" +
                                 index.frames[i].id + "', is older than the one before it), so "
                                 "the IMU, GPS and odometry samples cannot be given to scans");
    }
  }
  using Member = std::vector<std::int64_t> LogFrame::*;
  const std::pair<Samples*, Member> kinds[] = {
      {&imu, &LogFrame::imu}, {&gps, &LogFrame::gps}, {&odometry, &LogFrame::odometry}};
  for (const auto& [s, member] : kinds) {
    std::size_t after_last = 0;
    for (const Sample& smp : s->samples) {
      // The first scan at or after the sample: the sample happened since the scan before it.
      const auto it = std::lower_bound(
          index.frames.begin(), index.frames.end(), smp.utime,
          [](const LogFrame& f, std::int64_t t) { return f.utime < t; });
      if (it == index.frames.end()) {
        ++after_last;
        continue;
      }
      ((*it).*member).push_back(smp.offset);
    }
    unusedNotes(index.notes, s->channel, s->type, s->foreign, 0, 0, "");
    if (after_last)
      index.notes.push_back(std::to_string(after_last) + " " + s->type + " sample(s) on " +
                            s->channel + " come after the last scan and were ignored");
  }
  return index;
}

}  // namespace terramrf
