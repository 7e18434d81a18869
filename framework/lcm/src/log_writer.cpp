#include "terramrf/lcm/log_writer.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <vector>

#include "log_format.hpp"

namespace terramrf {
namespace {

using lcm_log_format::kHeaderBytes;
using lcm_log_format::kMagic;
using lcm_log_format::kMaxChannel;
using lcm_log_format::kMaxData;

void putBigEndian(std::vector<std::uint8_t>& out, std::uint64_t v, int bytes) {
  for (int i = bytes - 1; i >= 0; --i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

std::string osError(int err) { return std::strerror(err); }

std::int64_t nowMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace

std::optional<LcmLogUrl> parseLcmLogUrl(const std::string& url) {
  static const std::string kScheme = "file://";
  if (url.compare(0, kScheme.size(), kScheme) != 0) return std::nullopt;
  const std::string rest = url.substr(kScheme.size());
  const auto q = rest.find('?');
  LcmLogUrl out;
  out.path = rest.substr(0, q);
  if (out.path.empty()) {
    throw std::invalid_argument("'" + url + "' names no log file; expected e.g. " +
                                "file:///tmp/run.lcmlog?mode=w");
  }
  std::optional<std::string> mode;
  if (q != std::string::npos) {
    const std::string opts = rest.substr(q + 1);
    std::size_t start = 0;
    while (start <= opts.size()) {
      const auto amp = opts.find('&', start);
      const std::string opt =
          opts.substr(start, amp == std::string::npos ? std::string::npos : amp - start);
      start = amp == std::string::npos ? opts.size() + 1 : amp + 1;
      if (opt.empty()) continue;
      const auto eq = opt.find('=');
      const std::string key = opt.substr(0, eq);
      const std::string value = eq == std::string::npos ? "" : opt.substr(eq + 1);
      if (key != "mode") {
        throw std::invalid_argument("'" + url + "': option '" + key +
                                    "' has no meaning for a log being written; the only "
                                    "option is mode=w (or mode=a to append)");
      }
      if (value != "w" && value != "a") {
        throw std::invalid_argument("'" + url + "': mode '" + value +
                                    "' is not a write mode; expected mode=w (replace the log) "
                                    "or mode=a (append to it)");
      }
      if (mode && *mode != value) {
        throw std::invalid_argument("'" + url + "' gives both mode=" + *mode +
                                    " and mode=" + value + "; give one");
      }
      mode = value;
    }
  }
  // Wording kept from the plugin's earlier check, which users may have seen documented.
  if (!mode) {
    throw std::invalid_argument("'" + url +
                                "' opens the log for reading; to write one give ?mode=w (or "
                                "?mode=a to append), e.g. file:///tmp/run.lcmlog?mode=w");
  }
  out.append = *mode == "a";
  return out;
}

struct LcmLogWriter::Impl {
  std::string path;
  int fd = -1;
  bool regular = false;       // only a regular file can be cut back after a failed event
  std::int64_t complete = 0;  // file offset after the last whole event
  std::int64_t events = 0;
  std::string cut;  // why the log ends in a cut event, once it does ("" while it does not)
  std::mutex mutex;
};

LcmLogWriter::LcmLogWriter(const std::string& path, bool append) : impl_(std::make_unique<Impl>()) {
  impl_->path = path;
  // Its folder is made as every output's is (writeFileAtomic): `out/x.lcm` on a fresh clone.
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty() && !std::filesystem::is_directory(parent, ec)) {
    std::filesystem::create_directories(parent, ec);
    if (ec)
      throw std::runtime_error("cannot create folder '" + parent.string() + "' for LCM log '" +
                               path + "': " + ec.message());
  }
  const int flags = O_WRONLY | O_CREAT | O_CLOEXEC | (append ? O_APPEND : O_TRUNC);
  do {
    impl_->fd = ::open(path.c_str(), flags, 0666);
  } while (impl_->fd < 0 && errno == EINTR);
  if (impl_->fd < 0) {
    throw std::runtime_error("cannot open LCM log '" + path + "' for writing: " + osError(errno));
  }
  struct stat st {};
  if (::fstat(impl_->fd, &st) == 0 && S_ISREG(st.st_mode)) {
    impl_->regular = true;
    // Appending: the events already there are whole as far as this writer is concerned.
    impl_->complete = append ? static_cast<std::int64_t>(st.st_size) : 0;
  }
}

LcmLogWriter::~LcmLogWriter() {
  if (impl_ && impl_->fd >= 0) ::close(impl_->fd);
}

const std::string& LcmLogWriter::path() const { return impl_->path; }
std::int64_t LcmLogWriter::eventsWritten() const { return impl_->events; }
std::int64_t LcmLogWriter::bytesComplete() const { return impl_->complete; }

ssize_t LcmLogWriter::writeSome(int fd, const void* buf, std::size_t n) {
  return ::write(fd, buf, n);
}

int LcmLogWriter::truncateTo(int fd, off_t length) { return ::ftruncate(fd, length); }

void LcmLogWriter::write(const std::string& channel, const std::uint8_t* data, std::size_t size) {
  write(channel, data, size, nowMicros());
}

void LcmLogWriter::write(const std::string& channel, const std::uint8_t* data, std::size_t size,
                         std::int64_t utime) {
  if (channel.empty() || channel.size() > kMaxChannel || channel.find('\0') != std::string::npos) {
    throw std::invalid_argument("LCM log '" + impl_->path + "': channel '" + channel +
                                "' cannot be logged; LCM log readers take 1 to 999 bytes "
                                "without NUL");
  }
  if (size > kMaxData) {
    throw std::invalid_argument("LCM log '" + impl_->path + "': a message of " +
                                std::to_string(size) + " bytes on channel '" + channel +
                                "' cannot be logged; at most 2147483647 bytes fit an event");
  }
  std::lock_guard<std::mutex> lock(impl_->mutex);
  const std::string event_name = "event " + std::to_string(impl_->events) + " (channel '" +
                                 channel + "', " + std::to_string(size) + " bytes of message)";
  if (impl_->fd < 0) {
    throw std::runtime_error("LCM log '" + impl_->path + "': cannot write " + event_name +
                             ": the log is already closed");
  }
  if (!impl_->cut.empty()) {
    throw std::runtime_error("LCM log '" + impl_->path + "': " + event_name +
                             " not written: " + impl_->cut);
  }

  std::vector<std::uint8_t> head;
  head.reserve(kHeaderBytes + channel.size());
  putBigEndian(head, kMagic, 4);
  putBigEndian(head, static_cast<std::uint64_t>(impl_->events), 8);
  putBigEndian(head, static_cast<std::uint64_t>(utime), 8);
  putBigEndian(head, channel.size(), 4);
  putBigEndian(head, size, 4);
  head.insert(head.end(), channel.begin(), channel.end());

  // Header and channel, then the message straight from the caller's buffer (it can be MBs).
  const struct {
    const std::uint8_t* p;
    std::size_t n;
  } parts[2] = {{head.data(), head.size()}, {data, size}};
  std::size_t written = 0;  // bytes of this event now in the file
  int err = 0;
  for (const auto& part : parts) {
    std::size_t done = 0;
    while (done < part.n && err == 0) {
      const ssize_t r = writeSome(impl_->fd, part.p + done, part.n - done);
      if (r > 0) {
        done += static_cast<std::size_t>(r);
        written += static_cast<std::size_t>(r);
      } else if (r < 0 && errno == EINTR) {
        continue;
      } else {
        err = r < 0 ? errno : EIO;  // write(2) returning 0 for a non-empty buffer: no progress
      }
    }
    if (err != 0) break;
  }
  if (err == 0) {
    impl_->complete += static_cast<std::int64_t>(written);
    ++impl_->events;
    return;
  }

  const std::string failed =
      "LCM log '" + impl_->path + "': cannot write " + event_name + ": " + osError(err);
  const std::string kept = std::to_string(impl_->events) + " whole event(s), " +
                           std::to_string(impl_->complete) + " bytes";
  if (written == 0) {
    throw std::runtime_error(failed + "; nothing of it reached the file, which keeps its " + kept);
  }
  // Part of the event is in the file: readers would take the next event for the rest of it, so
  // cut the file back to the last whole event (and write on from there: O_APPEND does by itself).
  std::string repair_error;
  if (!impl_->regular) {
    repair_error = "it is not a regular file, so it cannot be cut back";
  } else if (truncateTo(impl_->fd, static_cast<off_t>(impl_->complete)) != 0) {
    repair_error = "cutting it back failed: " + osError(errno);
  } else if (::lseek(impl_->fd, static_cast<off_t>(impl_->complete), SEEK_SET) < 0) {
    repair_error = "cutting it back failed: " + osError(errno);
  }
  if (repair_error.empty()) {
    throw std::runtime_error(failed + "; the " + std::to_string(written) +
                             " bytes written of it were removed, the file keeps its " + kept);
  }
  impl_->cut = "the log ends in event " + std::to_string(impl_->events) + ", cut after " +
               std::to_string(written) + " of its bytes (" + osError(err) + "), and " +
               repair_error + "; nothing more is written to it (its first " + kept + " are whole)";
  throw std::runtime_error(failed + "; " + std::to_string(written) + " bytes of it are in the " +
                           "file and " + repair_error + ", so nothing more is written to this " +
                           "log (its first " + kept + " are whole)");
}

void LcmLogWriter::close() {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  if (impl_->fd < 0) return;
  const int fd = impl_->fd;
  impl_->fd = -1;
  // Writes went straight to the file; fsync catches what the file system reports only on the way
  // to its disk (NFS, delayed allocation). EINVAL: a device or pipe, which keeps nothing to sync.
  std::string why;
  if (::fsync(fd) != 0 && errno != EINVAL) why = "fsync failed: " + osError(errno);
  if (::close(fd) != 0 && errno != EINTR && why.empty()) why = "close failed: " + osError(errno);
  if (!why.empty()) {
    throw std::runtime_error("LCM log '" + impl_->path + "': " + why + "; the log may lack " +
                             "some of its last events");
  }
  if (!impl_->cut.empty()) throw std::runtime_error("LCM log '" + impl_->path + "': " + impl_->cut);
}

}  // namespace terramrf
