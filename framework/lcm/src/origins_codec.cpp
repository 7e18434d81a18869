#include "terramrf/lcm/origins_codec.hpp"

#include <yaml-cpp/yaml.h>

#include <limits>
#include <stdexcept>
#include <terramrf_msgs/layer_origins_t.hpp>

#include "lcm_bytes.hpp"
#include "terramrf/errors.hpp"

namespace terramrf {
namespace {

/// True if `origin` is a stage's record: a YAML map naming its stage. The pipeline parses the
/// origins of the layers a stage reads into that stage's own record, and a model compares them
/// key by key, so a damaged one is refused with its message rather than met as a YAML error.
bool isOriginRecord(const std::string& origin) {
  try {
    const YAML::Node n = YAML::Load(origin);
    if (!n.IsMap() || !n["stage"] || !n["stage"].IsScalar()) return false;
    // What a model's comparison reads as a number or walks as maps (feature_origins).
    if (n["cell_m"]) n["cell_m"].as<double>();
    for (const char* k : {"params", "inputs"})
      if (n[k] && !n[k].IsMap()) return false;
    if (n["inputs"])
      for (const auto& in : n["inputs"])
        if (!in.second.IsMap()) return false;
    return true;
  } catch (const YAML::Exception&) {
    return false;
  }
}

}  // namespace

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
    if (!isOriginRecord(m.origins[k]))
      throw InputError(source, "layer_origins_t: the origin of layer '" + layer +
                                   "' is not a stage's record (a YAML map with 'stage'): '" +
                                   m.origins[k].substr(0, 120) +
                                   (m.origins[k].size() > 120 ? "…'" : "'"));
    if (!out.origins.emplace(layer, m.origins[k]).second)
      throw InputError(source, "layer_origins_t: layer '" + layer + "' is named twice");
  }
  return out;
}

}  // namespace terramrf
