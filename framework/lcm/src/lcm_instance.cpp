#include "terramrf/lcm/lcm_instance.hpp"

#include <lcm/lcm.h>

#include <iterator>
#include <map>
#include <mutex>
#include <stdexcept>

namespace terramrf {

std::shared_ptr<::_lcm_t> openLcm(const std::string& url) {
  if (url.empty()) throw std::invalid_argument("openLcm: empty URL");
  if (url.rfind("file://", 0) == 0)
    throw std::invalid_argument("openLcm: '" + url + "' is a log, not a live provider");
  const auto create = [&url] {
    lcm_t* l = lcm_create(url.c_str());
    if (!l) {
      throw std::runtime_error("LCM could not be set up on '" + url +
                               "' (bad URL, or no multicast route for udpm: see "
                               "docs/messages.md)");
    }
    return std::shared_ptr<lcm_t>(l, lcm_destroy);
  };
  if (url.rfind("memq://", 0) != 0) return create();
  static std::mutex mutex;
  static std::map<std::string, std::weak_ptr<lcm_t>> shared;
  const std::lock_guard<std::mutex> lock(mutex);
  for (auto it = shared.begin(); it != shared.end();)  // forget instances no one holds
    it = it->second.expired() ? shared.erase(it) : std::next(it);
  if (std::shared_ptr<lcm_t> alive = shared[url].lock()) return alive;
  std::shared_ptr<lcm_t> made = create();
  shared[url] = made;
  return made;
}

}  // namespace terramrf
