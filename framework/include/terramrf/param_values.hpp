#pragma once
// Setting parameters from text, for tests and programmatic use (configs go through config.hpp,
// which adds file positions to the same checks).
#include <string>
#include <vector>

#include "terramrf/plugin.hpp"

namespace terramrf {

/// Parses `yaml_map` (e.g. "{window: 5, path: /data}") against the plugin's declaration, sets the
/// members, and calls configure(ctx). Throws std::runtime_error listing every problem.
void setParams(Plugin& plugin, const std::string& yaml_map, const PluginContext& ctx);

/// All parameter specs of a plugin (declare() on the instance).
std::vector<ParamSpec> declaredParams(Plugin& plugin);

}  // namespace terramrf
