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
  /// The grid_origins_channel parameter as given: "" = <grid channel>_ORIGINS (gridOriginsChannel).
  std::string grid_origins_channel;
};

/// The channel of the layer_origins_t that describe the grids' layers: the one named, else
/// `<grid channel>_ORIGINS`; "" without a grid channel.
std::string gridOriginsChannel(const ScanChannelParams& p);

/// Declares points_channel … odometry_channel, images_channel, camera_info_channel,
/// image_truth_channel, cameras, grid_channel, grid_layers, grid_origins_channel.
void declareScanChannels(ParamDecl& d, ScanChannelParams& p);
/// Throws ParamError for an empty points channel, one channel for the pose and the truth pose,
/// cameras without both image channels, image channels without cameras, a grid channel
/// without grid layers and the other way round, or an origins channel without a grid channel.
void checkScanChannels(const ScanChannelParams& p);

/// What a source with these parameters declares it writes (Source::writes()): the pose when a
/// pose channel is read, and the grid layers.
std::vector<std::string> scanWrites(const ScanChannelParams& p);

/// What frameFromMessages needs from these parameters, the run's labels and the source.
ScanOptions scanOptions(const ScanChannelParams& p, const LabelSet& labels, bool drop_no_return,
                        const std::string& source_path);

}  // namespace terramrf
