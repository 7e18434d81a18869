#pragma once
#include <stdexcept>
#include <string>

namespace terramrf {

/// Bad input data (a scan, a label file, a calibration, an image). The message names the file
/// and what was expected. In a batch the runner reports the frame and skips it.
class InputError : public std::runtime_error {
 public:
  InputError(const std::string& file, const std::string& what)
      : std::runtime_error(file.empty() ? what : file + ": " + what), file_(file) {}
  const std::string& file() const { return file_; }

 private:
  std::string file_;
};

/// A parameter value a plugin rejects in configure(); the core adds the config file position.
class ParamError : public std::runtime_error {
 public:
  ParamError(const std::string& param, const std::string& what)
      : std::runtime_error(what), param_(param) {}
  /// Name of the offending parameter ("" if it concerns the stage as a whole).
  const std::string& param() const { return param_; }

 private:
  std::string param_;
};

/// A plugin library that cannot be used (not a plugin, wrong ABI, missing symbol).
class PluginLoadError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace terramrf
