#include "terramrf/lcm/origins_codec.hpp"

#include <limits>
#include <stdexcept>
#include <terramrf_msgs/layer_origins_t.hpp>

#include "lcm_bytes.hpp"
#include "terramrf/errors.hpp"

namespace terramrf {

MessageBytes encodeLayerOrigins(const std::map<std::string, std::string>& origins,
                                const MessageHeader& header) {
  if (origins.size() > static_cast<std::size_t>(std::numeric_limits<int16_t>::max()))
    throw std::invalid_argument("encodeLayerOrigins: " + std::to_string(origins.size()) +
                                " layers; a layer_origins_t counts at most 32767");
  terramrf_msgs::layer_origins_t m;
  m.utime = toUtime(header.timestamp_s);
  m.frame_id = header.frame_id;
  for (const auto& [layer, origin] : origins) {
    // An empty string would be read back as a layer without a name or an origin.
    if (layer.empty() || origin.empty())
      throw std::invalid_argument("encodeLayerOrigins: layer '" + layer +
                                  "': empty name or origin");
    m.layer_names.push_back(layer);
    m.origins.push_back(origin);
  }
  m.num_layers = static_cast<int16_t>(m.layer_names.size());
  return lcm_detail::encodeMessage(m, "layer_origins_t");
}

DecodedLayerOrigins decodeLayerOrigins(const void* data, std::size_t size,
                                       const std::string& source) {
  auto m = lcm_detail::decodeMessage<terramrf_msgs::layer_origins_t>(data, size, source,
                                                                     "layer_origins_t");
  DecodedLayerOrigins out;
  out.header.frame_id = std::move(m.frame_id);
  out.header.timestamp_s = fromUtime(m.utime);
  for (std::size_t k = 0; k < m.layer_names.size(); ++k) {
    const std::string& layer = m.layer_names[k];
    if (layer.empty() || m.origins[k].empty())
      throw InputError(source, "layer_origins_t: layer " + std::to_string(k) + " ('" + layer +
                                   "') has an empty name or origin");
    if (!out.origins.emplace(layer, m.origins[k]).second)
      throw InputError(source, "layer_origins_t: layer '" + layer + "' is named twice");
  }
  return out;
}

}  // namespace terramrf
