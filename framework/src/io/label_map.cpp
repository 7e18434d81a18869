
#include "terramrf/io/label_map.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "terramrf/errors.hpp"
#include "terramrf/yaml_keys.hpp"

namespace terramrf {
namespace {

constexpr std::size_t kDenseSize = 65536;

uint32_t parseId(const YAML::Node& n, const std::string& path, const std::string& where) {
  long long v = 0;
  try {
    v = n.as<long long>();
  } catch (const YAML::Exception&) {
    throw InputError(path, where + ": '" + n.as<std::string>("?") + "' is not an integer label id");
  }
  if (v < 0 || v > 0xFFFFFFFFLL)
    throw InputError(path,
                     where + ": label id " + std::to_string(v) + " is out of range 0..2^32-1");
  return static_cast<uint32_t>(v);
}

}  // namespace

LabelMap LabelMap::load(const std::string& yaml_path, const LabelSet& labels) {
  if (!std::filesystem::is_regular_file(yaml_path))
    throw InputError(yaml_path, "label map file does not exist");
  const YAML::Node root = loadUserYaml(yaml_path);
  LabelMap m;
  try {
    m.path_ = yaml_path;
    if (root["dataset"]) m.dataset_ = root["dataset"].as<std::string>();
    const YAML::Node classes = root["classes"];
    if (!classes || !classes.IsMap())
      throw InputError(yaml_path, "expected a 'classes' map of project class -> list of raw ids");
    for (auto it = classes.begin(); it != classes.end(); ++it) {
      const std::string cls = it->first.as<std::string>();
      const int id = labels.find(cls);
      if (id < 0) {
        std::string known;
        for (const auto& n : labels.names()) known += (known.empty() ? "" : ", ") + n;
        throw InputError(yaml_path,
                         "class '" + cls + "' is not a project class (known: " + known + ")");
      }
      const YAML::Node ids = it->second;
      if (!ids.IsSequence())
        throw InputError(yaml_path,
                         "class '" + cls + "': expected a list of raw ids, e.g. [40, 44]");
      for (const auto& n : ids) {
        const uint32_t raw = parseId(n, yaml_path, "class '" + cls + "'");
        auto [pos, inserted] = m.by_raw_.emplace(raw, static_cast<LabelId>(id));
        if (!inserted && pos->second != static_cast<LabelId>(id))
          throw InputError(yaml_path, "raw id " + std::to_string(raw) + " is listed under both '" +
                                          labels.name(pos->second) + "' and '" + cls + "'");
      }
    }
    if (m.by_raw_.empty()) throw InputError(yaml_path, "'classes' lists no raw ids");
    if (const YAML::Node names = root["names"]) {
      if (!names.IsMap()) throw InputError(yaml_path, "'names' must be a map of raw id -> name");
      for (auto it = names.begin(); it != names.end(); ++it)
        m.names_[parseId(it->first, yaml_path, "names")] = it->second.as<std::string>();
    }
  } catch (const YAML::Exception& e) {
    throwYamlInputError(yaml_path, e,
                        "not a label map ({classes: {class: [raw ids]}, names: {id: name}})");
  }
  m.dense_.assign(kDenseSize, -1);
  for (const auto& [raw, cls] : m.by_raw_)
    if (raw < kDenseSize) m.dense_[raw] = cls;
  return m;
}

bool LabelMap::contains(uint32_t raw) const {
  if (raw < dense_.size()) return dense_[raw] >= 0;
  return by_raw_.count(raw) > 0;
}

void LabelMap::unmapped(uint32_t raw, const std::string& data_file, std::size_t count) const {
  std::string what = "raw label id " + std::to_string(raw);
  const std::string n = name(raw);
  if (!n.empty()) what += " (" + n + ")";
  if (!data_file.empty()) {
    what += ", found in " + data_file;
    if (count > 1) what += " (" + std::to_string(count) + " times)";
  }
  what += ", is not listed in the label map; add it to one of the classes";
  throw InputError(path_.empty() ? std::string("<no label map>") : path_, what);
}

LabelId LabelMap::map(uint32_t raw, const std::string& data_file) const {
  if (raw < dense_.size()) {
    const int16_t c = dense_[raw];
    if (c >= 0) return static_cast<LabelId>(c);
  } else if (auto it = by_raw_.find(raw); it != by_raw_.end()) {
    return it->second;
  }
  unmapped(raw, data_file, 1);
}

void LabelMap::mapAll(const std::vector<uint32_t>& raw, std::vector<LabelId>& out,
                      const std::string& data_file) const {
  out.resize(raw.size());
  const std::size_t n = raw.size();
  for (std::size_t i = 0; i < n; ++i) {
    const uint32_t r = raw[i];
    int c = -1;
    if (r < dense_.size())
      c = dense_[r];
    else if (auto it = by_raw_.find(r); it != by_raw_.end())
      c = it->second;
    if (c < 0) {
      const std::size_t count = static_cast<std::size_t>(std::count(raw.begin(), raw.end(), r));
      unmapped(r, data_file, count);
    }
    out[i] = static_cast<LabelId>(c);
  }
}

void LabelMap::mapAll(const uint8_t* raw, std::size_t n, LabelId* out,
                      const std::string& data_file) const {
  int16_t lut[256];
  for (int v = 0; v < 256; ++v)
    lut[v] = static_cast<std::size_t>(v) < dense_.size() ? dense_[v] : int16_t(-1);
  for (std::size_t i = 0; i < n; ++i) {
    const int16_t c = lut[raw[i]];
    if (c < 0) {
      const std::size_t count = static_cast<std::size_t>(std::count(raw, raw + n, raw[i]));
      unmapped(raw[i], data_file, count);
    }
    out[i] = static_cast<LabelId>(c);
  }
}

std::string LabelMap::name(uint32_t raw) const {
  auto it = names_.find(raw);
  return it == names_.end() ? std::string() : it->second;
}

std::vector<uint32_t> LabelMap::rawIds() const {
  std::vector<uint32_t> ids;
  ids.reserve(by_raw_.size());
  for (const auto& [raw, cls] : by_raw_) ids.push_back(raw);
  return ids;
}

std::string shippedLabelMap(const std::string& file) {
  std::string dirs;
  if (const char* env = std::getenv("TERRAMRF_CONFIG_DIR"))
    dirs = std::string(env) + "/label_maps:";
  dirs += TERRAMRF_LABEL_MAP_DIRS;
  std::stringstream ss(dirs);
  std::string d;
  while (std::getline(ss, d, ':'))
    if (!d.empty() && std::filesystem::is_regular_file(d + "/" + file)) return d + "/" + file;
  throw ParamError("label_map", "no label_map given and the shipped " + file +
                                    " was not found (searched " + dirs + ")");
}

}  // namespace terramrf
