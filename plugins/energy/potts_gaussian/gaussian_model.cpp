#include "gaussian_model.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "terramrf/errors.hpp"
#include "terramrf/params.hpp"
#include "terramrf/yaml_keys.hpp"

namespace terramrf {

namespace {
std::string at(const std::string& path, const YAML::Node& n) {
  return path + ":" + std::to_string(n.Mark().line + 1) + ":" + std::to_string(n.Mark().column + 1);
}

/// One number of a model entry: `key` of `entry`, named with its position when it is missing or
/// not a number.
double number(const std::string& path, const std::string& what, const YAML::Node& entry,
              const char* key) {
  const YAML::Node v = entry[key];
  if (!v) throw std::runtime_error(at(path, entry) + ": " + what + ": missing '" + key + "'");
  try {
    return v.as<double>();
  } catch (const YAML::Exception&) {
    throw std::runtime_error(
        at(path, v) + ": " + what + "." + key + ": expected a number, got '" +
        (v.IsScalar() ? v.Scalar() : std::string(v.IsMap() ? "a map" : "a list")) + "'");
  }
}

/// `{feature: {mean, sigma}, …}` of class `cls` into `out`.
void readFeatures(const std::string& path, const std::string& cls, const YAML::Node& map,
                  std::map<std::string, Gaussian>& out) {
  if (!map.IsMap())
    throw std::runtime_error(at(path, map) + ": class '" + cls +
                             "' must map features to {mean, sigma}");
  for (auto f = map.begin(); f != map.end(); ++f) {
    const std::string feat = f->first.as<std::string>();
    const std::string what = cls + "." + feat;
    if (!f->second.IsMap())
      throw std::runtime_error(at(path, f->second) + ": " + what +
                               ": expected {mean: <number>, sigma: <number > 0>}");
    throwOnUnknownYamlKeys(f->second, {"mean", "sigma"}, path, "feature '" + what + "'");
    Gaussian g;
    g.mean = number(path, what, f->second, "mean");
    g.sigma = number(path, what, f->second, "sigma");
    if (!std::isfinite(g.mean))
      throw std::runtime_error(at(path, f->second) + ": " + what +
                               ": mean must be a finite number, got " + numberText(g.mean));
    if (!(g.sigma > 0) || !std::isfinite(g.sigma))
      throw std::runtime_error(at(path, f->second) + ": " + what +
                               ": sigma must be a finite number > 0, got " + numberText(g.sigma));
    out[feat] = g;
  }
}

std::vector<GaussianComponent> readMixture(const std::string& path, const std::string& cls,
                                           const YAML::Node& list) {
  if (!list.IsSequence() || list.size() == 0)
    throw std::runtime_error(at(path, list) + ": " + cls +
                             ".components: expected a list of {weight, features}");
  std::vector<GaussianComponent> out;
  double sum = 0;
  for (const YAML::Node& c : list) {
    GaussianComponent comp;
    if (!c.IsMap())
      throw std::runtime_error(at(path, c) + ": " + cls +
                               ".components: each must be {weight: <number > 0>, features: …}");
    throwOnUnknownYamlKeys(c, {"weight", "features"}, path, "a component of class '" + cls + "'");
    comp.weight = number(path, cls + ".components", c, "weight");
    if (!(comp.weight > 0) || !std::isfinite(comp.weight))
      throw std::runtime_error(at(path, c) + ": " + cls +
                               ": component weight must be > 0 and finite, got " +
                               numberText(comp.weight));
    if (!c["features"])
      throw std::runtime_error(at(path, c) + ": " + cls + ".components: each needs 'features:'");
    readFeatures(path, cls, c["features"], comp.features);
    sum += comp.weight;
    out.push_back(std::move(comp));
  }
  if (std::abs(sum - 1) > 1e-3)
    throw std::runtime_error(at(path, list) + ": " + cls + ": component weights sum to " +
                             numberText(sum) + ", expected 1");
  return out;
}
}  // namespace

GaussianModel GaussianModel::load(const std::string& path) {
  GaussianModel m;
  m.path = path;
  // A second entry of a class or feature would silently be ignored: loadUserYaml refuses them.
  const YAML::Node root = loadUserYaml(path);
  if (!root.IsMap())
    throw InputError(path, "expected a model file (a map with 'classes:'; docs/training.md)");
  // A misspelt key (`feature_origin:`) would otherwise switch its check off without a word.
  throwOnUnknownYamlKeys(root, {"provenance", "trained_from", "feature_origins", "classes"}, path,
                         "the model file");
  try {
    if (root["provenance"]) m.provenance = root["provenance"].as<std::string>("");
    if (const YAML::Node o = root["feature_origins"]) {
      if (!o.IsMap())
        throw std::runtime_error(
            at(path, o) + ": expected 'feature_origins: {feature: {stage, params, inputs}}'");
      for (auto f = o.begin(); f != o.end(); ++f) {
        YAML::Emitter em;
        em << YAML::Flow << f->second;
        m.feature_origins[f->first.as<std::string>()] = em.c_str();
      }
    }
    const YAML::Node classes = root["classes"];
    if (!classes || !classes.IsMap())
      throw std::runtime_error(path +
                               ": expected a map 'classes: {class: {feature: {mean, sigma}}}'");
    for (auto c = classes.begin(); c != classes.end(); ++c) {
      const std::string cls = c->first.as<std::string>();
      if (c->second.IsMap() && c->second["components"]) {
        // Per-feature entries beside `components` would be ignored: a mixture is all or nothing.
        throwOnUnknownYamlKeys(c->second, {"components"}, path,
                               "class '" + cls + "' (a class with 'components' has nothing else)");
        m.classes[cls] = readMixture(path, cls, c->second["components"]);
      } else {
        GaussianComponent one;
        readFeatures(path, cls, c->second, one.features);
        m.classes[cls] = {one};
      }
    }
  } catch (const YAML::Exception& e) {
    throwYamlInputError(path, e, "not a model file (docs/training.md gives the format)");
  }
  return m;
}

}  // namespace terramrf
