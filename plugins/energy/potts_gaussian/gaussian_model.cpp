#include "gaussian_model.hpp"

#include <yaml-cpp/yaml.h>

#include <stdexcept>

namespace terramrf {

namespace {
std::string at(const std::string& path, const YAML::Node& n) {
  return path + ":" + std::to_string(n.Mark().line + 1) + ":" + std::to_string(n.Mark().column + 1);
}
}  // namespace

GaussianModel GaussianModel::load(const std::string& path) {
  GaussianModel m;
  m.path = path;
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(path + ": cannot read model file: " + e.what());
  }
  if (root["provenance"]) m.provenance = root["provenance"].as<std::string>("");
  const YAML::Node classes = root["classes"];
  if (!classes || !classes.IsMap())
    throw std::runtime_error(path + ": expected a map 'classes: {class: {feature: {mean, sigma}}}'");
  for (auto c = classes.begin(); c != classes.end(); ++c) {
    const std::string cls = c->first.as<std::string>();
    if (!c->second.IsMap())
      throw std::runtime_error(at(path, c->second) + ": class '" + cls + "' must map features to {mean, sigma}");
    for (auto f = c->second.begin(); f != c->second.end(); ++f) {
      const std::string feat = f->first.as<std::string>();
      Gaussian g;
      try {
        g.mean = f->second["mean"].as<double>();
        g.sigma = f->second["sigma"].as<double>();
      } catch (const YAML::Exception&) {
        throw std::runtime_error(at(path, f->second) + ": " + cls + "." + feat +
                                 ": expected {mean: <number>, sigma: <number > 0>}");
      }
      if (!(g.sigma > 0))
        throw std::runtime_error(at(path, f->second) + ": " + cls + "." + feat +
                                 ": sigma must be > 0, got " + std::to_string(g.sigma));
      m.classes[cls][feat] = g;
    }
  }
  return m;
}

}  // namespace terramrf
