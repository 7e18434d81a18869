#pragma once
// Loading a pipeline config: parse, validate everything against the plugins' declarations before
// anything runs, and report all problems at once as `file:line:col: stage 'name' (type): what`.
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "terramrf/plugin.hpp"
#include "terramrf/registry.hpp"

namespace terramrf {

struct Diagnostic {
  std::string file;
  int line = 0;    ///< 1-based; 0 = whole file
  int column = 0;  ///< 1-based
  std::string stage;  ///< instance name, "" for top-level keys
  std::string type;   ///< plugin type, "" if none
  std::string message;
  std::string str() const;
};

class ConfigError : public std::runtime_error {
 public:
  explicit ConfigError(std::vector<Diagnostic> d);
  const std::vector<Diagnostic>& diagnostics() const { return diags_; }

 private:
  std::vector<Diagnostic> diags_;
};

struct LoadOptions {
  std::string data_override;  ///< --data: replaces the source's `path` parameter
  std::string output_dir;     ///< --out: where outputs go ("" = config's `output_dir` or ./out)
};

/// A validated, configured pipeline ready to run.
struct Pipeline {
  std::string config_path;
  std::string output_dir;
  GridGeometry grid;
  std::shared_ptr<LabelSet> labels;
  std::unique_ptr<Source> source;
  std::vector<std::unique_ptr<Stage>> stages;  ///< in config order
  std::vector<PluginKind> stage_kinds;
  std::vector<std::unique_ptr<Output>> outputs;
  /// How each layer the stages write is computed (PluginContext::layer_origins).
  std::map<std::string, std::string> layer_origins;
  std::string resolved_yaml;  ///< the config with every default filled in
};

/// True if `path` holds a sweep (`terramrf compare`'s input: datasets, feature_sets, optimisers)
/// rather than a pipeline config; false too if it cannot be read or parsed.
bool isSweepFile(const std::string& path);

/// Parses and validates `config_path`. Plugins are searched in the registry's folders plus the
/// config's `plugin_path` entries. Throws ConfigError with every problem found.
Pipeline loadPipeline(const std::string& config_path, const LoadOptions& options,
                      PluginRegistry& registry);

}  // namespace terramrf
