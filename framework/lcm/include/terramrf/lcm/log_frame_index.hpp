#pragma once
// Groups the events of an LCM log into scans: a point cloud per scan, with the labels and poses
// that name the same scan (frame_id) and the IMU, GPS and odometry samples since the scan before.
// Built in one pass over the log, keeping positions, not data, so that a log of any length is
// indexed in little memory and each scan read on its own (LcmLogReader::readAt). LCM-free header.
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace terramrf {

/// Channels to read; "" = not read. Only `points` is required.
struct LogChannels {
  std::string points;      ///< point_cloud_t: one per scan, in scan order
  std::string labels;      ///< point_labels_t, matched to a scan by frame_id
  std::string pose;        ///< pose_t (the pose the pipeline is to use), by frame_id
  std::string truth_pose;  ///< pose_t (ground truth), by frame_id
  std::string imu, gps, odometry;  ///< samples, attached by time
  /// image_t and camera_info_t of every camera, matched by frame_id (several per scan: one per
  /// camera).
  std::string images, camera_info;
  std::string image_truth;  ///< image_t of per-pixel ground truth (mono8 class ids), optional
  std::string grid;         ///< terrain_grid_t of layers made elsewhere, by frame_id, optional
  std::string grid_origins;  ///< layer_origins_t of those grids' layers, by frame_id, optional
};

/// Where one scan's messages are in the log (byte offsets of their events).
struct LogFrame {
  std::string id;              ///< the cloud's frame_id; "event<N>" if it has none
  /// The cloud's time [µs]; for a message that is no readable point_cloud_t, the scan before's.
  std::int64_t utime = 0;
  std::int64_t eventnum = 0;   ///< the cloud's event number (for messages)
  std::int64_t points = 0;
  std::optional<std::int64_t> labels, pose, truth_pose, grid, grid_origins;
  /// Samples with a time after the previous scan's cloud, up to and including this one's.
  std::vector<std::int64_t> imu, gps, odometry;
  /// Its images and camera calibrations, in log order.
  std::vector<std::int64_t> images, camera_infos, image_truths;
  /// Why this scan cannot be read, "" if it can: two labels, poses, grids or origins name it.
  /// Reading it fails with this (the scan alone, not the log).
  std::string error;
};

struct LogFrameIndex {
  std::vector<LogFrame> frames;  ///< in log order
  /// Events seen per channel of the whole log, read or not (to name what a log holds).
  std::map<std::string, std::size_t> channel_events;
  /// Why some events of the channels read belong to no scan (a label or pose naming a scan
  /// without a cloud, a message of another type, samples after the last scan), one line each;
  /// empty if none.
  std::vector<std::string> notes;
  std::int64_t skipped_bytes = 0;  ///< LcmLogReader::skippedBytes() after the pass
};

/// Throws InputError naming the log if it cannot be read, if two clouds name the same scan
/// (their events given: which is the scan cannot be told, and the two cannot both run under one
/// id), or if sample channels are read and the clouds are not in time order (samples could not
/// be told which scan they precede). Two labels or poses for one scan fail that scan only
/// (LogFrame::error).
LogFrameIndex indexLogFrames(const std::string& path, const LogChannels& channels);

}  // namespace terramrf
