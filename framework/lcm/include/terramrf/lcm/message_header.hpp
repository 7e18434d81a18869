#pragma once
// What every terramrf_msgs message carries besides its payload, in TerraMRF units.
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace terramrf {

/// An encoded LCM message (fingerprint + payload), ready for lcm_publish or a log file.
using MessageBytes = std::vector<uint8_t>;

struct MessageHeader {
  /// Scan id (Frame::id, e.g. "000042"): ties grids, clouds and images of one scan together.
  std::string frame_id;
  /// Frame the coordinates are in ("lidar": x forward, y left, z up; "world" for mapped data).
  std::string coordinate_frame = "lidar";
  /// [s]. On the wire it is `utime` in whole microseconds, so it round-trips to 1 µs.
  double timestamp_s = 0;
};

/// Seconds → LCM's microsecond `utime` (rounded to nearest).
inline int64_t toUtime(double t_s) { return static_cast<int64_t>(std::llround(t_s * 1e6)); }
/// LCM's microsecond `utime` → seconds.
inline double fromUtime(int64_t utime) { return static_cast<double>(utime) * 1e-6; }

}  // namespace terramrf
