#pragma once
// Writes LCM log files (the format of lcm-logger and of LCM's file:// provider, read by
// lcm-logplayer, lcm::LogFile and lcm_eventlog_read_next_event) and checks every write.
//
// Why not LCM's own file:// provider: in liblcm 1.3 its publish returns 0 even when the write
// fails, and closing the log ignores what fflush/fclose return, so a full disk cut a log in the
// middle of an event while the run reported every frame ok.
#include <sys/types.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

namespace terramrf {

/// What a `file://` LCM URL asks for when a log is to be written.
struct LcmLogUrl {
  std::string
      path;  ///< as in the URL; a relative path is taken from the working folder, as LCM does
  bool append = false;  ///< mode=a (append) rather than mode=w (replace)
};

/// Reads a `file://PATH?mode=w` (or `?mode=a`) URL the way LCM splits it: the path runs up to the
/// first '?', options are `key=value` joined by '&'. Returns nullopt if `url` is not a file://
/// URL. Throws std::invalid_argument with a message naming the URL if it names no path, asks for
/// no write mode (LCM would open the log for reading), gives a mode other than w or a, or any
/// other option (LCM's speed and start_timestamp only concern reading).
std::optional<LcmLogUrl> parseLcmLogUrl(const std::string& url);

/// An LCM log being written. Each event is written with write(2) straight to the file, so when
/// write() returns the event is in the file whole, and when it throws the writer knows how much
/// of it got there.
///
/// A failed event is never left for readers to misparse (its length fields would make them read
/// the next event as its payload): the file is cut back to the end of the last complete event, and
/// later events are tried again (a full disk may get space back). Only if that cut is impossible
/// (a file that cannot be truncated, such as a device or a pipe, with part of the event in it) does
/// the writer stop: every later write() and close() throws, saying the log ends in a cut event.
///
/// Not copyable. Thread-safe: writes from several threads are serialised, as in LCM's provider.
class LcmLogWriter {
 public:
  /// Opens (creates) `path`: replaced if `append` is false, appended to otherwise. Throws
  /// std::runtime_error naming the file and the OS error if it cannot be opened.
  LcmLogWriter(const std::string& path, bool append);
  /// Closes the file if close() was not called; errors are not reported here (call close()).
  virtual ~LcmLogWriter();
  LcmLogWriter(const LcmLogWriter&) = delete;
  LcmLogWriter& operator=(const LcmLogWriter&) = delete;

  /// Writes one event on `channel`, stamped with the wall-clock time now in µs since the Unix
  /// epoch (what LCM's file provider records). Event numbers count from 0 for each writer (LCM
  /// does the same, also when appending). Throws std::runtime_error naming the file, the event
  /// and the OS error if it cannot be written whole (see the class comment for the file's state
  /// then), or std::invalid_argument for a channel or size no LCM log reader accepts.
  void write(const std::string& channel, const std::uint8_t* data, std::size_t size);
  /// As above with an explicit timestamp [µs].
  void write(const std::string& channel, const std::uint8_t* data, std::size_t size,
             std::int64_t utime);

  /// Flushes the file to its disk (fsync) and closes it. Throws std::runtime_error naming the
  /// file if either fails, or if the log ends in a cut event that could not be removed. Calling it
  /// again does nothing.
  void close();

  const std::string& path() const;
  /// Events written whole by this writer.
  std::int64_t eventsWritten() const;
  /// Bytes of the file that hold whole events (for an appended log, those before it too).
  std::int64_t bytesComplete() const;

 protected:
  /// The system calls a write and its repair go through; a test overrides them to fail at will.
  virtual ssize_t writeSome(int fd, const void* buf, std::size_t n);
  virtual int truncateTo(int fd, off_t length);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace terramrf
