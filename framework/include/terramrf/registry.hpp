#pragma once
// Finds plugin libraries, checks their ABI string before trusting them, and creates instances.
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "terramrf/plugin.hpp"

namespace terramrf {

struct PluginInfo {
  std::string type;
  PluginKind kind;
  std::string summary;
  std::string library;  ///< path of the shared library
};

class PluginRegistry {
 public:
  /// Searches `dirs` in order (first hit for a type wins; duplicates are reported).
  explicit PluginRegistry(std::vector<std::string> dirs);

  /// The built-in plugin folder (next to the executable / library: ../lib/terramrf/plugins),
  /// then every folder of $TERRAMRF_PLUGIN_PATH (colon-separated).
  static std::vector<std::string> defaultSearchDirs();

  /// Adds folders (e.g. the config's plugin_path) in front of the current ones and rescans.
  void prependDirs(const std::vector<std::string>& dirs);

  std::vector<PluginInfo> list() const;
  const PluginInfo* find(const std::string& type) const;
  /// Known type names (for "did you mean").
  std::vector<std::string> types() const;
  /// Libraries that looked like plugins but could not be used, with the reason.
  const std::vector<std::string>& problems() const { return problems_; }
  const std::vector<std::string>& dirs() const { return dirs_; }

  /// New instance of `type`; throws PluginLoadError if unknown.
  std::unique_ptr<Plugin> create(const std::string& type) const;

  /// Loads one library file explicitly; throws PluginLoadError naming the file and the reason
  /// (not a shared library, not a TerraMRF plugin, built against another version).
  static PluginInfo inspect(const std::string& library_path);

 private:
  void scan();
  std::vector<std::string> dirs_;
  std::map<std::string, PluginInfo> by_type_;
  std::vector<std::string> problems_;
};

}  // namespace terramrf
