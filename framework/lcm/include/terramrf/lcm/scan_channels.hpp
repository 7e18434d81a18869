#pragma once
// The channel parameters both LCM sources take (lcm_log, lcm_subscribe), declared and checked
// once. LCM-free header.
#include <string>
#include <vector>

#include "terramrf/lcm/log_frame_index.hpp"
#include "terramrf/params.hpp"

namespace terramrf {

struct ScanChannelParams {
  LogChannels channels{"TERRAMRF_GRID_POINTS"};
  /// Cameras every scan carries (image_t and camera_info_t each); empty = images not read.
  std::vector<std::string> cameras;
};

/// Declares points_channel … odometry_channel, images_channel, camera_info_channel, cameras.
void declareScanChannels(ParamDecl& d, ScanChannelParams& p);
/// Throws ParamError for an empty points channel, one channel for the pose and the truth pose,
/// or cameras without both image channels.
void checkScanChannels(const ScanChannelParams& p);

}  // namespace terramrf
