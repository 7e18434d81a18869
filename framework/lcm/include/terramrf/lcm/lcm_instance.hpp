#pragma once
// LCM instances by URL. memq:// is a queue private to one LCM instance, so a publisher and a
// subscriber of one process (an lcm_publish output and an lcm_subscribe source, or a test) meet
// only if they share it: memq URLs give one instance per URL in the process, alive while anyone
// holds it. Other providers (udpm, tcpq) give an instance of its own to each caller, as
// lcm_create does. liblcm 1.3 drops a memq message that no one has subscribed to yet: a
// subscriber receives only what is published after it subscribed. LCM-free header.
#include <memory>
#include <string>

/// LCM's C handle (`lcm_t` in lcm/lcm.h).
struct _lcm_t;

namespace terramrf {

/// Throws std::runtime_error naming the URL if LCM cannot set it up (a bad URL, no multicast
/// route for udpm), std::invalid_argument for an empty URL (say which) or a file:// one (logs are
/// written by LcmLogWriter and read by LcmLogReader, not through an instance).
std::shared_ptr<::_lcm_t> openLcm(const std::string& url);

}  // namespace terramrf
