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
#include <exception>
#include <mutex>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "terramrf/errors.hpp"
#include "terramrf/lcm/lcm_instance.hpp"
#include "terramrf/lcm/scan_assembler.hpp"
#include "terramrf/lcm/scan_channels.hpp"
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
    declareScanChannels(d, sp_);
    d.add("wait_s", wait_s_,
          "how long a scan waits after its point cloud for labels and poses its channels read "
          "and it has not yet received (lcm_publish sends them before the points; a scan it "
          "has none of, e.g. no ground truth, waits this long)")
        .unit("s")
        .range(0, 60);
    d.add("idle_timeout_s", idle_timeout_s_,
          "end the stream when no point cloud has come for this long; 0 = wait until stopped "
          "(Ctrl-C, --limit)")
        .unit("s")
        .range(0, 86400);
    d.add("queue_scans", queue_scans_,
          "scans received and not yet taken by the stages, at most; when the stages fall "
          "behind the sender the oldest are dropped (counted) and the newest run")
        .unit("1")
        .range(1, 1000);
    d.add("drop_no_return", drop_no_return_, "drop points exactly at (0, 0, 0) (counted)");
  }

  void configure(const PluginContext& ctx) override {
    if (url_.empty()) throw ParamError("url", "is empty; expected e.g. udpm://239.255.76.67:7667?ttl=0");
    if (url_.rfind("file://", 0) == 0)
      throw ParamError("url", "'" + url_ + "' is a log file; read it with the lcm_log source "
                                           "(a batch: indexed, read ahead, usable by compare "
                                           "and train)");
    checkScanChannels(sp_);
    ch_.grid_origins = gridOriginsChannel(sp_);
    if (wake_[0] < 0)
      throw std::runtime_error("lcm_subscribe: cannot make the pipe that lets Ctrl-C end a wait: " +
                               std::string(std::strerror(errno)));
    labels_ = ctx.labels ? *ctx.labels : LabelSet::defaults();
  }

  /// The cameras listed (their images and calibrations come with every scan).
  std::vector<std::string> cameraNames() const override { return sp_.cameras; }

  std::vector<std::string> writes() const override { return scanWrites(sp_); }

  std::optional<Frame> next() override {
    if (ended_) return std::nullopt;
    if (!lcm_) open();  // ends the stream (ended_) if LCM cannot be opened
    for (;;) {
      if (stopped_) return end();
      // What has come is taken first, so that a consumer slower than idle_timeout_s does not end
      // a stream whose clouds sit in LCM's queue.
      receive(0);
      const double now = steadyNow();
      if (std::optional<ScanAssembler::Ready> r = assembler_->pop(now)) {
        if (!r->scan) throw InputError(r->error_source, r->error);
        Frame f = frameFromMessages(*r->scan, scanOptions(sp_, labels_, drop_no_return_, url_));
        // Once the stream has brought origins for the layers taken, a scan without them could
        // not be checked against the model: it fails, as in a log. Before that (the first scan
        // after subscribing may have missed its own) it runs unchecked.
        if (f.grid && !ch_.grid_origins.empty()) {
          if (!f.layer_origins.empty()) {
            origins_seen_ = true;
          } else if (origins_seen_) {
            throw InputError(r->scan->points.source,
                             "no layer_origins_t on channel " + ch_.grid_origins + " for scan '" +
                                 f.id +
                                 "'; the stream has carried them for earlier scans, so every "
                                 "scan needs its own (how its layers were computed)");
          }
        }
        return f;
      }
      if (idle_timeout_s_ > 0 && now - last_cloud_s_ >= idle_timeout_s_) {
        assembler_->flush();
        if (assembler_->empty()) return end();
        continue;
      }
      // Wait for a message, the next scan's deadline, the idle end, or interrupt().
      double wait = 0.5;
      if (const auto d = assembler_->nextDeadline()) wait = std::min(wait, *d - now);
      if (idle_timeout_s_ > 0) wait = std::min(wait, last_cloud_s_ + idle_timeout_s_ - now);
      receive(static_cast<int>(std::ceil(std::max(0.0, wait) * 1000)));
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
  // opens no socket. A subscriber receives only what is published after this.
  void open() {
    ScanAssembler::Options o;
    o.channels = ch_;
    o.wait_s = wait_s_;
    o.max_waiting = queue_scans_;
    o.cameras = sp_.cameras;
    assembler_ = std::make_unique<ScanAssembler>(o);
    try {
      if (url_.rfind("memq://", 0) == 0) claimMemq();
      lcm_ = openLcm(url_);
    } catch (const std::exception& e) {
      fail(e.what());
    }
    std::vector<std::string> channels = {ch_.points,     ch_.labels, ch_.pose,
                                         ch_.truth_pose, ch_.imu,    ch_.gps,
                                         ch_.odometry,   ch_.grid,   ch_.grid_origins};
    if (!sp_.cameras.empty()) {
      channels.push_back(ch_.images);
      channels.push_back(ch_.camera_info);
      channels.push_back(ch_.image_truth);
    }
    std::sort(channels.begin(), channels.end());
    channels.erase(std::unique(channels.begin(), channels.end()), channels.end());
    for (const std::string& c : channels) {
      if (c.empty()) continue;
      // LCM takes the channel as a regular expression (anchored by LCM); ours are names.
      std::string re;
      for (char ch : c) {
        if (std::string("\\^$.|?*+()[]{}").find(ch) != std::string::npos) re += '\\';
        re += ch;
      }
      subscriptions_.push_back(lcm_subscribe(lcm_.get(), re.c_str(), &onMessage, this));
    }
    last_cloud_s_ = steadyNow();
  }

  /// Takes what LCM has (waiting up to `timeout_ms` for the first message). A receive error
  /// ends the stream: it will not mend, and a stream that cannot go on returns nullopt.
  void receive(int timeout_ms) {
    pollfd fds[2] = {{lcm_get_fileno(lcm_.get()), POLLIN, 0}, {wake_[0], POLLIN, 0}};
    // Bounded, so that a sender faster than the stages cannot keep next() here.
    for (int taken = 0; taken < 10000; ++taken) {
      const int n = ::poll(fds, 2, taken == 0 ? timeout_ms : 0);
      if (n < 0 && errno == EINTR) return;
      if (n < 0) fail(std::string("waiting for LCM messages failed: ") + std::strerror(errno));
      if (n == 0 || stopped_) return;
      if (fds[0].revents & (POLLERR | POLLHUP | POLLNVAL))
        fail("LCM's receive socket failed (poll revents " + std::to_string(fds[0].revents) + ")");
      if (!(fds[0].revents & POLLIN)) return;  // only the wake-up
      if (lcm_handle(lcm_.get()) != 0) fail("LCM could not receive a message");
      if (callback_error_) {
        // Thrown here, not through LCM's C code (which would be left with its lock held).
        std::exception_ptr e = callback_error_;
        callback_error_ = nullptr;
        std::rethrow_exception(e);
      }
    }
  }

  [[noreturn]] void fail(const std::string& why) {
    ended_ = true;
    note();
    throw InputError(url_, why + "; the stream ends here");
  }

  std::optional<Frame> end() {
    if (assembler_) assembler_->flush();
    ended_ = true;
    note();
    return std::nullopt;
  }

  /// memq:// is one queue per process and URL: a second subscriber would run this one's
  /// callbacks on its own thread. Claimed at open, released at close.
  void claimMemq() {
    const std::lock_guard<std::mutex> lock(memqMutex());
    if (!memqClaims().insert(url_).second)
      throw std::runtime_error("another lcm_subscribe of this process already listens on " +
                               url_ + "; one subscriber per memq:// URL");
    memq_claimed_ = true;
  }
  void releaseMemq() {
    if (!memq_claimed_) return;
    const std::lock_guard<std::mutex> lock(memqMutex());
    memqClaims().erase(url_);
    memq_claimed_ = false;
  }
  static std::mutex& memqMutex() {
    static std::mutex m;
    return m;
  }
  static std::set<std::string>& memqClaims() {
    static std::set<std::string> claimed;
    return claimed;
  }

  static void onMessage(const lcm_recv_buf_t* rbuf, const char* channel, void* self) {
    auto* s = static_cast<LcmSubscribeSource*>(self);
    try {
      const double now = steadyNow();
      if (s->ch_.points == channel) s->last_cloud_s_ = now;
      s->assembler_->add(channel, static_cast<const std::uint8_t*>(rbuf->data), rbuf->data_size,
                         now);
    } catch (...) {
      if (!s->callback_error_) s->callback_error_ = std::current_exception();
    }
  }

  /// What went unused, once, when the stream ends or the source goes.
  void note() {
    if (noted_ || !assembler_) return;
    noted_ = true;
    const ScanAssembler::Counts& c = assembler_->counts();
    if (!c.any()) return;
    std::fprintf(stderr,
                 "lcm_subscribe: %s: %zu scan(s) dropped while the stages fell behind "
                 "(queue_scans), %zu left without labels or poses their channels read (raise "
                 "wait_s), %zu label/pose message(s) after their scan had left, %zu never "
                 "claimed by a cloud, %zu without a frame_id, %zu message(s) of another type, "
                 "%zu sample(s) unused\n",
                 url_.c_str(), c.scans_dropped, c.incomplete, c.late, c.unclaimed, c.unnamed,
                 c.foreign, c.samples_dropped);
  }

  void close() {
    note();
    for (lcm_subscription_t* s : subscriptions_) lcm_unsubscribe(lcm_.get(), s);
    subscriptions_.clear();
    lcm_.reset();
    releaseMemq();
  }

  std::string url_ = "udpm://239.255.76.67:7667?ttl=0";
  ScanChannelParams sp_;
  LogChannels& ch_ = sp_.channels;
  bool origins_seen_ = false;  ///< a scan brought origins of the layers taken
  double wait_s_ = 0.5;
  double idle_timeout_s_ = 0;
  int queue_scans_ = 16;
  bool drop_no_return_ = true;

  LabelSet labels_ = LabelSet::defaults();
  std::shared_ptr<::_lcm_t> lcm_;
  std::vector<lcm_subscription_t*> subscriptions_;
  std::unique_ptr<ScanAssembler> assembler_;
  double last_cloud_s_ = 0;
  int wake_[2] = {-1, -1};
  std::atomic<bool> stopped_{false};
  bool ended_ = false;
  bool noted_ = false;
  bool memq_claimed_ = false;
  std::exception_ptr callback_error_;
};

}  // namespace
}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::LcmSubscribeSource, terramrf::PluginKind::kSource, "lcm_subscribe",
                "a stream of scans received live over LCM: point clouds with their labels, poses "
                "and IMU/GPS/odometry samples")
