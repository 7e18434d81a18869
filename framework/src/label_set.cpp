#include "terramrf/label_set.hpp"

#include <stdexcept>

namespace terramrf {

LabelSet LabelSet::defaults() {
  return LabelSet({{"unknown", {0, 0, 0}},
                   {"road", {128, 128, 128}},
                   {"rough", {139, 90, 43}},
                   {"obstacle", {220, 30, 30}}});
}

LabelSet::LabelSet(std::vector<LabelInfo> infos) : infos_(std::move(infos)) {
  if (infos_.empty() || infos_[0].name != "unknown") {
    throw std::invalid_argument("label set: the first class (id 0) must be 'unknown'");
  }
  if (infos_.size() > 255) throw std::invalid_argument("label set: at most 255 classes");
}

int LabelSet::find(const std::string& name) const {
  for (std::size_t i = 0; i < infos_.size(); ++i)
    if (infos_[i].name == name) return static_cast<int>(i);
  return -1;
}

std::vector<std::string> LabelSet::names() const {
  std::vector<std::string> n;
  for (const auto& i : infos_) n.push_back(i.name);
  return n;
}

}  // namespace terramrf
