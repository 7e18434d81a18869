#include "terramrf/lcm/log_reader.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>

#include "log_format.hpp"
#include "terramrf/errors.hpp"

namespace terramrf {
namespace {

using lcm_log_format::kHeaderBytes;
using lcm_log_format::kMagic;
using lcm_log_format::kMaxChannel;

std::uint64_t bigEndian(const unsigned char* p, int bytes) {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | p[i];
  return v;
}

}  // namespace

LcmLogReader::LcmLogReader(const std::string& path) : path_(path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    throw InputError(path, std::string("cannot open the LCM log: ") + std::strerror(errno));
  if (S_ISDIR(st.st_mode)) throw InputError(path, "is a folder; expected an LCM log file");
  file_ = std::fopen(path.c_str(), "rb");
  if (!file_)
    throw InputError(path, std::string("cannot open the LCM log: ") + std::strerror(errno));
  size_ = st.st_size;
}

LcmLogReader::~LcmLogReader() {
  if (file_) std::fclose(file_);
}

std::optional<LcmLogEvent> LcmLogReader::eventAt(std::int64_t at) {
  unsigned char h[kHeaderBytes];
  if (at < 0 || at + static_cast<std::int64_t>(kHeaderBytes) > size_ ||
      ::fseeko(file_, at, SEEK_SET) != 0 || std::fread(h, 1, kHeaderBytes, file_) != kHeaderBytes)
    return std::nullopt;
  if (bigEndian(h, 4) != kMagic) return std::nullopt;
  const auto channel_len = static_cast<std::int32_t>(bigEndian(h + 20, 4));
  const auto data_len = static_cast<std::int32_t>(bigEndian(h + 24, 4));
  // Lengths LCM's reader refuses, or an event running past the file's end (a cut write).
  if (channel_len < 1 || channel_len > static_cast<std::int32_t>(kMaxChannel) || data_len < 0 ||
      at + static_cast<std::int64_t>(kHeaderBytes) + channel_len + data_len > size_)
    return std::nullopt;
  LcmLogEvent e;
  e.offset = at;
  e.eventnum = static_cast<std::int64_t>(bigEndian(h + 4, 8));
  e.log_utime = static_cast<std::int64_t>(bigEndian(h + 12, 8));
  e.channel.resize(static_cast<std::size_t>(channel_len));
  e.data.resize(static_cast<std::size_t>(data_len));
  if (std::fread(e.channel.data(), 1, e.channel.size(), file_) != e.channel.size() ||
      std::fread(e.data.data(), 1, e.data.size(), file_) != e.data.size())
    return std::nullopt;
  return e;
}

std::optional<LcmLogEvent> LcmLogReader::next() {
  if (at_end_) return std::nullopt;
  // Where the previous event ended, or else the next sync word that starts a whole event.
  for (std::int64_t at = end_; at + static_cast<std::int64_t>(kHeaderBytes) <= size_; ++at) {
    if (at != end_) {
      // Scan byte by byte for the sync word's first byte; rare (damage only), so kept simple.
      if (::fseeko(file_, at, SEEK_SET) != 0) break;
      int c;
      while ((c = std::fgetc(file_)) != EOF && c != static_cast<int>(kMagic >> 24)) ++at;
      if (c == EOF) break;
    }
    if (std::optional<LcmLogEvent> e = eventAt(at)) {
      skipped_ += at - end_;
      end_ = at + static_cast<std::int64_t>(kHeaderBytes + e->channel.size() + e->data.size());
      return e;
    }
  }
  at_end_ = true;
  skipped_ += size_ - end_;
  return std::nullopt;
}

LcmLogEvent LcmLogReader::readAt(std::int64_t offset) {
  std::optional<LcmLogEvent> e = eventAt(offset);
  if (!e) {
    throw InputError(path_, "no whole LCM event starts at byte " + std::to_string(offset) +
                                " (the log changed since it was indexed?)");
  }
  at_end_ = false;
  end_ = offset + static_cast<std::int64_t>(kHeaderBytes + e->channel.size() + e->data.size());
  return std::move(*e);
}

}  // namespace terramrf
