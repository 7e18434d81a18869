#include "terramrf/yaml_keys.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <filesystem>
#include <map>

#include "param_yaml.hpp"
#include "terramrf/errors.hpp"

namespace terramrf {
namespace {

void collect(const YAML::Node& n, std::vector<RepeatedYamlKey>& out) {
  if (n.IsMap()) {
    std::map<std::string, int> first_line;
    for (auto it = n.begin(); it != n.end(); ++it) {
      if (it->first.IsScalar()) {
        const YAML::Mark m = it->first.Mark();
        const auto [at, fresh] = first_line.emplace(it->first.Scalar(), m.line + 1);
        if (!fresh) out.push_back({it->first.Scalar(), m.line + 1, m.column + 1, at->second});
      }
      collect(it->second, out);
    }
  } else if (n.IsSequence()) {
    for (const auto& e : n) collect(e, out);
  }
}

}  // namespace

std::string RepeatedYamlKey::what() const {
  return "duplicate key '" + key + "' (first at line " + std::to_string(first_line) +
         "): only one of the two would be used";
}

std::string RepeatedYamlKey::message() const {
  return "line " + std::to_string(line) + ":" + std::to_string(column) + ": " + what();
}

std::vector<RepeatedYamlKey> repeatedYamlKeys(const YAML::Node& root) {
  std::vector<RepeatedYamlKey> out;
  if (root) collect(root, out);
  return out;
}

void throwOnRepeatedYamlKey(const YAML::Node& root, const std::string& file) {
  const auto repeats = repeatedYamlKeys(root);
  if (!repeats.empty()) throw InputError(file, repeats.front().message());
}

void throwOnUnknownYamlKeys(const YAML::Node& map, const std::vector<std::string>& allowed,
                            const std::string& file, const std::string& where) {
  if (!map.IsMap()) return;
  for (auto it = map.begin(); it != map.end(); ++it) {
    const std::string key = it->first.IsScalar() ? it->first.Scalar() : "";
    if (std::find(allowed.begin(), allowed.end(), key) != allowed.end()) continue;
    const YAML::Mark m = it->first.Mark();
    std::string msg = "line " + std::to_string(m.line + 1) + ":" + std::to_string(m.column + 1) +
                      ": unknown key '" + key + "' in " + where;
    const std::string dym = detail::didYouMean(key, allowed);
    if (!dym.empty()) msg += " (did you mean '" + dym + "'?)";
    std::string list;
    for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
    throw InputError(file, msg + "; expected one of: " + list);
  }
}

namespace {
std::string where(const YAML::Exception& e) {
  if (e.mark.is_null()) return "";
  return "line " + std::to_string(e.mark.line + 1) + ":" + std::to_string(e.mark.column + 1) + ": ";
}
}  // namespace

void throwYamlInputError(const std::string& file, const YAML::Exception& e,
                         const std::string& what) {
  throw InputError(file, where(e) + what + ": " + e.msg);
}

YAML::Node loadUserYaml(const std::string& file) {
  YAML::Node root;
  std::error_code ec;
  // std::ifstream opens a folder and then fails to read it with "basic_filebuf::underflow".
  if (std::filesystem::is_directory(file, ec))
    throw InputError(file, "is a folder; expected a YAML file");
  try {
    root = YAML::LoadFile(file);
  } catch (const YAML::BadFile&) {
    throw InputError(file, "cannot be opened");
  } catch (const YAML::Exception& e) {
    throwYamlInputError(file, e, "YAML syntax error");
  }
  throwOnRepeatedYamlKey(root, file);
  return root;
}

}  // namespace terramrf
