#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace terramrf {

/// Project class id as stored in the grid's label layer and in per-point ground truth.
using LabelId = uint8_t;

/// The project's default classes (paper 000 §4.4). `unknown` means "no data": it is never
/// predicted for a cell that holds points, and ground truth marked unknown is not scored.
namespace labels {
inline constexpr LabelId kUnknown = 0;
inline constexpr LabelId kRoad = 1;
inline constexpr LabelId kRough = 2;
inline constexpr LabelId kObstacle = 3;
}  // namespace labels

struct LabelInfo {
  std::string name;
  std::array<uint8_t, 3> rgb;  ///< display colour
};

/// Names and colours of the classes. Id 0 is always "unknown".
class LabelSet {
 public:
  /// {unknown, road, rough, obstacle} with the colours of the grid PNG (black, grey, brown, red).
  static LabelSet defaults();

  explicit LabelSet(std::vector<LabelInfo> infos);
  LabelSet() : LabelSet(defaults()) {}

  std::size_t size() const { return infos_.size(); }
  const LabelInfo& operator[](LabelId id) const { return infos_.at(id); }
  const std::string& name(LabelId id) const { return infos_.at(id).name; }
  /// Id of a class by name; -1 if absent.
  int find(const std::string& name) const;
  /// Id of "obstacle" (evaluation rules of paper 001 need it); -1 if the set has none.
  int obstacle() const { return find("obstacle"); }
  std::vector<std::string> names() const;

 private:
  std::vector<LabelInfo> infos_;
};

}  // namespace terramrf
