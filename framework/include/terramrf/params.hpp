#pragma once
// Parameter declaration: a plugin binds each parameter to one of its members once, with doc, unit
// and range; the member's in-class initialiser is the default. The core uses the same declaration
// to validate configs, fill defaults, and print `terramrf describe`, so docs cannot drift.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

namespace terramrf {

enum class ParamType { kBool, kInt, kDouble, kString, kStringList, kDoubleList };
const char* toString(ParamType t);

using ParamValue =
    std::variant<bool, int64_t, double, std::string, std::vector<std::string>, std::vector<double>>;

/// Renders a value as YAML flow text (for describe and the resolved config).
std::string toYaml(const ParamValue& v);
/// The shortest text that reads back as `d` (4194304, 1e-09, 0.12000000000123): for messages,
/// which must state the limits exactly (six digits made 4194304 read 4.1943e+06).
std::string numberText(double d);

struct ParamSpec {
  std::string name;
  ParamType type = ParamType::kDouble;
  std::string doc;
  std::string unit;                ///< "m", "rad", "1" (dimensionless), "" if not numeric
  std::optional<double> min, max;  ///< inclusive range for numbers (and list elements)
  std::vector<std::string> choices;  ///< allowed strings, if restricted
  bool required = false;           ///< no default; the config must give it
  bool existing_path = false;      ///< a string that names a file/folder which must exist
  bool unique = false;             ///< a string list whose entries must all differ
  ParamValue default_value;        ///< the bound member's value at declaration time

  // Bound member access (set by ParamDecl::add).
  std::function<void(const ParamValue&)> set;
  std::function<ParamValue()> get;
};

/// Fluent handle returned by ParamDecl::add.
class ParamRef {
 public:
  explicit ParamRef(ParamSpec& s) : s_(s) {}
  ParamRef& unit(std::string u) { s_.unit = std::move(u); return *this; }
  ParamRef& range(double lo, double hi) { s_.min = lo; s_.max = hi; return *this; }
  ParamRef& min(double lo) { s_.min = lo; return *this; }
  ParamRef& max(double hi) { s_.max = hi; return *this; }
  ParamRef& choices(std::vector<std::string> c) { s_.choices = std::move(c); return *this; }
  ParamRef& required() { s_.required = true; return *this; }
  /// The value is a path that must exist (resolved relative to the config file's folder).
  ParamRef& existingPath() { s_.existing_path = true; return *this; }
  /// A string list whose entries must all differ (layers, features, classes, cameras).
  ParamRef& unique() {
    s_.unique = true;
    return *this;
  }

 private:
  ParamSpec& s_;
};

class ParamDecl {
 public:
  /// Binds `field` as parameter `name`. Supported member types: bool, int, int64_t, uint32_t,
  /// double, float, std::string, std::vector<std::string>, std::vector<double>.
  template <class T>
  ParamRef add(const std::string& name, T& field, std::string doc);

  const std::vector<ParamSpec>& specs() const { return specs_; }
  std::vector<ParamSpec>& specs() { return specs_; }
  const ParamSpec* find(const std::string& name) const;

 private:
  std::vector<ParamSpec> specs_;
};

// ---- implementation ------------------------------------------------------------------------

template <class T>
ParamRef ParamDecl::add(const std::string& name, T& field, std::string doc) {
  ParamSpec s;
  s.name = name;
  s.doc = std::move(doc);
  T* f = &field;
  if constexpr (std::is_same_v<T, bool>) {
    s.type = ParamType::kBool;
    s.set = [f](const ParamValue& v) { *f = std::get<bool>(v); };
    s.get = [f]() -> ParamValue { return *f; };
  } else if constexpr (std::is_integral_v<T>) {
    s.type = ParamType::kInt;
    s.set = [f](const ParamValue& v) { *f = static_cast<T>(std::get<int64_t>(v)); };
    s.get = [f]() -> ParamValue { return static_cast<int64_t>(*f); };
  } else if constexpr (std::is_floating_point_v<T>) {
    s.type = ParamType::kDouble;
    s.set = [f](const ParamValue& v) { *f = static_cast<T>(std::get<double>(v)); };
    s.get = [f]() -> ParamValue { return static_cast<double>(*f); };
  } else if constexpr (std::is_same_v<T, std::string>) {
    s.type = ParamType::kString;
    s.set = [f](const ParamValue& v) { *f = std::get<std::string>(v); };
    s.get = [f]() -> ParamValue { return *f; };
  } else if constexpr (std::is_same_v<T, std::vector<std::string>>) {
    s.type = ParamType::kStringList;
    s.set = [f](const ParamValue& v) { *f = std::get<std::vector<std::string>>(v); };
    s.get = [f]() -> ParamValue { return *f; };
  } else if constexpr (std::is_same_v<T, std::vector<double>>) {
    s.type = ParamType::kDoubleList;
    s.set = [f](const ParamValue& v) { *f = std::get<std::vector<double>>(v); };
    s.get = [f]() -> ParamValue { return *f; };
  } else {
    static_assert(sizeof(T) == 0, "unsupported parameter type");
  }
  s.default_value = s.get();
  specs_.push_back(std::move(s));
  return ParamRef(specs_.back());
}

}  // namespace terramrf
