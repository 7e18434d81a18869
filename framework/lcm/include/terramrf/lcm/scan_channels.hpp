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
  /// Layers of the grids on channels.grid that every scan brings (Frame::grid); "@labels" for
  /// their label layer.
  std::vector<std::string> grid_layers;
};

/// Declares points_channel … odometry_channel, images_channel, camera_info_channel,
/// image_truth_channel, cameras, grid_channel, grid_layers.
void declareScanChannels(ParamDecl& d, ScanChannelParams& p);
/// Throws ParamError for an empty points channel, one channel for the pose and the truth pose,
/// cameras without both image channels, image channels without cameras, or a grid channel
/// without grid layers and the other way round.
void checkScanChannels(const ScanChannelParams& p);

/// What a source with these parameters declares it writes (Source::writes()): the pose when a
/// pose channel is read, and the grid layers.
std::vector<std::string> scanWrites(const ScanChannelParams& p);

/// What frameFromMessages needs from these parameters, the run's labels and the source.
ScanOptions scanOptions(const ScanChannelParams& p, const LabelSet& labels, bool drop_no_return,
                        const std::string& source_path);

}  // namespace terramrf
