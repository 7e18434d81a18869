// Source plugin "lcm_subscribe": a stream of scans received live over LCM, as lcm_publish sends
// them (publish_points, and publish_pose / publish_truth / publish_samples for the rest) or any
// publisher of terramrf_msgs point_cloud_t. Scans are put together by ScanAssembler; the run
// ends when the stream has been idle for idle_timeout_s, at --limit, or on Ctrl-C. A log file is
// the lcm_log source's: it reads it as a batch.
#include <fcntl.h>
#include <lcm/lcm.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "terramrf/errors.hpp"
#include "terramrf/lcm/lcm_instance.hpp"
#include "terramrf/lcm/scan_assembler.hpp"
#include "terramrf/lcm/scan_messages.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {
namespace {

double steadyNow() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

class LcmSubscribeSource : public StreamSource {
 public:
  LcmSubscribeSource() {
    // The wake-up for interrupt(): next() polls it beside LCM's socket.
    if (::pipe2(wake_, O_CLOEXEC | O_NONBLOCK) != 0) wake_[0] = wake_[1] = -1;
  }
  ~LcmSubscribeSource() override {
    close();
    for (int fd : wake_)
      if (fd >= 0) ::close(fd);
  }

  void declare(ParamDecl& d) override {
    d.add("url", url_,
          "LCM provider URL to listen on (udpm://group:port?ttl=N; memq:// meets publishers of "
          "the same process)");
    d.add("points_channel", ch_.points,
          "channel of the point_cloud_t messages: one per scan, the scan's id its frame_id "
          "(lcm_publish with publish_points: <channel>_POINTS)");
    d.add("labels_channel", ch_.labels,
          "channel of point_labels_t ground truth, matched to scans by frame_id; empty = none");
    d.add("pose_channel", ch_.pose,
          "channel of pose_t LiDAR poses (Frame::pose), matched by frame_id; every scan must "
          "have one; empty = no pose");
    d.add("truth_pose_channel", ch_.truth_pose,
          "channel of pose_t ground-truth poses (Frame::truth_pose), matched by frame_id; "
          "empty = none");
    d.add("imu_channel", ch_.imu,
          "channel of imu_t samples; each scan gets those up to its own time; empty = none");
    d.add("gps_channel", ch_.gps, "channel of gps_t samples, given to scans as imu_channel's");
    d.add("odometry_channel", ch_.odometry,
          "channel of odometry_t samples, given to scans as imu_channel's");
    d.add("wait_s", wait_s_,
          "how long a scan waits after its point cloud for labels and poses still missing "
          "(lcm_publish sends them before the points, so they need none)")
        .unit("s")
        .range(0, 60);
    d.add("idle_timeout_s", idle_timeout_s_,
          "end the stream when no point cloud has come for this long; 0 = wait until stopped "
          "(Ctrl-C, --limit)")
        .unit("s")
        .range(0, 86400);
    d.add("drop_no_return", drop_no_return_, "drop points exactly at (0, 0, 0) (counted)");
  }

  void configure(const PluginContext& ctx) override {
    if (url_.empty()) throw ParamError("url", "is empty; expected e.g. udpm://239.255.76.67:7667?ttl=0");
    if (url_.rfind("file://", 0) == 0)
      throw ParamError("url", "'" + url_ + "' is a log file; read it with the lcm_log source "
                                           "(a batch: indexed, read ahead, usable by compare "
                                           "and train)");
    if (ch_.points.empty())
      throw ParamError("points_channel", "is empty; expected e.g. TERRAMRF_GRID_POINTS");
    if (!ch_.pose.empty() && ch_.pose == ch_.truth_pose)
      throw ParamError("truth_pose_channel",
                       "is pose_channel's (" + ch_.pose +
                           "); the pose to use and the ground truth must come on different "
                           "channels, or they could not be told apart");
    if (wake_[0] < 0) throw ParamError("", "cannot make the pipe that lets Ctrl-C end a wait");
    labels_ = ctx.labels ? *ctx.labels : LabelSet::defaults();
  }

  std::vector<std::string> writes() const override {
    return ch_.pose.empty() ? std::vector<std::string>{}
                            : std::vector<std::string>{artefacts::kPose};
  }

  std::optional<Frame> next() override {
    if (stopped_ || ended_) return std::nullopt;
    if (!lcm_) open();
    for (;;) {
      const double now = steadyNow();
      if (std::optional<ScanAssembler::Ready> r = assembler_->pop(now)) {
        if (!r->scan) throw InputError(r->error_source, r->error);
        ScanOptions o;
        o.labels = &labels_;
        o.pose_channel = ch_.pose;
        o.drop_no_return = drop_no_return_;
        o.source_path = url_;
        return frameFromMessages(*r->scan, o);
      }
      if (idle_timeout_s_ > 0 && now - last_cloud_s_ >= idle_timeout_s_) {
        assembler_->flush();
        if (assembler_->empty()) {
          ended_ = true;
          note();
          return std::nullopt;
        }
        continue;
      }
      // Wait for a message, the next scan's deadline, the idle end, or interrupt().
      double wait = 0.5;
      if (const auto d = assembler_->nextDeadline()) wait = std::min(wait, *d - now);
      if (idle_timeout_s_ > 0) wait = std::min(wait, last_cloud_s_ + idle_timeout_s_ - now);
      pollfd fds[2] = {{lcm_get_fileno(lcm_.get()), POLLIN, 0}, {wake_[0], POLLIN, 0}};
      const int ms = static_cast<int>(std::ceil(std::max(0.0, wait) * 1000));
      if (::poll(fds, 2, ms) < 0 && errno != EINTR)
        throw InputError(url_, std::string("waiting for LCM messages failed: ") +
                                   std::strerror(errno));
      if (stopped_) return std::nullopt;
      if (fds[0].revents & POLLIN) {
        if (lcm_handle(lcm_.get()) != 0)
          throw InputError(url_, "LCM could not receive a message");
      }
    }
  }

  void interrupt() override {
    stopped_ = true;
    if (wake_[1] >= 0) {
      const char b = 1;
      [[maybe_unused]] const ssize_t n = ::write(wake_[1], &b, 1);
    }
  }

 private:
  // LCM is opened at the first next() rather than in configure(), so that validating a config
  // opens no socket.
  void open() {
    ScanAssembler::Options o;
    o.channels = ch_;
    o.wait_s = wait_s_;
    assembler_ = std::make_unique<ScanAssembler>(o);
    try {
      lcm_ = openLcm(url_);
    } catch (const std::exception& e) {
      throw InputError(url_, e.what());
    }
    std::vector<std::string> channels = {ch_.points, ch_.labels, ch_.pose, ch_.truth_pose,
                                         ch_.imu,    ch_.gps,    ch_.odometry};
    std::sort(channels.begin(), channels.end());
    channels.erase(std::unique(channels.begin(), channels.end()), channels.end());
    for (const std::string& c : channels) {
      if (c.empty()) continue;
      // LCM takes the channel as a regular expression; ours are names, so anchor and escape it.
      std::string re;
      for (char ch : c) {
        if (std::string("\\^$.|?*+()[]{}").find(ch) != std::string::npos) re += '\\';
        re += ch;
      }
      subscriptions_.push_back(lcm_subscribe(lcm_.get(), re.c_str(), &onMessage, this));
    }
    last_cloud_s_ = steadyNow();
  }

  static void onMessage(const lcm_recv_buf_t* rbuf, const char* channel, void* self) {
    auto* s = static_cast<LcmSubscribeSource*>(self);
    const double now = steadyNow();
    if (s->ch_.points == channel) s->last_cloud_s_ = now;
    s->assembler_->add(channel, static_cast<const std::uint8_t*>(rbuf->data), rbuf->data_size,
                       now);
  }

  void note() const {
    const ScanAssembler::Counts& c = assembler_->counts();
    if (c.late || c.dropped || c.foreign || c.samples_dropped)
      std::fprintf(stderr,
                   "lcm_subscribe: %s: unused: %zu label/pose message(s) after their scan had "
                   "left (raise wait_s), %zu never matched a scan, %zu of another type, %zu "
                   "sample(s) over the buffer\n",
                   url_.c_str(), c.late, c.dropped, c.foreign, c.samples_dropped);
  }

  void close() {
    for (lcm_subscription_t* s : subscriptions_) lcm_unsubscribe(lcm_.get(), s);
    subscriptions_.clear();
    lcm_.reset();
  }

  std::string url_ = "udpm://239.255.76.67:7667?ttl=0";
  LogChannels ch_{"TERRAMRF_GRID_POINTS"};
  double wait_s_ = 0.5;
  double idle_timeout_s_ = 0;
  bool drop_no_return_ = true;

  LabelSet labels_ = LabelSet::defaults();
  std::shared_ptr<::_lcm_t> lcm_;
  std::vector<lcm_subscription_t*> subscriptions_;
  std::unique_ptr<ScanAssembler> assembler_;
  double last_cloud_s_ = 0;
  int wake_[2] = {-1, -1};
  std::atomic<bool> stopped_{false};
  bool ended_ = false;
};

}  // namespace
}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::LcmSubscribeSource, terramrf::PluginKind::kSource, "lcm_subscribe",
                "a stream of scans received live over LCM: point clouds with their labels, poses "
                "and IMU/GPS/odometry samples")
