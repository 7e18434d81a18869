#include "gaussian_model.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "terramrf/errors.hpp"
#include "terramrf/yaml_keys.hpp"

namespace terramrf {

namespace {
std::string at(const std::string& path, const YAML::Node& n) {
  return path + ":" + std::to_string(n.Mark().line + 1) + ":" + std::to_string(n.Mark().column + 1);
}

/// `{feature: {mean, sigma}, …}` of class `cls` into `out`.
void readFeatures(const std::string& path, const std::string& cls, const YAML::Node& map,
                  std::map<std::string, Gaussian>& out) {
  if (!map.IsMap())
    throw std::runtime_error(at(path, map) + ": class '" + cls +
                             "' must map features to {mean, sigma}");
  for (auto f = map.begin(); f != map.end(); ++f) {
    const std::string feat = f->first.as<std::string>();
    Gaussian g;
    try {
      g.mean = f->second["mean"].as<double>();
      g.sigma = f->second["sigma"].as<double>();
    } catch (const YAML::Exception&) {
      throw std::runtime_error(at(path, f->second) + ": " + cls + "." + feat +
                               ": expected {mean: <number>, sigma: <number > 0>}");
    }
    if (!std::isfinite(g.mean))
      throw std::runtime_error(at(path, f->second) + ": " + cls + "." + feat +
                               ": mean must be a finite number, got " + std::to_string(g.mean));
    if (!(g.sigma > 0) || !std::isfinite(g.sigma))
      throw std::runtime_error(at(path, f->second) + ": " + cls + "." + feat +
                               ": sigma must be a finite number > 0, got " +
                               std::to_string(g.sigma));
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
    try {
      comp.weight = c["weight"].as<double>();
    } catch (const YAML::Exception&) {
      throw std::runtime_error(at(path, c) + ": " + cls +
                               ".components: each needs 'weight: <number > 0>'");
    }
    if (!(comp.weight > 0))
      throw std::runtime_error(at(path, c) + ": " + cls + ": component weight must be > 0, got " +
                               std::to_string(comp.weight));
    if (!c["features"])
      throw std::runtime_error(at(path, c) + ": " + cls + ".components: each needs 'features:'");
    readFeatures(path, cls, c["features"], comp.features);
    sum += comp.weight;
    out.push_back(std::move(comp));
  }
  if (std::abs(sum - 1) > 1e-3)
    throw std::runtime_error(at(path, list) + ": " + cls + ": component weights sum to " +
                             std::to_string(sum) + ", expected 1");
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
