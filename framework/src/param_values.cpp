#include "terramrf/param_values.hpp"

#include <stdexcept>

#include "param_yaml.hpp"

namespace terramrf {

void setParams(Plugin& plugin, const std::string& yaml_map, const PluginContext& ctx) {
  YAML::Node n;
  try {
    n = YAML::Load(yaml_map);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("parameters '" + yaml_map + "': " + e.what());
  }
  const auto issues = detail::applyParams(plugin, n, ctx, YAML::Mark());
  if (issues.empty()) return;
  std::string msg = plugin.type() + ":";
  for (const auto& i : issues) msg += "\n  " + i.message;
  throw std::runtime_error(msg);
}

std::vector<ParamSpec> declaredParams(Plugin& plugin) {
  ParamDecl d;
  plugin.declare(d);
  return d.specs();
}

}  // namespace terramrf
