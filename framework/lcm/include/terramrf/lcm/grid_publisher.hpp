#pragma once
// Publishes grids (and the scan's points) on an LCM channel. The LCM handle is opaque so this
// header can be included next to CGAL.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "terramrf/label_set.hpp"
#include "terramrf/lcm/message_header.hpp"
#include "terramrf/point_cloud.hpp"
#include "terramrf/terrain_grid.hpp"

/// LCM's C handle (`lcm_t` in lcm/lcm.h), declared here so callers need not include LCM.
struct _lcm_t;

namespace terramrf {

class GridPublisher {
 public:
  /// Opens an LCM instance on `url` (e.g. "udpm://239.255.76.67:7667?ttl=0", "memq://",
  /// "" = $LCM_DEFAULT_URL, else LCM's default) through openLcm: its own, except that memq://
  /// URLs share the process's instance so that its subscribers receive what it publishes. Throws std::runtime_error naming the URL if LCM
  /// cannot be set up (bad URL, no multicast route, ...).
  ///
  /// A `file://PATH?mode=w` (or `mode=a`) URL, given or in $LCM_DEFAULT_URL, is written by
  /// LcmLogWriter instead of LCM's file provider (same log format, channels and timestamps), so
  /// that a failed write is reported: see log_writer.hpp. Throws std::invalid_argument for a
  /// file:// URL that cannot be written (parseLcmLogUrl), std::runtime_error naming the file if
  /// it cannot be opened.
  GridPublisher(const std::string& url, std::string channel);
  /// Publishes through an LCM instance the caller owns (lcm::LCM::getUnderlyingLCM() or
  /// lcm_create()); it must outlive the publisher. Throws std::invalid_argument if null.
  GridPublisher(::_lcm_t* lcm, std::string channel);
  ~GridPublisher();
  GridPublisher(GridPublisher&&) noexcept;
  GridPublisher& operator=(GridPublisher&&) noexcept;
  GridPublisher(const GridPublisher&) = delete;
  GridPublisher& operator=(const GridPublisher&) = delete;

  /// Channel of the grid messages (terrain_grid_t).
  const std::string& channel() const;
  /// Channel of the point clouds: `<channel>_POINTS` (point_cloud_t).
  std::string pointsChannel() const { return channel() + "_POINTS"; }

  /// Encodes (see encodeGrid) and publishes on channel(). Throws std::runtime_error naming the
  /// channel if LCM refuses the message, or naming the log file, the event and the OS error if a
  /// log cannot write it.
  void publish(const TerrainGrid& grid, const LabelSet& labels, const MessageHeader& header,
               const std::vector<std::string>& layers = {});
  /// Encodes (see encodePointCloud) and publishes on pointsChannel().
  void publishPoints(const PointCloud& cloud, const MessageHeader& header);
  /// Publishes an encoded message of the scan `header` names on `channel`, stamped in a log as
  /// publish() stamps its grids (stampLogWithMessageTime).
  void publishForScan(const std::string& channel, const MessageBytes& bytes,
                      const MessageHeader& header);
  /// Publishes an already encoded message on any channel. `log_utime` [µs]: the event's time in
  /// a log; none = the wall clock now (what LCM's logger records). Live providers ignore it.
  void publishBytes(const std::string& channel, const MessageBytes& bytes,
                    std::optional<int64_t> log_utime = std::nullopt);

  /// True if this publisher writes a log (a file:// URL) rather than publishing live.
  bool writesLog() const;
  /// For a log: stamp the events of publish()/publishPoints() with their message's
  /// MessageHeader::timestamp_s instead of the wall clock, so that lcm-logplayer (or any reader
  /// pacing by event time) replays a dataset at its recorded rate rather than at the speed it was
  /// processed. No effect on live providers: their receivers stamp the arrival.
  void stampLogWithMessageTime(bool on);

  /// Closes the LCM instance it opened, or the log (see LcmLogWriter::close: throws naming the
  /// file if its last bytes cannot be saved or it ends in a cut event). The destructor closes
  /// too but cannot report; call this where a failure must be seen. Later publishes throw.
  void close();

 private:
  std::optional<int64_t> logTime(const MessageHeader& header) const;

  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace terramrf
