#include "terramrf/plugin.hpp"

#include <filesystem>

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

std::string PluginContext::resolve(const std::string& path) const {
  if (path.empty()) return path;
  std::filesystem::path p(path);
  if (p.is_absolute() || config_dir.empty()) return p.lexically_normal().string();
  return (std::filesystem::path(config_dir) / p).lexically_normal().string();
}

}  // namespace terramrf
