#pragma once
// Layer origins (how each grid layer was computed, PluginContext::layer_origins) ⇄
// terramrf_msgs::layer_origins_t, as encoded bytes. LCM-free header, like the other codecs.
#include <cstddef>
#include <map>
#include <string>

#include "terramrf/lcm/message_header.hpp"

namespace terramrf {

/// Encodes `origins` (layer -> origin record). Throws std::invalid_argument for an empty layer
/// name or origin, or more layers than the message can count.
MessageBytes encodeLayerOrigins(const std::map<std::string, std::string>& origins,
                                const MessageHeader& header);

struct DecodedLayerOrigins {
  MessageHeader header;
  std::map<std::string, std::string> origins;  ///< layer -> origin record
};

/// Decodes a layer_origins_t. Throws InputError (file = `source`) if the bytes are not one, a
/// layer is named twice, a name or origin is empty, or an origin is no stage's record (a YAML
/// map with a `stage`, a numeric `cell_m` and `params`/`inputs` maps where given).
DecodedLayerOrigins decodeLayerOrigins(const void* data, std::size_t size,
                                       const std::string& source = "layer_origins_t");
inline DecodedLayerOrigins decodeLayerOrigins(const MessageBytes& bytes,
                                              const std::string& source = "layer_origins_t") {
  return decodeLayerOrigins(bytes.data(), bytes.size(), source);
}

}  // namespace terramrf
