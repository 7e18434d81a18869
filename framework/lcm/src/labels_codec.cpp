#include "terramrf/lcm/labels_codec.hpp"

#include <limits>
#include <stdexcept>
#include <terramrf_msgs/point_labels_t.hpp>

#include "lcm_bytes.hpp"
#include "terramrf/errors.hpp"

namespace terramrf {

MessageBytes encodePointLabels(const PointLabels& truth, const LabelSet& labels,
                               const MessageHeader& header) {
  const std::size_t n = truth.label.size();
  if (!truth.raw.empty() && truth.raw.size() != n) {
    throw std::invalid_argument("encodePointLabels: " + std::to_string(truth.raw.size()) +
                                " raw ids for " + std::to_string(n) + " labels");
  }
  if (n > static_cast<std::size_t>(std::numeric_limits<int32_t>::max()))
    throw std::invalid_argument("encodePointLabels: too many points");
  terramrf_msgs::point_labels_t m;
  m.utime = toUtime(header.timestamp_s);
  m.frame_id = header.frame_id;
  m.label_names = labels.names();
  m.num_label_names = static_cast<int16_t>(m.label_names.size());
  m.num_points = static_cast<int32_t>(n);
  m.label.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (truth.label[i] >= labels.size()) {
      throw std::invalid_argument("encodePointLabels: point " + std::to_string(i) + " has class " +
                                  std::to_string(truth.label[i]) + ", the label set has " +
                                  std::to_string(labels.size()));
    }
    m.label[i] = truth.label[i];
  }
  m.raw.assign(truth.raw.begin(), truth.raw.end());
  m.num_raw = static_cast<int32_t>(m.raw.size());
  return lcm_detail::encodeMessage(m, "point_labels_t");
}

DecodedPointLabels decodePointLabels(const void* data, std::size_t size,
                                     const std::string& source) {
  auto m = lcm_detail::decodeMessage<terramrf_msgs::point_labels_t>(data, size, source,
                                                                    "point_labels_t");
  if (m.num_label_names <= 0 || m.label_names.front() != "unknown") {
    throw InputError(source, "point_labels_t: label_names must start with \"unknown\" (id 0), got " +
                                 (m.label_names.empty() ? std::string("none")
                                                        : "\"" + m.label_names.front() + "\""));
  }
  if (m.num_raw != 0 && m.num_raw != m.num_points) {
    throw InputError(source, "point_labels_t: num_raw must be 0 or num_points (" +
                                 std::to_string(m.num_points) + "), got " +
                                 std::to_string(m.num_raw));
  }
  DecodedPointLabels out;
  out.header.frame_id = std::move(m.frame_id);
  out.header.timestamp_s = fromUtime(m.utime);
  out.label_names = std::move(m.label_names);
  out.truth.label.resize(m.label.size());
  for (std::size_t i = 0; i < m.label.size(); ++i) {
    if (m.label[i] >= out.label_names.size()) {
      throw InputError(source, "point_labels_t: point " + std::to_string(i) + " has class id " +
                                   std::to_string(m.label[i]) + " but only " +
                                   std::to_string(out.label_names.size()) + " names");
    }
    out.truth.label[i] = m.label[i];
  }
  out.truth.raw.assign(m.raw.begin(), m.raw.end());
  return out;
}

void mapLabelsByName(std::vector<LabelId>& ids, const std::vector<std::string>& names,
                     const LabelSet& labels, const std::string& source, const std::string& type) {
  std::vector<LabelId> to(names.size(), labels::kUnknown);
  std::vector<bool> used(names.size(), false);
  for (LabelId l : ids) {
    // A class id the message names no class for cannot be mapped (a decoder may let labels
    // without names through).
    if (l >= names.size())
      throw InputError(source, type + ": label id " + std::to_string(l) + " has no class name (" +
                                   std::to_string(names.size()) +
                                   " named); expected the sender's class names with its labels");
    used[l] = true;
  }
  for (std::size_t id = 1; id < names.size(); ++id) {
    const int mine = labels.find(names[id]);
    if (mine < 0 && used[id]) {
      std::string have;
      for (const std::string& n : labels.names()) have += (have.empty() ? "" : ", ") + n;
      throw InputError(source, type + ": class \"" + names[id] +
                                   "\" is not in this run's label set (" + have +
                                   "); add it to the config's labels or send mapped labels");
    }
    if (mine >= 0) to[id] = static_cast<LabelId>(mine);
  }
  for (LabelId& l : ids) l = to[l];
}

PointLabels mapPointLabels(DecodedPointLabels decoded, const LabelSet& labels,
                           const std::string& source) {
  mapLabelsByName(decoded.truth.label, decoded.label_names, labels, source, "point_labels_t");
  return std::move(decoded.truth);
}

}  // namespace terramrf
