#pragma once
// Repeated keys in YAML files. yaml-cpp keeps both entries of a repeated key and every lookup
// returns the first, so a second `road:` in a label map or a second class in a model file would
// silently be ignored. Every reader of a YAML file the user writes or edits checks for them.
//
// Only declared here (yaml-cpp stays out of the core headers); callers include yaml-cpp.
#include <string>
#include <vector>

namespace YAML {
class Node;
class Exception;
}

namespace terramrf {

/// A key that appears a second time in one map. Positions are 1-based.
struct RepeatedYamlKey {
  std::string key;
  int line = 0, column = 0;  ///< of the repeat
  int first_line = 0;        ///< of the first occurrence
  /// "duplicate key 'road' (first at line 4): only one of the two would be used"
  std::string what() const;
  /// what(), prefixed with the repeat's position: "line 12:3: duplicate key 'road' …"
  std::string message() const;
};

/// Every repeated key of every map under `root`, depth first in file order.
std::vector<RepeatedYamlKey> repeatedYamlKeys(const YAML::Node& root);

/// Throws InputError(file, first repeat's message) when `root` repeats a key.
void throwOnRepeatedYamlKey(const YAML::Node& root, const std::string& file);

/// Throws InputError(file, "line L:C: unknown key 'sigmaa' in <where> (did you mean 'sigma'?);
/// expected one of: mean, sigma") for the first key of `map` that is not in `allowed`: a
/// misspelt key in a file the user edits would otherwise be ignored without a word. Does
/// nothing when `map` is not a map (the caller reports that in its own words).
void throwOnUnknownYamlKeys(const YAML::Node& map, const std::vector<std::string>& allowed,
                            const std::string& file, const std::string& where);

/// The YAML of a file the user writes or edits (label map, model, calibration), with its repeated
/// keys refused. A folder at `file` is refused as such. A file that cannot be read or parsed throws
/// InputError(file, "line L:C: YAML syntax error: …") — the position as repeats give it, not
/// yaml-cpp's own wording.
YAML::Node loadUserYaml(const std::string& file);

/// yaml-cpp's error from reading `file`'s nodes (a scalar indexed as a map, a key that is not a
/// string, a value of the wrong type) as InputError(file, "line L:C: <what>: <yaml-cpp's
/// message>"), so that no reader lets yaml-cpp's own message out without the file it is about.
[[noreturn]] void throwYamlInputError(const std::string& file, const YAML::Exception& e,
                                      const std::string& what);

}  // namespace terramrf
