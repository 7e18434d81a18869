#pragma once
// The channel parameters both LCM sources take (lcm_log, lcm_subscribe), declared and checked
// once. LCM-free header.
#include <string>
#include <vector>

#include "terramrf/lcm/log_frame_index.hpp"
#include "terramrf/lcm/scan_messages.hpp"
#include "terramrf/params.hpp"

namespace terramrf {

struct ScanChannelParams {
  LogChannels channels{"TERRAMRF_GRID_POINTS"};
  /// Cameras every scan carries (image_t and camera_info_t each); empty = images not read.
  std::vector<std::string> cameras;
};

/// Declares points_channel … odometry_channel, images_channel, camera_info_channel,
/// image_truth_channel, cameras.
void declareScanChannels(ParamDecl& d, ScanChannelParams& p);
/// Throws ParamError for an empty points channel, one channel for the pose and the truth pose,
/// cameras without both image channels, or image channels without cameras.
void checkScanChannels(const ScanChannelParams& p);

/// What frameFromMessages needs from these parameters, the run's labels and the source.
ScanOptions scanOptions(const ScanChannelParams& p, const LabelSet& labels, bool drop_no_return,
                        const std::string& source_path);

}  // namespace terramrf
