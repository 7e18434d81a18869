// Test-only stream source (Source::streaming()): a flat ground plane with one box obstacle and
// known truth, frame after frame through next(), then the end of the stream or a wait for a
// message that never comes, which only interrupt() ends. Frames can be told to fail and ids to
// repeat, so the runner's stream paths are testable without LCM.
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <fstream>
#include <mutex>
#include <random>

#include "terramrf/plugin.hpp"
#include "terramrf/stop_request.hpp"

namespace terramrf {

class SyntheticStream final : public StreamSource {
 public:
  void declare(ParamDecl& d) override {
    d.add("frames", frames_, "frames the stream yields").range(0, 1000);
    d.add("ids", ids_, "ids of the first frames, in order (the others: s<position>)");
    d.add("bad_frames", bad_, "positions whose next() throws InputError");
    d.add("after", after_, "after the frames: end the stream, or wait until interrupted")
        .choices({"end", "wait"});
    d.add("waiting_marker", waiting_marker_,
          "file written when the stream starts waiting (a test then knows it waits)");
    d.add("stop_when_waiting", stop_when_waiting_,
          "ask the run to stop (SIGINT, as the handler does) just before waiting");
    d.add("wait_limit_s", wait_limit_s_,
          "the wait ends anyway after this long, as the end of the stream, so that a stream "
          "that is not interrupted fails a test rather than hang it")
        .unit("s")
        .range(0.1, 600);
  }

  std::optional<Frame> next() override {
    std::unique_lock<std::mutex> lock(m_);
    if (interrupted_) return std::nullopt;
    if (position_ < static_cast<std::size_t>(frames_)) return make(position_++);
    if (after_ == "end") return std::nullopt;
    if (!waiting_marker_.empty()) std::ofstream(waiting_marker_) << "waiting\n";
    if (stop_when_waiting_) requestStop(SIGINT);
    cv_.wait_for(lock, std::chrono::duration<double>(wait_limit_s_), [&] { return interrupted_; });
    return std::nullopt;
  }

  void interrupt() override {
    {
      std::lock_guard<std::mutex> lock(m_);
      interrupted_ = true;
    }
    cv_.notify_all();
  }

 private:
  Frame make(std::size_t i) const {
    for (double b : bad_)
      if (static_cast<std::size_t>(b) == i)
        throw InputError("stream message " + std::to_string(i), "truncated: 12 of 40 bytes");
    Frame f;
    if (i < ids_.size()) {
      f.id = ids_[i];
    } else {
      char b[16];
      std::snprintf(b, sizeof b, "s%06zu", i);
      f.id = b;
    }
    f.source_path = "stream/" + f.id;
    std::mt19937 rng(static_cast<unsigned>(i));
    std::normal_distribution<float> noise(0.f, 0.005f);
    for (double x = -10; x < 10; x += 0.1)
      for (double y = -10; y < 10; y += 0.1) {
        if (x > 3 && x < 4 && y > -1 && y < 1) continue;  // the box's footprint
        f.points.push_back(static_cast<float>(x), static_cast<float>(y), -1.7f + noise(rng), 0.5f);
        f.truth.label.push_back(x < 0 ? labels::kRough : labels::kRoad);
        f.truth.raw.push_back(x < 0 ? 2 : 1);
      }
    // Box: 1 m × 2 m × 1.5 m, sampled on its face towards the sensor.
    for (double z = -1.7; z < -0.2; z += 0.1)
      for (double y = -1; y < 1; y += 0.1) {
        f.points.push_back(3.f, static_cast<float>(y), static_cast<float>(z), 0.5f);
        f.truth.label.push_back(labels::kObstacle);
        f.truth.raw.push_back(3);
      }
    return f;
  }

  int frames_ = 3;
  std::vector<std::string> ids_;
  std::vector<double> bad_;
  std::string after_ = "end";
  std::string waiting_marker_;
  bool stop_when_waiting_ = false;
  double wait_limit_s_ = 60;

  std::mutex m_;
  std::condition_variable cv_;
  std::size_t position_ = 0;
  bool interrupted_ = false;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::SyntheticStream, terramrf::PluginKind::kSource, "test_synthetic_stream",
                "test-only stream: synthetic plane + box frames through next()")
