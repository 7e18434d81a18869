#pragma once
// Per-point ground truth (Frame::truth) ⇄ terramrf_msgs::point_labels_t. LCM-free header (see
// grid_codec.hpp).
#include <cstddef>
#include <string>

#include "terramrf/frame.hpp"
#include "terramrf/label_set.hpp"
#include "terramrf/lcm/message_header.hpp"

namespace terramrf {

/// The classes travel with their names (`labels`), so a receiver whose config orders or names
/// its classes otherwise maps them by name (mapPointLabels). `truth.raw` is sent when it has one
/// id per point. Throws std::invalid_argument if truth.raw has another length than truth.label
/// (other than 0) or a class id is not in `labels`.
MessageBytes encodePointLabels(const PointLabels& truth, const LabelSet& labels,
                               const MessageHeader& header);

struct DecodedPointLabels {
  MessageHeader header;  ///< coordinate_frame is not carried and stays default
  std::vector<std::string> label_names;  ///< index = class id of `truth.label`
  PointLabels truth;                     ///< class ids as sent (label_names'), raw if sent
};
/// Throws InputError (file = `source`) on foreign or truncated bytes, a class id without a
/// name, no names, a first name other than "unknown", or a raw array of another length.
DecodedPointLabels decodePointLabels(const void* data, std::size_t size,
                                     const std::string& source = "point_labels_t");

/// `ids`, numbered by the sender's class `names`, in place into the ids of `labels` (the
/// receiving run's classes), matched by name. Throws InputError (file = `source`) naming a class
/// that some id carries and `labels` lacks, listing those it has (`type`, the message's, leads
/// the message); names no id carries need no counterpart. Id 0 is unknown on both sides.
void mapLabelsByName(std::vector<LabelId>& ids, const std::vector<std::string>& names,
                     const LabelSet& labels, const std::string& source, const std::string& type);

/// The decoded labels in the ids of `labels` (the receiving run's classes), matched by name.
/// Throws InputError (file = `source`) naming a class that some point carries and `labels`
/// lacks, listing those it has: a class silently dropped to unknown would be one never scored.
/// Classes the sender names but no point carries need no counterpart.
PointLabels mapPointLabels(DecodedPointLabels decoded, const LabelSet& labels,
                           const std::string& source = "point_labels_t");

}  // namespace terramrf
