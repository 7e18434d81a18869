#include "param_yaml.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

namespace terramrf::detail {

std::string describeNode(const YAML::Node& n) {
  if (n.IsScalar()) return "'" + n.Scalar() + "'";
  if (n.IsSequence()) return "a list";
  if (n.IsMap()) return "a map";
  return "nothing";
}

namespace {

std::size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] != b[j - 1])});
    }
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

bool parseBool(const YAML::Node& n, bool& out) {
  if (!n.IsScalar()) return false;
  const std::string s = n.Scalar();
  if (s == "true" || s == "True" || s == "TRUE" || s == "yes" || s == "on") return out = true, true;
  if (s == "false" || s == "False" || s == "FALSE" || s == "no" || s == "off")
    return out = false, true;
  return false;
}

bool parseInt(const YAML::Node& n, int64_t& out) {
  if (!n.IsScalar()) return false;
  const std::string& s = n.Scalar();
  try {
    std::size_t pos = 0;
    out = std::stoll(s, &pos, 10);
    return pos == s.size();
  } catch (...) {
    return false;
  }
}

bool parseDouble(const YAML::Node& n, double& out) {
  if (!n.IsScalar()) return false;
  const std::string& s = n.Scalar();
  if (s == ".nan" || s == ".NaN") return out = std::nan(""), true;
  if (s == ".inf" || s == "+.inf") return out = HUGE_VAL, true;
  if (s == "-.inf") return out = -HUGE_VAL, true;
  try {
    std::size_t pos = 0;
    out = std::stod(s, &pos);
    return pos == s.size();
  } catch (...) {
    return false;
  }
}

std::string rangeText(const ParamSpec& s) {
  std::ostringstream o;
  if (!s.min && !s.max)
    return "a finite number" + (s.unit.empty() || s.unit == "1" ? "" : " (" + s.unit + ")");
  if (s.min && s.max)
    o << "in [" << numberText(*s.min) << ", " << numberText(*s.max) << "]";
  else if (s.min)
    o << ">= " << numberText(*s.min);
  else if (s.max)
    o << "<= " << numberText(*s.max);
  if (!s.unit.empty() && s.unit != "1") o << " " << s.unit;
  return o.str();
}

// Converts one node to the spec's type; returns "" on success or the complaint.
std::string convert(const ParamSpec& s, const YAML::Node& n, ParamValue& out) {
  const std::string want = std::string("expected ") + toString(s.type);
  // Not finite is out of every range: an unbounded `class_cost: .inf` would make the
  // optimisers' energy differences NaN as surely as a NaN would.
  auto checkRange = [&](double v) -> std::string {
    if ((s.min && v < *s.min) || (s.max && v > *s.max) || !std::isfinite(v)) {
      std::ostringstream o;
      o << "value " << numberText(v) << " out of range: expected " << rangeText(s);
      return o.str();
    }
    return "";
  };
  switch (s.type) {
    case ParamType::kBool: {
      bool b;
      if (!parseBool(n, b)) return want + " (true/false), got " + describeNode(n);
      out = b;
      return "";
    }
    case ParamType::kInt: {
      int64_t i;
      if (!parseInt(n, i)) return want + ", got " + describeNode(n);
      out = i;
      return checkRange(static_cast<double>(i));
    }
    case ParamType::kDouble: {
      double d;
      if (!parseDouble(n, d)) return want + ", got " + describeNode(n);
      out = d;
      return checkRange(d);
    }
    case ParamType::kString: {
      if (!n.IsScalar()) return want + ", got " + describeNode(n);
      if (!s.choices.empty() &&
          std::find(s.choices.begin(), s.choices.end(), n.Scalar()) == s.choices.end()) {
        std::string c;
        for (const auto& x : s.choices) c += (c.empty() ? "" : ", ") + x;
        std::string m = "'" + n.Scalar() + "' is not one of: " + c;
        const std::string dym = didYouMean(n.Scalar(), s.choices);
        if (!dym.empty()) m += " (did you mean '" + dym + "'?)";
        return m;
      }
      out = n.Scalar();
      return "";
    }
    case ParamType::kStringList: {
      std::vector<std::string> v;
      if (n.IsScalar()) v.push_back(n.Scalar());  // a single value is a one-element list
      else if (n.IsSequence()) {
        for (const auto& e : n) {
          if (!e.IsScalar()) return want + ", got a nested " + describeNode(e);
          if (!s.choices.empty() &&
              std::find(s.choices.begin(), s.choices.end(), e.Scalar()) == s.choices.end())
            return "'" + e.Scalar() + "' is not an allowed value";
          if (s.unique && std::find(v.begin(), v.end(), e.Scalar()) != v.end())
            return "'" + e.Scalar() + "' is listed twice; list each entry once";
          v.push_back(e.Scalar());
        }
      } else if (!n.IsNull()) return want + ", got " + describeNode(n);
      out = v;
      return "";
    }
    case ParamType::kDoubleList: {
      std::vector<double> v;
      if (!n.IsSequence() && !n.IsNull()) return want + ", got " + describeNode(n);
      for (const auto& e : n) {
        double d;
        if (!parseDouble(e, d)) return want + ", element " + describeNode(e) + " is not a number";
        const std::string r = checkRange(d);
        if (!r.empty()) return r;
        v.push_back(d);
      }
      out = v;
      return "";
    }
  }
  return "unsupported type";
}

}  // namespace

std::string checkParamValue(const ParamSpec& spec, const YAML::Node& value) {
  ParamValue v;
  return convert(spec, value, v);
}

std::string canonicalParamValue(const ParamSpec& spec, const YAML::Node& value) {
  ParamValue v;
  return convert(spec, value, v).empty() ? toYaml(v) : "";
}

std::string didYouMean(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t best_d = std::max<std::size_t>(2, word.size() / 3) + 1;
  for (const auto& c : candidates) {
    const std::size_t d = editDistance(word, c);
    if (d < best_d) best_d = d, best = c;
  }
  return best;
}

std::vector<ParamIssue> applyParams(Plugin& plugin, const YAML::Node& params,
                                    const PluginContext& ctx, const YAML::Mark& stage_mark,
                                    const std::vector<std::pair<std::string, std::string>>& overrides) {
  std::vector<ParamIssue> issues;
  ParamDecl decl;
  plugin.declare(decl);
  std::vector<std::string> names;
  for (const auto& s : decl.specs()) names.push_back(s.name);
  std::map<std::string, YAML::Mark> seen;

  auto setOne = [&](const ParamSpec& spec, const YAML::Node& value, const YAML::Mark& mark) {
    ParamValue v;
    const std::string err = convert(spec, value, v);
    if (!err.empty()) {
      issues.push_back({spec.name, mark, "parameter '" + spec.name + "': " + err});
      return;
    }
    // An optional path given as "" is the default's "none" (a resolved config writes it so).
    const bool none = spec.existing_path && !spec.required && std::get<std::string>(v).empty();
    if (spec.existing_path && !none) {
      const std::string p = ctx.resolve(std::get<std::string>(v));
      if (!std::filesystem::exists(p)) {
        issues.push_back({spec.name, mark,
                          "parameter '" + spec.name + "': data path '" + p + "' does not exist"});
        return;
      }
      v = p;
    }
    spec.set(v);
  };

  if (params && !params.IsNull()) {
    if (!params.IsMap()) {
      issues.push_back({"", params.Mark(), "'params' must be a map of parameter: value"});
    } else {
      for (auto it = params.begin(); it != params.end(); ++it) {
        const YAML::Mark mark = it->first.Mark();
        if (!it->first.IsScalar()) {
          // `? [a, b] : 3` and merge keys' maps: no parameter is named by a list or a map.
          issues.push_back(
              {"", mark, "parameter names must be plain words, got " + describeNode(it->first)});
          continue;
        }
        const std::string key = it->first.Scalar();
        if (key == "<<") {
          issues.push_back({key, mark,
                            "YAML merge keys ('<<: *anchor') are not supported; give the "
                            "parameters themselves, or the whole params map as an alias "
                            "(params: *anchor)"});
          continue;
        }
        const ParamSpec* spec = decl.find(key);
        if (!spec) {
          std::string m = "unknown parameter '" + key + "'";
          const std::string dym = didYouMean(key, names);
          if (!dym.empty()) m += " (did you mean '" + dym + "'?)";
          else if (!names.empty()) {
            m += " (valid: ";
            for (std::size_t k = 0; k < names.size(); ++k) m += (k ? ", " : "") + names[k];
            m += ")";
          } else {
            m += " (this plugin takes no parameters)";
          }
          issues.push_back({key, mark, m});
          continue;
        }
        seen[key] = mark;
        // --data replaces the config's path, which need not exist where the override is used
        // (a config naming the author's data, run on another machine's).
        const bool overridden =
            std::any_of(overrides.begin(), overrides.end(),
                        [&](const std::pair<std::string, std::string>& o) { return o.first == key; });
        if (!overridden) {
          setOne(*spec, it->second, it->second.Mark());
        } else {
          // Still the right kind of value: only its existence is the override's to decide.
          ParamValue v;
          const std::string err = convert(*spec, it->second, v);
          if (!err.empty())
            issues.push_back({spec->name, it->second.Mark(), "parameter '" + spec->name + "': " + err});
        }
      }
    }
  }
  for (const auto& [key, text] : overrides) {
    const ParamSpec* spec = decl.find(key);
    if (!spec) {
      issues.push_back({key, stage_mark,
                        "cannot set '" + key +
                            "' from the command line (--data sets 'path'): this plugin "
                            "has no such parameter"});
      continue;
    }
    seen[key] = stage_mark;
    setOne(*spec, YAML::Node(text), stage_mark);
  }
  for (const auto& s : decl.specs()) {
    if (s.required && !seen.count(s.name)) {
      issues.push_back({s.name, stage_mark,
                        "missing required parameter '" + s.name + "' (" + toString(s.type) +
                            (s.doc.empty() ? "" : ": " + s.doc) + ")"});
    } else if (s.existing_path && !seen.count(s.name)) {
      // A default path must exist as well (resolved against the config folder).
      const auto* str = std::get_if<std::string>(&s.default_value);
      if (str && !str->empty()) {
        const std::string p = ctx.resolve(*str);
        if (!std::filesystem::exists(p))
          issues.push_back({s.name, stage_mark,
                            "parameter '" + s.name + "': default data path '" + p + "' does not exist"});
        else
          s.set(ParamValue(p));
      }
    }
  }
  if (issues.empty()) {
    try {
      plugin.configure(ctx);
    } catch (const ParamError& e) {
      auto it = seen.find(e.param());
      issues.push_back({e.param(), it != seen.end() ? it->second : stage_mark,
                        (e.param().empty() ? std::string() : "parameter '" + e.param() + "': ") + e.what()});
    } catch (const std::exception& e) {
      issues.push_back({"", stage_mark, e.what()});
    }
  }
  return issues;
}

YAML::Node currentParams(Plugin& plugin) {
  ParamDecl decl;
  plugin.declare(decl);
  YAML::Node n(YAML::NodeType::Map);
  for (const auto& s : decl.specs()) n[s.name] = YAML::Load(toYaml(s.get()));
  return n;
}

}  // namespace terramrf::detail
