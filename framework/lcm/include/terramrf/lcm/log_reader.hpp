#pragma once
// Reads LCM log files (lcm-logger's, LCM's file:// provider's, LcmLogWriter's) with each event's
// place in the file, so that a log can be indexed once and an event read again later by its
// offset. LCM-free header.
//
// Why not LCM's own reader (lcm_eventlog_read_next_event, lcm::LogFile): in liblcm 1.3, when the
// bytes after an event are not the next event's sync word (a damaged stretch, a second writer's
// bytes), it drops that whole event and returns NULL as at the end of the log, so everything
// from there on is lost, with only "Invalid header after log data" on stderr. This reader keeps
// every whole event and goes on at the next sync word, counting what it passed over.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

namespace terramrf {

struct LcmLogEvent {
  std::int64_t offset = 0;     ///< byte position of the event's sync word in the file
  std::int64_t eventnum = 0;   ///< as its writer numbered it
  std::int64_t log_utime = 0;  ///< the event's time in the log [µs]
  std::string channel;
  std::vector<std::uint8_t> data;  ///< the encoded message, or its first bytes (next()'s limit)
  /// The encoded message's length in the log [bytes]; more than data.size() when next() was told
  /// to read only a prefix of it.
  std::int64_t data_size = 0;
};

/// Not thread-safe; open one reader per thread (opening costs one fopen).
class LcmLogReader {
 public:
  /// Throws InputError naming the file if it cannot be opened for reading.
  explicit LcmLogReader(const std::string& path);
  ~LcmLogReader();
  LcmLogReader(const LcmLogReader&) = delete;
  LcmLogReader& operator=(const LcmLogReader&) = delete;

  const std::string& path() const { return path_; }

  /// The next whole event in file order; nullopt once no whole event is left. Of its message
  /// only the first `max_data_bytes` are read (LcmLogEvent::data_size gives its length): an index
  /// that needs a message's time and scan id (peekMessageStamp) then reads a few KiB per event
  /// instead of the whole log. The event is still checked whole (its lengths fit the file and a
  /// sync word or the end of the file follows it).
  std::optional<LcmLogEvent> next(std::size_t max_data_bytes = SIZE_MAX);
  /// The event whose sync word is at `offset` (an earlier LcmLogEvent::offset). Throws
  /// InputError naming the file and the offset if no whole event starts there (the file changed
  /// since it was indexed). next() then goes on after that event.
  LcmLogEvent readAt(std::int64_t offset);

  /// Bytes next() passed over so far that belong to no whole event: damage between events (the
  /// reader goes on at the next sync word that starts a whole event) and, once next() returned
  /// nullopt, a cut event at the end of the file (a writer killed mid-event).
  std::int64_t skippedBytes() const { return skipped_; }
  /// Offset just past the last whole event next() returned.
  std::int64_t endOfLastEvent() const { return end_; }

 private:
  struct Header {
    std::int64_t eventnum = 0, utime = 0;
    std::int32_t channel_len = 0, data_len = 0;
  };
  /// The header of an event starting at `at` whose lengths are valid and fit in the file.
  std::optional<Header> headerAt(std::int64_t at);
  /// The whole event starting at `at`, if one does, with at most `max_data_bytes` of its message.
  std::optional<LcmLogEvent> eventAt(std::int64_t at, std::size_t max_data_bytes = SIZE_MAX);
  bool followedBySyncOrEnd(std::int64_t end);
  /// True if an event header (headerAt) starts in [from, to).
  bool wholeEventWithin(std::int64_t from, std::int64_t to);

  std::string path_;
  std::FILE* file_ = nullptr;
  std::int64_t size_ = 0;
  std::int64_t end_ = 0;
  std::int64_t skipped_ = 0;
  bool at_end_ = false;
};

}  // namespace terramrf
