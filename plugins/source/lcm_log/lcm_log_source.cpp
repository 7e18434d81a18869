// Source plugin "lcm_log": scans from an LCM log (terramrf_msgs point_cloud_t, with point_labels_t,
// pose_t and IMU/GPS/odometry samples on further channels), such as `lcm_publish` writes with a
// file:// URL or lcm-logger records from live publishers. The log is indexed once at configure()
// (LogFrameIndex), so it is a batch: `compare` and `train` can use it, frames are read ahead on
// several threads, and a damaged message fails its scan alone (two clouds under one id, or
// clouds out of time order when samples are read, refuse the log: docs/plugins/readers.md).
#include <cstdio>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "terramrf/errors.hpp"
#include "terramrf/lcm/log_frame_index.hpp"
#include "terramrf/lcm/log_reader.hpp"
#include "terramrf/lcm/scan_messages.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {
namespace {

class LcmLogSource : public Source {
 public:
  void declare(ParamDecl& d) override {
    d.add("path", log_, "LCM log file to read (lcm-logger's, or lcm_publish's with a file:// url)")
        .required()
        .existingPath();
    d.add("points_channel", ch_.points,
          "channel of the point_cloud_t messages: one per scan, the scan's id its frame_id "
          "(lcm_publish with publish_points: <channel>_POINTS)");
    d.add("labels_channel", ch_.labels,
          "channel of point_labels_t ground truth, matched to scans by frame_id (lcm_publish "
          "with publish_truth: <channel>_LABELS); empty = no ground truth");
    d.add("pose_channel", ch_.pose,
          "channel of pose_t LiDAR poses for the pipeline (Frame::pose), matched by frame_id "
          "(lcm_publish with publish_pose: <channel>_POSE); every scan must have one; empty = "
          "no pose");
    d.add("truth_pose_channel", ch_.truth_pose,
          "channel of pose_t ground-truth poses (Frame::truth_pose), matched by frame_id "
          "(lcm_publish with publish_truth: <channel>_TRUTH_POSE); empty = none");
    d.add("imu_channel", ch_.imu,
          "channel of imu_t samples; each scan gets those after the previous scan's time, up to "
          "its own (the first scan every earlier one); needs the clouds in time order "
          "(lcm_publish with publish_samples: <channel>_IMU); empty = none");
    d.add("gps_channel", ch_.gps, "channel of gps_t samples, given to scans as imu_channel's");
    d.add("odometry_channel", ch_.odometry,
          "channel of odometry_t samples, given to scans as imu_channel's");
    d.add("drop_no_return", drop_no_return_, "drop points exactly at (0, 0, 0) (counted)");
  }

  void configure(const PluginContext& ctx) override {
    if (ch_.points.empty())
      throw ParamError("points_channel", "is empty; expected e.g. TERRAMRF_GRID_POINTS");
    if (!ch_.pose.empty() && ch_.pose == ch_.truth_pose)
      throw ParamError("truth_pose_channel",
                       "is pose_channel's (" + ch_.pose +
                           "); the pose to use and the ground truth must come on different "
                           "channels, or they could not be told apart");
    labels_ = ctx.labels ? *ctx.labels : LabelSet::defaults();
    try {
      index_ = indexLogFrames(log_, ch_);
    } catch (const InputError& e) {
      throw ParamError("path", e.what());
    }
    // A channel that the log does not carry at all is a typo or the wrong log, not "no data".
    const std::pair<const char*, const std::string*> asked[] = {
        {"points_channel", &ch_.points},     {"labels_channel", &ch_.labels},
        {"pose_channel", &ch_.pose},         {"truth_pose_channel", &ch_.truth_pose},
        {"imu_channel", &ch_.imu},           {"gps_channel", &ch_.gps},
        {"odometry_channel", &ch_.odometry}};
    for (const auto& [param, channel] : asked) {
      if (channel->empty() || index_.channel_events.count(*channel)) continue;
      std::string have;
      for (const auto& [c, n] : index_.channel_events)
        have += (have.empty() ? "" : ", ") + c + " (" + std::to_string(n) + ")";
      const std::string skipped =
          index_.skipped_bytes > 0
              ? " (" + std::to_string(index_.skipped_bytes) +
                    " byte(s) belong to no whole event: a damaged or cut log)"
              : "";
      throw ParamError(param, "'" + log_ + "' has no event on channel " + *channel +
                                  "; its channels (events): " +
                                  (have.empty() ? "none, no whole event in the log" : have) +
                                  skipped);
    }
    for (const std::string& n : index_.notes)
      std::fprintf(stderr, "lcm: %s: %s\n", log_.c_str(), n.c_str());
    if (index_.skipped_bytes > 0)
      std::fprintf(stderr,
                   "lcm: %s: %lld byte(s) belong to no whole event (damage, or a writer stopped "
                   "mid-event); the events around them are read\n",
                   log_.c_str(), static_cast<long long>(index_.skipped_bytes));
  }

  /// Every scan has a pose when a pose channel is read: one without fails (read()).
  std::vector<std::string> writes() const override {
    return ch_.pose.empty() ? std::vector<std::string>{}
                            : std::vector<std::string>{artefacts::kPose};
  }

  std::size_t size() const override { return index_.frames.size(); }
  std::string frameId(std::size_t i) const override { return index_.frames.at(i).id; }
  bool concurrentReads() const override { return true; }  // each read opens its own reader

  Frame read(std::size_t i) override {
    const LogFrame& lf = index_.frames.at(i);
    if (!lf.error.empty()) throw InputError(log_, lf.error);
    LcmLogReader reader(log_);
    const auto message = [&](std::int64_t offset) {
      LcmLogEvent e = reader.readAt(offset);
      return ScanMessage{log_ + " event " + std::to_string(e.eventnum) + " (" + e.channel + ")",
                         std::move(e.data)};
    };
    ScanMessages m;
    m.id = lf.id;
    m.points = message(lf.points);
    if (lf.labels) m.labels = message(*lf.labels);
    if (lf.pose) m.pose = message(*lf.pose);
    if (lf.truth_pose) m.truth_pose = message(*lf.truth_pose);
    for (std::int64_t at : lf.imu) m.imu.push_back(message(at));
    for (std::int64_t at : lf.gps) m.gps.push_back(message(at));
    for (std::int64_t at : lf.odometry) m.odometry.push_back(message(at));
    ScanOptions o;
    o.labels = &labels_;
    o.pose_channel = ch_.pose;
    o.drop_no_return = drop_no_return_;
    o.source_path = log_;
    return frameFromMessages(m, o);
  }

 private:
  std::string log_;
  bool drop_no_return_ = true;
  LogChannels ch_{"TERRAMRF_GRID_POINTS"};
  LabelSet labels_ = LabelSet::defaults();
  LogFrameIndex index_;
};

}  // namespace
}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::LcmLogSource, terramrf::PluginKind::kSource, "lcm_log",
                "scans from an LCM log: point clouds with their labels, poses and IMU/GPS/"
                "odometry samples")
