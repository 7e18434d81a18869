#pragma once
// A model's class Gaussians hold only for features computed as they were when it was learnt: a
// roughness window of 9 instead of 5 moves every cell's value, and the energy would then score
// cells against the wrong distributions without a word. The model records each feature's origin
// (stage, parameters, inputs: PluginContext::layer_origins); this compares it with the run's.
#include <string>
#include <vector>

namespace terramrf {

/// How the origin `here` (the run's) differs from `learnt` (the model's), both flow YAML
/// {stage, params, inputs}: one line per difference, e.g. "window: 9 here, 5 in the model";
/// inputs are compared too ("input 'roughness': window: …"). Empty when they agree.
std::vector<std::string> originDifferences(const std::string& learnt, const std::string& here);

}  // namespace terramrf
