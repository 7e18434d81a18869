#pragma once
// One scan's messages (a point cloud, its labels and poses, the samples since the scan before)
// made into a Frame: what the lcm_log and lcm_subscribe sources share, whether the messages
// come from a log or live. LCM-free header.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "terramrf/frame.hpp"
#include "terramrf/label_set.hpp"

namespace terramrf {

/// An encoded message and where it came from, for errors ("<log> event 12 (PTS)", a channel).
struct ScanMessage {
  std::string source;
  std::vector<std::uint8_t> bytes;
};

struct ScanMessages {
  std::string id;  ///< the scan's id (the cloud's frame_id)
  ScanMessage points;
  std::optional<ScanMessage> labels, pose, truth_pose;
  std::vector<ScanMessage> imu, gps, odometry;
  std::vector<ScanMessage> images, camera_infos;  ///< image_t and camera_info_t, any order
  std::vector<ScanMessage> image_truths;           ///< image_t of per-pixel truth (optional)
  std::optional<ScanMessage> grid;  ///< terrain_grid_t of layers made elsewhere (optional)
  std::optional<ScanMessage> grid_origins;  ///< layer_origins_t of that grid's layers (optional)
};

struct ScanOptions {
  const LabelSet* labels = nullptr;  ///< the run's classes; ground truth is mapped into them
  /// Set when every scan must have its pose (a pose channel is read): the channel, for errors.
  std::string pose_channel;
  bool drop_no_return = true;  ///< drop points exactly at (0, 0, 0)
  std::string source_path;     ///< Frame::source_path (the log, or the URL)
  /// Cameras every scan must carry (image and calibration each), in Frame::cameras' order;
  /// empty = images are not read.
  std::vector<std::string> cameras;
  std::string images_channel, camera_info_channel;  ///< for errors
  /// Set when every scan must have a grid made elsewhere (a grid channel is read): the channel,
  /// for errors, and the layers to take from it (Frame::grid); "@labels" takes its label layer.
  std::string grid_channel;
  std::vector<std::string> grid_layers;
};

/// Decodes every message into a Frame: the cloud (which must be in the "lidar" frame), ground
/// truth mapped by class name (one label per point), Frame::pose and covariance, the truth
/// pose, the samples in time order, and the images of `options.cameras` with their
/// calibrations (the image's size must be the calibration's). Points with a NaN/inf coordinate or
/// intensity, and no-returns at (0, 0, 0) if asked, are dropped and counted as every reader does,
/// with their labels, rings and times. Throws InputError naming the message's source for anything
/// that cannot be decoded or does not fit, and the scan's pose channel if it lacks a required pose.
/// With a grid channel, Frame::grid holds `options.grid_layers` of the scan's terrain_grid_t
/// (and its label layer, classes mapped by name): a grid without one of them, or a scan without
/// a grid, is an error naming the message or the channel. The origins of those layers that came
/// with it (layer_origins_t) go to Frame::layer_origins; a damaged one is an error naming it.
Frame frameFromMessages(const ScanMessages& messages, const ScanOptions& options);

/// The dropping above, on its own: for a frame whose points came from elsewhere.
void dropUnusablePoints(Frame& frame, bool drop_no_return);

}  // namespace terramrf
