// Source plugin "lcm_log": scans from an LCM log (terramrf_msgs point_cloud_t, with point_labels_t,
// pose_t and IMU/GPS/odometry samples on further channels), such as `lcm_publish` writes with a
// file:// URL or lcm-logger records from live publishers. The log is indexed once at configure()
// (LogFrameIndex), so it is a batch: `compare` and `train` can use it, frames are read ahead on
// several threads, and a damaged message fails its scan alone (two clouds under one id, or
// clouds out of time order when samples are read, refuse the log: docs/plugins/readers.md).
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "terramrf/errors.hpp"
#include "terramrf/lcm/log_frame_index.hpp"
#include "terramrf/lcm/log_reader.hpp"
#include "terramrf/lcm/origins_codec.hpp"
#include "terramrf/lcm/scan_channels.hpp"
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
    declareScanChannels(d, sp_);
    d.add("drop_no_return", drop_no_return_, "drop points exactly at (0, 0, 0) (counted)");
  }

  void configure(const PluginContext& ctx) override {
    checkScanChannels(sp_);
    labels_ = ctx.labels ? *ctx.labels : LabelSet::defaults();
    ch_.grid_origins = gridOriginsChannel(sp_);
    try {
      index_ = indexLogFrames(log_, ch_);
    } catch (const InputError& e) {
      throw ParamError("path", e.what());
    }
    // A channel that the log does not carry at all is a typo or the wrong log, not "no data".
    const std::pair<const char*, const std::string*> asked[] = {
        {"points_channel", &ch_.points},
        {"labels_channel", &ch_.labels},
        {"pose_channel", &ch_.pose},
        {"truth_pose_channel", &ch_.truth_pose},
        {"imu_channel", &ch_.imu},
        {"gps_channel", &ch_.gps},
        {"odometry_channel", &ch_.odometry},
        {"images_channel", &ch_.images},
        {"camera_info_channel", &ch_.camera_info},
        {"image_truth_channel", &ch_.image_truth},
        {"grid_channel", &ch_.grid},
        {"grid_origins_channel", &sp_.grid_origins_channel}};
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
    if (!ch_.grid_origins.empty() && !index_.channel_events.count(ch_.grid_origins)) {
      // Not asked for by name, and absent: a log of another sender, or of an older TerraMRF.
      std::fprintf(stderr,
                   "lcm: %s: no layer_origins_t on %s: how the grids' layers were computed is "
                   "unknown, so a model cannot be checked against them\n",
                   log_.c_str(), ch_.grid_origins.c_str());
      ch_.grid_origins.clear();
    }
    if (!ch_.grid_origins.empty()) readOrigins();
    for (const std::string& n : index_.notes)
      std::fprintf(stderr, "lcm: %s: %s\n", log_.c_str(), n.c_str());
    if (index_.skipped_bytes > 0)
      std::fprintf(stderr,
                   "lcm: %s: %lld byte(s) belong to no whole event (damage, or a writer stopped "
                   "mid-event); the events around them are read\n",
                   log_.c_str(), static_cast<long long>(index_.skipped_bytes));
  }

  /// The cameras listed (their images and calibrations come with every scan).
  std::vector<std::string> cameraNames() const override { return sp_.cameras; }

  /// Every scan has a pose when a pose channel is read: one without fails (read()).
  std::vector<std::string> writes() const override { return scanWrites(sp_); }

  std::map<std::string, std::string> layerOrigins() const override { return origins_; }

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
    if (lf.grid) m.grid = message(*lf.grid);
    if (lf.grid_origins) m.grid_origins = message(*lf.grid_origins);
    // Its origins were compared with the log's at configure(): a scan without them could not be
    // (unless no layer taken has an origin to compare).
    if (!ch_.grid_origins.empty() && !origins_.empty() && !lf.grid_origins)
      throw InputError(log_, "event " + std::to_string(lf.eventnum) + " (" + ch_.points +
                                 "): no layer_origins_t on channel " + ch_.grid_origins +
                                 " for scan '" + lf.id +
                                 "'; the log carries them for other scans, so every scan needs "
                                 "its own (how its layers were computed)");
    for (std::int64_t at : lf.imu) m.imu.push_back(message(at));
    for (std::int64_t at : lf.gps) m.gps.push_back(message(at));
    for (std::int64_t at : lf.odometry) m.odometry.push_back(message(at));
    if (!sp_.cameras.empty()) {
      for (std::int64_t at : lf.images) m.images.push_back(message(at));
      for (std::int64_t at : lf.camera_infos) m.camera_infos.push_back(message(at));
      for (std::int64_t at : lf.image_truths) m.image_truths.push_back(message(at));
    }
    return frameFromMessages(m, scanOptions(sp_, labels_, drop_no_return_, log_));
  }

 private:
  /// The origins of the grid layers taken, from the first scan whose layer_origins_t decodes; a
  /// scan whose message cannot be decoded, or describes a taken layer otherwise, fails alone
  /// (LogFrame::error): one model cannot be right for both.
  void readOrigins() {
    LcmLogReader reader(log_);
    std::string first_event;
    bool have = false;
    for (LogFrame& lf : index_.frames) {
      if (!lf.grid_origins || !lf.error.empty()) continue;
      const LcmLogEvent e = reader.readAt(*lf.grid_origins);
      const std::string event = "event " + std::to_string(e.eventnum) + " (" + e.channel + ")";
      DecodedLayerOrigins d;
      try {
        d = decodeLayerOrigins(e.data.data(), e.data.size(), event);
      } catch (const InputError& err) {
        lf.error = err.what();
        continue;
      }
      std::map<std::string, std::string> taken;
      for (const std::string& l : sp_.grid_layers)
        if (const auto it = d.origins.find(l); it != d.origins.end()) taken.insert(*it);
      if (!have) {
        origins_ = std::move(taken);
        first_event = event;
        have = true;
        continue;
      }
      if (taken == origins_) continue;
      std::string which;
      for (const std::string& l : sp_.grid_layers) {
        const auto a = origins_.find(l), b = taken.find(l);
        const bool in_a = a != origins_.end(), in_b = b != taken.end();
        if (in_a != in_b || (in_a && a->second != b->second)) {
          which = l;
          break;
        }
      }
      lf.error = event + ": layer '" + which + "' of scan '" + lf.id +
                 "' was computed otherwise than the log's first scan's (" + first_event +
                 "): the sender's stages changed during the recording, so one model cannot fit "
                 "both";
    }
  }

  std::string log_;
  std::map<std::string, std::string> origins_;
  bool drop_no_return_ = true;
  ScanChannelParams sp_;
  LogChannels& ch_ = sp_.channels;
  LabelSet labels_ = LabelSet::defaults();
  LogFrameIndex index_;
};

}  // namespace
}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::LcmLogSource, terramrf::PluginKind::kSource, "lcm_log",
                "scans from an LCM log: point clouds with their labels, poses and IMU/GPS/"
                "odometry samples")
