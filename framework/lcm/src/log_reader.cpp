#include "terramrf/lcm/log_reader.hpp"

#include <sys/stat.h>

#include <algorithm>
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

std::optional<LcmLogReader::Header> LcmLogReader::headerAt(std::int64_t at) {
  unsigned char h[kHeaderBytes];
  if (at < 0 || at + static_cast<std::int64_t>(kHeaderBytes) > size_ ||
      ::fseeko(file_, at, SEEK_SET) != 0 || std::fread(h, 1, kHeaderBytes, file_) != kHeaderBytes)
    return std::nullopt;
  if (bigEndian(h, 4) != kMagic) return std::nullopt;
  Header r;
  r.eventnum = static_cast<std::int64_t>(bigEndian(h + 4, 8));
  r.utime = static_cast<std::int64_t>(bigEndian(h + 12, 8));
  r.channel_len = static_cast<std::int32_t>(bigEndian(h + 20, 4));
  r.data_len = static_cast<std::int32_t>(bigEndian(h + 24, 4));
  // Lengths LCM's reader refuses, or an event running past the file's end (a cut write).
  if (r.channel_len < 1 || r.channel_len > static_cast<std::int32_t>(kMaxChannel) ||
      r.data_len < 0 ||
      at + static_cast<std::int64_t>(kHeaderBytes) + r.channel_len + r.data_len > size_)
    return std::nullopt;
  return r;
}

std::optional<LcmLogEvent> LcmLogReader::eventAt(std::int64_t at, std::size_t max_data_bytes) {
  const std::optional<Header> h = headerAt(at);
  if (!h) return std::nullopt;
  const std::int32_t channel_len = h->channel_len, data_len = h->data_len;
  LcmLogEvent e;
  e.offset = at;
  e.eventnum = h->eventnum;
  e.log_utime = h->utime;
  if (::fseeko(file_, at + static_cast<std::int64_t>(kHeaderBytes), SEEK_SET) != 0)
    return std::nullopt;
  e.channel.resize(static_cast<std::size_t>(channel_len));
  e.data_size = data_len;
  e.data.resize(std::min(static_cast<std::size_t>(data_len), max_data_bytes));
  if (std::fread(e.channel.data(), 1, e.channel.size(), file_) != e.channel.size() ||
      std::fread(e.data.data(), 1, e.data.size(), file_) != e.data.size())
    return std::nullopt;
  return e;
}

bool LcmLogReader::followedBySyncOrEnd(std::int64_t end) {
  unsigned char b[4];
  if (end == size_) return true;
  return end + 4 <= size_ && ::fseeko(file_, end, SEEK_SET) == 0 &&
         std::fread(b, 1, 4, file_) == 4 && bigEndian(b, 4) == kMagic;
}

bool LcmLogReader::wholeEventWithin(std::int64_t from, std::int64_t to) {
  for (std::int64_t at = from; at < to && at + static_cast<std::int64_t>(kHeaderBytes) <= size_;
       ++at) {
    if (::fseeko(file_, at, SEEK_SET) != 0) return false;
    int c;
    while (at < to && (c = std::fgetc(file_)) != EOF && c != static_cast<int>(kMagic >> 24)) ++at;
    if (at >= to || c == EOF) return false;
    if (headerAt(at)) return true;
  }
  return false;
}

std::optional<LcmLogEvent> LcmLogReader::next(std::size_t max_data_bytes) {
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
    if (std::optional<LcmLogEvent> e = eventAt(at, max_data_bytes)) {
      const std::int64_t end =
          at + static_cast<std::int64_t>(kHeaderBytes + e->channel.size()) + e->data_size;
      // An event whose lengths fit the file but run into later events is a cut one (a writer
      // killed mid-event, then the log appended to): its "data" would swallow them. It is told
      // by a whole event starting inside its span when no sync word follows it.
      if (!followedBySyncOrEnd(end) && wholeEventWithin(at + 1, end)) continue;
      skipped_ += at - end_;
      end_ = end;
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
  end_ = offset + static_cast<std::int64_t>(kHeaderBytes + e->channel.size()) + e->data_size;
  return std::move(*e);
}

}  // namespace terramrf
