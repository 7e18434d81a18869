#include "terramrf/plugin.hpp"

#include <filesystem>
#include <stdexcept>

namespace terramrf {

const char* toString(PluginKind k) {
  switch (k) {
    case PluginKind::kSource: return "source";
    case PluginKind::kEgomotion: return "egomotion";
    case PluginKind::kFeature: return "feature";
    case PluginKind::kEnergy: return "energy";
    case PluginKind::kOptimiser: return "optimiser";
    case PluginKind::kOutput: return "output";
  }
  return "?";
}

std::optional<Frame> Source::next() {
  throw std::logic_error("source '" + type() +
                         "' is a batch (streaming() is false): its frames are read by index, "
                         "never through next()");
}

std::string StreamSource::frameId(std::size_t) const {
  throw std::logic_error("source '" + type() +
                         "' is a stream: its frames have no index, and each carries its own id");
}

Frame StreamSource::read(std::size_t) {
  throw std::logic_error("source '" + type() +
                         "' is a stream: its frames come through next(), not by index");
}

std::string PluginContext::resolve(const std::string& path) const {
  if (path.empty()) return path;
  std::filesystem::path p(path);
  if (p.is_absolute() || config_dir.empty()) return p.lexically_normal().string();
  return (std::filesystem::path(config_dir) / p).lexically_normal().string();
}

}  // namespace terramrf
