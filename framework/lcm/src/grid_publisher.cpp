#include "terramrf/lcm/grid_publisher.hpp"

#include <lcm/lcm.h>

#include <climits>
#include <cstdlib>
#include <stdexcept>

#include "terramrf/lcm/grid_codec.hpp"
#include "terramrf/lcm/lcm_instance.hpp"
#include "terramrf/lcm/log_writer.hpp"
#include "terramrf/lcm/sensor_codec.hpp"

namespace terramrf {

// Only LCM's C API is used here: the handle is what callers pass in, and it keeps lcm-cpp.hpp out.
struct GridPublisher::Impl {
  lcm_t* lcm = nullptr;
  std::shared_ptr<lcm_t> held;  // the instance openLcm gave (shared for memq://), if not borrowed
  // file:// URLs: the log is written here, not by LCM's file provider, whose failed writes go
  // unreported (see log_writer.hpp). Exactly one of lcm and log is used.
  std::unique_ptr<LcmLogWriter> log;
  std::string url;  // for messages; "(caller's instance)" when borrowed
  std::string channel;
  bool log_message_time = false;  // log events at the message's time, not the wall clock
};

GridPublisher::GridPublisher(const std::string& url, std::string channel)
    : impl_(std::make_unique<Impl>()) {
  // LCM takes an empty URL to mean $LCM_DEFAULT_URL, which may name a log too.
  const char* env = url.empty() ? std::getenv("LCM_DEFAULT_URL") : nullptr;
  const std::string effective = url.empty() ? (env != nullptr ? env : "") : url;
  if (const auto log = parseLcmLogUrl(effective)) {
    impl_->log = std::make_unique<LcmLogWriter>(log->path, log->append);
    impl_->url = effective;
    impl_->channel = std::move(channel);
    return;
  }
  if (effective.empty()) {
    // LCM's own default (udpm).
    lcm_t* l = lcm_create(nullptr);
    if (l == nullptr) {
      throw std::runtime_error("LCM could not be set up on its default URL (udpm; no multicast "
                               "route? see docs/messages.md)");
    }
    impl_->held.reset(l, lcm_destroy);
  } else {
    impl_->held = openLcm(effective);  // memq:// shared with the process's subscribers
  }
  impl_->lcm = impl_->held.get();
  impl_->url = url;
  impl_->channel = std::move(channel);
}

GridPublisher::GridPublisher(::_lcm_t* lcm, std::string channel) : impl_(std::make_unique<Impl>()) {
  if (lcm == nullptr) throw std::invalid_argument("GridPublisher: null LCM handle");
  impl_->lcm = lcm;
  impl_->url = "(caller's LCM instance)";
  impl_->channel = std::move(channel);
}

GridPublisher::~GridPublisher() = default;
GridPublisher::GridPublisher(GridPublisher&&) noexcept = default;
GridPublisher& GridPublisher::operator=(GridPublisher&&) noexcept = default;

const std::string& GridPublisher::channel() const { return impl_->channel; }

bool GridPublisher::writesLog() const { return impl_->log != nullptr; }

void GridPublisher::stampLogWithMessageTime(bool on) { impl_->log_message_time = on; }

void GridPublisher::publishBytes(const std::string& channel, const MessageBytes& bytes,
                                 std::optional<int64_t> log_utime) {
  if (impl_->log) {
    if (log_utime)
      impl_->log->write(channel, bytes.data(), bytes.size(), *log_utime);
    else
      impl_->log->write(channel, bytes.data(), bytes.size());
    return;
  }
  if (impl_->lcm == nullptr) {
    throw std::runtime_error("cannot publish on channel '" + channel + "': the publisher (" +
                             impl_->url + ") is closed");
  }
  if (bytes.size() > static_cast<std::size_t>(UINT_MAX) ||
      lcm_publish(impl_->lcm, channel.c_str(), bytes.data(),
                  static_cast<unsigned int>(bytes.size())) != 0) {
    throw std::runtime_error("LCM could not publish " + std::to_string(bytes.size()) +
                             " bytes on channel '" + channel + "' (" + impl_->url + ")");
  }
}

void GridPublisher::close() {
  if (impl_->log) {
    impl_->log->close();
    return;
  }
  impl_->held.reset();
  impl_->lcm = nullptr;
}

void GridPublisher::publish(const TerrainGrid& grid, const LabelSet& labels,
                            const MessageHeader& header, const std::vector<std::string>& layers) {
  publishBytes(impl_->channel, encodeGrid(grid, labels, header, layers), logTime(header));
}

void GridPublisher::publishPoints(const PointCloud& cloud, const MessageHeader& header) {
  publishForScan(pointsChannel(), encodePointCloud(cloud, header), header);
}

void GridPublisher::publishForScan(const std::string& channel, const MessageBytes& bytes,
                                   const MessageHeader& header) {
  publishBytes(channel, bytes, logTime(header));
}

std::optional<int64_t> GridPublisher::logTime(const MessageHeader& header) const {
  if (!impl_->log_message_time) return std::nullopt;
  return toUtime(header.timestamp_s);
}

}  // namespace terramrf
