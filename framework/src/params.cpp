#include "terramrf/params.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace terramrf {

const char* toString(ParamType t) {
  switch (t) {
    case ParamType::kBool: return "bool";
    case ParamType::kInt: return "int";
    case ParamType::kDouble: return "float";
    case ParamType::kString: return "string";
    case ParamType::kStringList: return "list of strings";
    case ParamType::kDoubleList: return "list of floats";
  }
  return "?";
}

std::string numberText(double d) {
  if (std::isnan(d)) return "nan";
  if (std::isinf(d)) return d > 0 ? "inf" : "-inf";
  // Whole numbers as such: general notation writes 4194304 as 4.194304e+06.
  if (d == std::trunc(d) && std::abs(d) < 1e15 && !(d == 0 && std::signbit(d)))
    return std::to_string(static_cast<int64_t>(d));
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, d, std::chars_format::general);
  return std::string(buf, r.ptr);
}

namespace {
std::string num(double d) {
  if (std::isnan(d)) return ".nan";
  if (std::isinf(d)) return d > 0 ? ".inf" : "-.inf";
  // The shortest text that reads back as the same double: a resolved config must reproduce the
  // run (ten digits turned 0.12000000000123 into 0.12, and simulated another cloud). ".0" keeps
  // a whole number a float in YAML.
  std::string s = numberText(d);
  if (s.find_first_of(".eE") == std::string::npos) s += ".0";
  return s;
}
std::string quote(const std::string& s) {
  bool plain = !s.empty();
  for (char c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.' ||
          c == '/'))
      plain = false;
  if (plain && (s == "true" || s == "false" || s == "null" || s == "yes" || s == "no")) plain = false;
  if (plain && (std::isdigit(static_cast<unsigned char>(s[0])) || s[0] == '-' || s[0] == '.'))
    plain = false;
  if (plain) return s;
  std::string q = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') q += '\\';
    q += c;
  }
  return q + "\"";
}
}  // namespace

std::string toYaml(const ParamValue& v) {
  std::ostringstream o;
  if (auto b = std::get_if<bool>(&v)) return *b ? "true" : "false";
  if (auto i = std::get_if<int64_t>(&v)) return std::to_string(*i);
  if (auto d = std::get_if<double>(&v)) return num(*d);
  if (auto s = std::get_if<std::string>(&v)) return quote(*s);
  if (auto l = std::get_if<std::vector<std::string>>(&v)) {
    o << "[";
    for (std::size_t k = 0; k < l->size(); ++k) o << (k ? ", " : "") << quote((*l)[k]);
    o << "]";
    return o.str();
  }
  if (auto l = std::get_if<std::vector<double>>(&v)) {
    o << "[";
    for (std::size_t k = 0; k < l->size(); ++k) o << (k ? ", " : "") << num((*l)[k]);
    o << "]";
    return o.str();
  }
  return "?";
}

const ParamSpec* ParamDecl::find(const std::string& name) const {
  for (const auto& s : specs_)
    if (s.name == name) return &s;
  return nullptr;
}

}  // namespace terramrf
