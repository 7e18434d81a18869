#pragma once
// LCM's log format (lcm/eventlog.c), shared by LcmLogWriter and LcmLogReader: per event,
// big-endian int32 sync word 0xEDA1DA01, int64 event number, int64 timestamp [µs], int32
// channel length, int32 data length, then the channel (no NUL) and the data. Private to
// terramrf_lcm.
#include <cstddef>
#include <cstdint>

namespace terramrf::lcm_log_format {

constexpr std::uint32_t kMagic = 0xEDA1DA01u;
constexpr std::size_t kHeaderBytes = 4 + 8 + 8 + 4 + 4;
// lcm_eventlog_read_next_event refuses channel lengths outside 1..999 and negative data lengths.
constexpr std::size_t kMaxChannel = 999;
constexpr std::size_t kMaxData = 0x7fffffff;

}  // namespace terramrf::lcm_log_format
