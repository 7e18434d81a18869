#pragma once
// Internal: converting YAML parameter maps into declared parameters, collecting every problem.
#include <yaml-cpp/yaml.h>

#include <string>
#include <vector>

#include "terramrf/plugin.hpp"

namespace terramrf::detail {

struct ParamIssue {
  std::string param;  ///< "" = the stage as a whole
  YAML::Mark mark;
  std::string message;
};

/// What a node is, for messages: 'text' for a scalar, "a list", "a map", or "nothing".
std::string describeNode(const YAML::Node& n);

/// Nearest candidate by edit distance, or "" if none is close.
std::string didYouMean(const std::string& word, const std::vector<std::string>& candidates);

/// Sets the plugin's declared parameters from `params` (a map or null), then calls configure().
/// Returns every problem found (unknown key with "did you mean", wrong type, out of range, not one
/// of the choices, missing required, path that does not exist, ParamError from configure).
/// `overrides` are applied after the file's values (e.g. --data for a source's path).
std::vector<ParamIssue> applyParams(Plugin& plugin, const YAML::Node& params,
                                    const PluginContext& ctx, const YAML::Mark& stage_mark,
                                    const std::vector<std::pair<std::string, std::string>>& overrides = {});

/// Why `value` cannot be the value of `spec` (wrong type, out of range, not one of the choices),
/// or "" if it can. Nothing is set.
std::string checkParamValue(const ParamSpec& spec, const YAML::Node& value);
/// The value as the plugin would take it (`seed: 07` and `seed: 7` are the same 7), or "" if
/// it does not convert.
std::string canonicalParamValue(const ParamSpec& spec, const YAML::Node& value);

/// The plugin's current parameter values as a YAML map (flow style lines "key: value").
YAML::Node currentParams(Plugin& plugin);

}  // namespace terramrf::detail
