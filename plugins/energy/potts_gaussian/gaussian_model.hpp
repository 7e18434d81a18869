#pragma once
// Per-class Gaussian feature model (mean, standard deviation per feature), as learnt from
// annotated cells (paper 000 §4.6) or given by hand.
#include <map>
#include <string>
#include <vector>

namespace terramrf {

struct Gaussian {
  double mean = 0;
  double sigma = 1;  ///< > 0
};

struct GaussianModel {
  std::string path;                                         ///< file it came from
  std::string provenance;                                   ///< free text: data, label map, split
  std::map<std::string, std::map<std::string, Gaussian>> classes;  ///< class → feature → N(μ, σ)

  /// Loads a model file; throws std::runtime_error naming the file, line and what was expected.
  static GaussianModel load(const std::string& path);
};

}  // namespace terramrf
