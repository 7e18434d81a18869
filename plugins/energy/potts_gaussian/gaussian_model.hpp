#pragma once
// Per-class feature model, as learnt from annotated cells (paper 000 §4.6) or given by hand:
// per class one diagonal Gaussian over the features (eq. 11), or a mixture of several.
#include <map>
#include <string>
#include <vector>

namespace terramrf {

struct Gaussian {
  double mean = 0;
  double sigma = 1;  ///< > 0
};

/// One component of a class: a diagonal Gaussian over the features and its weight.
struct GaussianComponent {
  double weight = 1;                         ///< > 0; a class's weights sum to 1
  std::map<std::string, Gaussian> features;  ///< feature → N(μ, σ)
};

struct GaussianModel {
  std::string path;        ///< file it came from
  std::string provenance;  ///< free text: data, label map, split
  /// class → components: one for paper 000's model, several for a mixture.
  std::map<std::string, std::vector<GaussianComponent>> classes;
  /// feature → how it was computed when the model was learnt (PluginContext::layer_origins'
  /// flow YAML); empty for models written before it was recorded, or by hand.
  std::map<std::string, std::string> feature_origins;

  /// Loads a model file; throws std::runtime_error naming the file, line and what was expected.
  /// A class is either `{feature: {mean, sigma}, …}` (one component) or
  /// `{components: [{weight, features: {feature: {mean, sigma}, …}}, …]}`.
  static GaussianModel load(const std::string& path);
};

}  // namespace terramrf
