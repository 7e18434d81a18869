#pragma once
// Dataset label ids -> project classes. The mapping is a config file (configs/label_maps/*.yaml) so
// a project can change, e.g., whether vegetation is an obstacle without touching code:
//
//   dataset: semantickitti
//   classes:                 # project class name (from the LabelSet) -> raw dataset ids
//     unknown: [0, 1]
//     road: [40, 44, 48, 60]
//   names: {40: road, ...}   # optional raw id -> dataset class name, for messages
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "terramrf/label_set.hpp"

namespace terramrf {

class LabelMap {
 public:
  /// Reads and validates a label-map YAML. Throws InputError naming the file when it cannot be
  /// read, a class is not in `labels`, an id is negative or listed twice.
  static LabelMap load(const std::string& yaml_path, const LabelSet& labels);

  LabelMap() = default;

  /// Project class of a raw dataset id. An id the map does not list throws InputError naming
  /// the label-map file, the id and `data_file` (the scan or image the id came from).
  LabelId map(uint32_t raw, const std::string& data_file = "") const;
  /// Maps a whole array; same error as map() for the first unlisted id (with its count).
  void mapAll(const std::vector<uint32_t>& raw, std::vector<LabelId>& out,
              const std::string& data_file) const;
  /// Maps an 8-bit id array (pixel label images) into `out` (n entries).
  void mapAll(const uint8_t* raw, std::size_t n, LabelId* out, const std::string& data_file) const;

  bool contains(uint32_t raw) const;
  /// Dataset name of a raw id ("" if the file gives none).
  std::string name(uint32_t raw) const;
  /// All listed raw ids, ascending.
  std::vector<uint32_t> rawIds() const;

  const std::string& path() const { return path_; }
  const std::string& dataset() const { return dataset_; }
  bool empty() const { return by_raw_.empty(); }

 private:
  [[noreturn]] void unmapped(uint32_t raw, const std::string& data_file, std::size_t count) const;

  std::string path_;
  std::string dataset_;
  std::map<uint32_t, LabelId> by_raw_;
  std::map<uint32_t, std::string> names_;
  /// Dense table for ids < 65536 (all SemanticKITTI / RELLIS ids): -1 = unlisted.
  std::vector<int16_t> dense_;
};

/// Path of the shipped label map `file` (e.g. "semantickitti.yaml") for a source whose
/// `label_map` is not configured: $TERRAMRF_CONFIG_DIR/label_maps, then the source tree's
/// configs/label_maps (build-tree runs), then the install's. Throws ParamError("label_map", …)
/// naming the folders searched.
std::string shippedLabelMap(const std::string& file);

}  // namespace terramrf
