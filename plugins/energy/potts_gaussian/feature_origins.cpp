#include "feature_origins.hpp"

#include <yaml-cpp/yaml.h>

#include <set>

#include "terramrf/params.hpp"

namespace terramrf {
namespace {

std::string text(const YAML::Node& n) {
  if (!n) return "(not set)";
  YAML::Emitter em;
  em << YAML::Flow << n;
  return em.c_str();
}

/// The keys of map `key` in either origin.
std::set<std::string> keysOf(const YAML::Node& a, const YAML::Node& b, const char* key) {
  std::set<std::string> keys;
  for (const YAML::Node* n : {&a, &b})
    if ((*n)[key] && (*n)[key].IsMap())
      for (auto it = (*n)[key].begin(); it != (*n)[key].end(); ++it)
        keys.insert(it->first.as<std::string>());
  return keys;
}

/// `n[key][sub]`, or an undefined node when `n[key]` is missing or not a map: yaml-cpp throws when
/// a missing node is indexed, and a record without `inputs` (a stage that reads none) is valid.
YAML::Node child(const YAML::Node& n, const char* key, const std::string& sub) {
  const YAML::Node m = n[key];
  if (!m || !m.IsMap()) return YAML::Node(YAML::NodeType::Undefined);
  return m[sub];
}

void compare(const YAML::Node& learnt, const YAML::Node& here, const std::string& prefix,
             std::vector<std::string>& out) {
  const std::string stage_l = text(learnt["stage"]), stage_h = text(here["stage"]);
  if (stage_l != stage_h) {
    out.push_back(prefix + "written by " + stage_h + " here, by " + stage_l + " in the model");
    return;
  }
  // One grid for every layer of a run: said once, for the feature itself.
  // The sizes as numberText writes them: yaml-cpp's emitter records 0.1 as 0.10000000000000001.
  if (prefix.empty() && learnt["cell_m"] && here["cell_m"]) {
    const double learnt_m = learnt["cell_m"].as<double>(), here_m = here["cell_m"].as<double>();
    if (learnt_m != here_m)
      out.push_back("cells of " + numberText(here_m) + " m here, " + numberText(learnt_m) +
                    " m in the model");
  }
  for (const auto& k : keysOf(learnt, here, "params")) {
    const std::string l = text(child(learnt, "params", k)), h = text(child(here, "params", k));
    if (l != h) out.push_back(prefix + k + ": " + h + " here, " + l + " in the model");
  }
  for (const auto& in : keysOf(learnt, here, "inputs")) {
    const YAML::Node l = child(learnt, "inputs", in), h = child(here, "inputs", in);
    const std::string p = prefix + "input '" + in + "': ";
    if (!l || !h)
      out.push_back(p + (h ? "computed here, not recorded in the model"
                           : "recorded in the model, not computed here"));
    else
      compare(l, h, p, out);
  }
}

}  // namespace

std::vector<std::string> originDifferences(const std::string& learnt, const std::string& here) {
  std::vector<std::string> out;
  if (learnt == here) return out;
  try {
    compare(YAML::Load(learnt), YAML::Load(here), "", out);
  } catch (const YAML::Exception&) {
    out.push_back("the model's record of it cannot be read (" + learnt + ")");
  }
  return out;
}

}  // namespace terramrf
