// Output "lcm_publish": publishes each labelled grid as terramrf_msgs.terrain_grid_t and, if
// asked, the scan's pose, ground truth, camera images with their calibrations, IMU/GPS/odometry
// samples and points, so that a log it writes can be read back as a
// source (lcm_log). Writes nothing to disk, except the LCM log a file:// URL names.
#include <map>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "terramrf/lcm/camera_codec.hpp"
#include "terramrf/lcm/grid_publisher.hpp"
#include "terramrf/lcm/labels_codec.hpp"
#include "terramrf/lcm/log_writer.hpp"
#include "terramrf/lcm/origins_codec.hpp"
#include "terramrf/lcm/pose_codec.hpp"
#include "terramrf/lcm/sensor_codec.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {
namespace {

class LcmPublishOutput : public Output {
 public:
  void declare(ParamDecl& d) override {
    d.add("url", url_,
          "LCM provider URL (udpm://group:port?ttl=N for the network, memq:// in-process, "
          "file:///path.lcmlog?mode=w to log (mode=a appends); empty = $LCM_DEFAULT_URL)");
    d.add("channel", channel_, "channel of the terrain_grid_t messages");
    d.add("layers", layers_, "float layers to send; empty = every layer of the grid").unique();
    d.add("publish_grid", publish_grid_,
          "publish the labelled grid (terrain_grid_t on <channel>), after how its layers were "
          "computed (layer_origins_t on <channel>_ORIGINS); false records a source's scans "
          "without classifying them (no stage needed before it)");
    d.add("publish_points", publish_points_,
          "also publish the scan's points as point_cloud_t on <channel>_POINTS");
    d.add("publish_pose", publish_pose_,
          "also publish the scan's pose (Frame::pose, with its covariance) as pose_t on "
          "<channel>_POSE, for scans that have one");
    d.add("publish_truth", publish_truth_,
          "also publish the scan's ground truth, for scans that have it: per-point classes as "
          "point_labels_t on <channel>_LABELS, the ground-truth pose as pose_t on "
          "<channel>_TRUTH_POSE");
    d.add("publish_samples", publish_samples_,
          "also publish the IMU, GPS and odometry samples that came with the scan (since the "
          "scan before) as imu_t, gps_t and odometry_t on <channel>_IMU, _GPS and _ODOMETRY, "
          "each stamped in a log with its own time under log_time: frame");
    d.add("publish_images", publish_images_,
          "also publish each camera's image as image_t on <channel>_IMAGE and its calibration "
          "as camera_info_t on <channel>_CAMERA_INFO, so that a log carries what camera "
          "features and the textured mesh need (with publish_truth, per-pixel truth images on "
          "<channel>_IMAGE_TRUTH)");
    d.add("log_time", log_time_,
          "time of each event in a file:// log: 'wall' (when it was written, as LCM's logger "
          "records) or 'frame' (the frame's own timestamp, so lcm-logplayer replays a dataset "
          "at its recorded rate)")
        .choices({"wall", "frame"});
  }

  void configure(const PluginContext& ctx) override {
    if (channel_.empty()) throw ParamError("channel", "is empty; expected e.g. TERRAMRF_GRID");
    if (!publish_grid_ && !layers_.empty())
      throw ParamError("layers", "lists layers of the grid, which publish_grid: false does not send");
    if (!publish_grid_ && !publish_points_ && !publish_pose_ && !publish_truth_ &&
        !publish_samples_ && !publish_images_)
      throw ParamError("publish_grid", "is false and no publish_* is true: nothing would be sent");
    if (!url_.empty()) {
      const auto sep = url_.find("://");
      const std::string provider = sep == std::string::npos ? "" : url_.substr(0, sep);
      static const std::set<std::string> kProviders = {"udpm", "tcpq", "file", "memq"};
      if (!kProviders.count(provider)) {
        throw ParamError("url", "'" + url_ +
                                    "' is not an LCM URL; expected provider://address "
                                    "with provider udpm, tcpq, file or memq");
      }
      // A log is written by terramrf_lcm itself (LCM's provider hid failed writes); the same
      // reading of the URL refuses one LCM would open for reading (every publish failed).
      if (provider == "file") {
        try {
          parseLcmLogUrl(url_);
        } catch (const std::invalid_argument& e) {
          throw ParamError("url", e.what());
        }
      } else if (log_time_ == "frame") {
        // Live receivers stamp the arrival: the setting would be silently without effect.
        throw ParamError("log_time",
                         "'frame' applies to a log being written (url file://...); "
                         "'" +
                             url_ +
                             "' publishes live, where each receiver "
                             "stamps the arrival time");
      }
    }
    if (ctx.labels) labels_ = *ctx.labels;
    if (ctx.layer_origins) origins_ = *ctx.layer_origins;
  }

  std::vector<std::string> reads() const override {
    if (!publish_grid_) return {};
    std::vector<std::string> r{artefacts::kLabels};
    r.insert(r.end(), layers_.begin(), layers_.end());
    return r;
  }

  // LCM is opened here rather than in configure() so validating a config opens no socket.
  void begin(const RunInfo& info) override {
    if (info.labels) labels_ = *info.labels;
    publisher_ = makePublisher();
    if (log_time_ == "frame" && !publisher_->writesLog())  // url empty: $LCM_DEFAULT_URL decided
      throw ParamError("log_time", "'frame' applies to a log being written (file://...), but "
                                   "$LCM_DEFAULT_URL publishes live, where each receiver stamps "
                                   "the arrival time");
  }

  void write(const FrameContext& ctx) override {
    if (!ctx.frame || !ctx.grid) {
      throw std::invalid_argument("lcm_publish: frame context without a frame or a grid");
    }
    if (!publisher_) publisher_ = makePublisher();
    MessageHeader header;
    header.frame_id = ctx.frame->id;
    header.timestamp_s = ctx.frame->timestamp_s;
    const LabelSet& labels = ctx.labels ? *ctx.labels : labels_;
    const Frame& f = *ctx.frame;
    if (publish_grid_) {
      // How the layers sent were computed, just before them: a receiver that takes them as they
      // came (lcm_log's grid_layers) checks its model against these.
      std::map<std::string, std::string> sent;
      for (const std::string& l : layers_.empty() ? ctx.grid->layerNames() : layers_)
        if (const auto it = origins_.find(l); it != origins_.end()) sent.insert(*it);
      if (!sent.empty())
        publisher_->publishForScan(channel_ + "_ORIGINS", encodeLayerOrigins(sent, header), header);
      publisher_->publish(*ctx.grid, labels, header, layers_);
    }
    // The points go last: a receiver assembling scans takes the cloud as the scan's end.
    if (publish_pose_) {
      if (const auto pose = framePoseMessage(f))
        publisher_->publishForScan(channel_ + "_POSE", encodePose(*pose), header);
    }
    if (publish_truth_) {
      if (f.truth_pose) {
        PoseMessage truth;
        truth.header = header;
        truth.header.coordinate_frame = "world";
        truth.pose = *f.truth_pose;
        publisher_->publishForScan(channel_ + "_TRUTH_POSE", encodePose(truth), header);
      }
      if (!f.truth.empty())
        publisher_->publishForScan(channel_ + "_LABELS", encodePointLabels(f.truth, labels, header),
                                   header);
    }
    if (publish_images_) {
      for (std::size_t i = 0; i < f.cameras.size(); ++i) {
        const CameraImage& c = f.cameras[i];
        CameraModel model = c.model;
        model.name = cameraName(f, i);
        // A calibration sent without its image would fail the scan on the receiving side with
        // no hint of why: said here, where the frame is.
        if (!c.image)
          throw std::invalid_argument("lcm_publish: camera '" + model.name + "' of frame " +
                                      f.id + " has no image to publish (publish_images)");
        publisher_->publishForScan(channel_ + "_IMAGE", encodeImage(*c.image, model.name, header),
                                   header);
        publisher_->publishForScan(channel_ + "_CAMERA_INFO", encodeCameraInfo(model, header),
                                   header);
        if (publish_truth_ && c.truth)
          publisher_->publishForScan(channel_ + "_IMAGE_TRUTH",
                                     encodeImage(*c.truth, model.name, header), header);
      }
    }
    if (publish_samples_) {
      // Stamped with their own times, so a log replays them between the scans, as recorded.
      const auto sample = [&](const std::string& suffix, double t_s, const MessageBytes& b) {
        MessageHeader at = header;
        at.timestamp_s = t_s;
        publisher_->publishForScan(channel_ + suffix, b, at);
      };
      for (const ImuSample& s : f.imu) sample("_IMU", s.t_s, encodeImu(s));
      for (const GpsSample& s : f.gps) sample("_GPS", s.t_s, encodeGps(s));
      for (const OdometrySample& s : f.odometry) sample("_ODOMETRY", s.t_s, encodeOdometry(s));
    }
    if (publish_points_) publisher_->publishPoints(f.points, header);
  }

  // Closing a log saves its last bytes: a failure there is the run's output error, not lost.
  void end(const RunSummary& /*summary*/) override {
    if (!publisher_) return;
    std::unique_ptr<GridPublisher> p = std::move(publisher_);  // gone even if close() throws
    p->close();
  }

 private:
  std::unique_ptr<GridPublisher> makePublisher() const {
    auto p = std::make_unique<GridPublisher>(url_, channel_);
    p->stampLogWithMessageTime(log_time_ == "frame");
    return p;
  }

  std::string url_ = "udpm://239.255.76.67:7667?ttl=0";
  std::string channel_ = "TERRAMRF_GRID";
  std::vector<std::string> layers_;
  bool publish_grid_ = true;
  bool publish_points_ = false;
  bool publish_pose_ = false;
  bool publish_truth_ = false;
  bool publish_samples_ = false;
  bool publish_images_ = false;
  std::string log_time_ = "wall";

  LabelSet labels_ = LabelSet::defaults();
  std::map<std::string, std::string> origins_;  ///< how the run computes each layer
  std::unique_ptr<GridPublisher> publisher_;
};

}  // namespace
}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::LcmPublishOutput, terramrf::PluginKind::kOutput, "lcm_publish",
                "publishes the labelled grid, and optionally the scan's points, poses, ground "
                "truth, camera images and samples, over LCM (live, or to a log)")
