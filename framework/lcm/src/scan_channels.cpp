#include "terramrf/lcm/scan_channels.hpp"

#include <utility>

#include "terramrf/errors.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {

void declareScanChannels(ParamDecl& d, ScanChannelParams& p) {
  LogChannels& ch = p.channels;
  d.add("points_channel", ch.points,
        "channel of the point_cloud_t messages: one per scan, the scan's id its frame_id "
        "(lcm_publish with publish_points: <channel>_POINTS)");
  d.add("labels_channel", ch.labels,
        "channel of point_labels_t ground truth, matched to scans by frame_id (lcm_publish with "
        "publish_truth: <channel>_LABELS); empty = no ground truth");
  d.add("pose_channel", ch.pose,
        "channel of pose_t LiDAR poses for the pipeline (Frame::pose), matched by frame_id "
        "(lcm_publish with publish_pose: <channel>_POSE); every scan must have one; empty = no "
        "pose");
  d.add("truth_pose_channel", ch.truth_pose,
        "channel of pose_t ground-truth poses (Frame::truth_pose), matched by frame_id "
        "(lcm_publish with publish_truth: <channel>_TRUTH_POSE); empty = none");
  d.add("imu_channel", ch.imu,
        "channel of imu_t samples; each scan gets those after the previous scan's time, up to "
        "its own (the first scan every earlier one); in a log, needs the clouds in time order "
        "(lcm_publish with publish_samples: <channel>_IMU); empty = none");
  d.add("gps_channel", ch.gps, "channel of gps_t samples, given to scans as imu_channel's");
  d.add("odometry_channel", ch.odometry,
        "channel of odometry_t samples, given to scans as imu_channel's");
  d.add("images_channel", ch.images,
        "channel of the image_t messages of every camera, matched to scans by frame_id and to "
        "cameras by name (lcm_publish with publish_images: <channel>_IMAGE)");
  d.add("camera_info_channel", ch.camera_info,
        "channel of the camera_info_t calibrations, one per camera and scan (lcm_publish with "
        "publish_images: <channel>_CAMERA_INFO)");
  d.add("image_truth_channel", ch.image_truth,
        "channel of per-pixel ground truth images (image_t, mono8 class ids, one per camera and "
        "scan; lcm_publish with publish_images and publish_truth: <channel>_IMAGE_TRUTH); "
        "empty = none");
  d.add("cameras", p.cameras,
        "cameras every scan carries, an image and a calibration each (e.g. [image_2]); empty = "
        "images are not read")
      .unique();
  d.add("grid_channel", ch.grid,
        "channel of terrain_grid_t grids whose layers another process computed (a feature node: "
        "lcm_publish with publish_grid), matched to scans by frame_id; every scan must have "
        "one, of the run's grid geometry; empty = the grid is built here from the points alone");
  d.add("grid_layers", p.grid_layers,
        "layers taken from those grids, which the stages after the source then read as if "
        "computed here (e.g. [height_diff, log_roughness]); '@labels' takes their label layer "
        "too (classes mapped by name; for outputs of another process's classification)")
      .unique();
  d.add("grid_origins_channel", p.grid_origins_channel,
        "channel of the layer_origins_t saying how those grids' layers were computed (lcm_publish "
        "sends one before each grid, on <channel>_ORIGINS), matched to scans by frame_id; the "
        "energy checks its model against them as against layers computed here. Empty = "
        "<grid_channel>_ORIGINS (lcm_log: when the log carries it; else the layers' origins are "
        "unknown and not checked)");
}

std::string gridOriginsChannel(const ScanChannelParams& p) {
  if (!p.grid_origins_channel.empty()) return p.grid_origins_channel;
  return p.channels.grid.empty() ? "" : p.channels.grid + "_ORIGINS";
}

void checkScanChannels(const ScanChannelParams& p) {
  const LogChannels& ch = p.channels;
  if (ch.points.empty())
    throw ParamError("points_channel", "is empty; expected e.g. TERRAMRF_GRID_POINTS");
  if (!ch.pose.empty() && ch.pose == ch.truth_pose)
    throw ParamError("truth_pose_channel",
                     "is pose_channel's (" + ch.pose +
                         "); the pose to use and the ground truth must come on different "
                         "channels, or they could not be told apart");
  if (p.cameras.empty()) {
    // Read, and then dropped: a camera left out of the list by mistake would go unnoticed.
    for (const auto& [param, channel] : {std::pair<const char*, const std::string*>{
                                             "images_channel", &ch.images},
                                         {"camera_info_channel", &ch.camera_info},
                                         {"image_truth_channel", &ch.image_truth}})
      if (!channel->empty())
        throw ParamError(param, "is " + *channel +
                                    ", but cameras lists none; name the cameras to read (e.g. "
                                    "cameras: [image_2]) or leave the channel empty");
  }
  if (!ch.grid.empty() && p.grid_layers.empty())
    throw ParamError("grid_layers", "is empty, but grid_channel is " + ch.grid +
                                        "; name the layers the stages after the source read "
                                        "from those grids (e.g. [height_diff])");
  if (ch.grid.empty() && !p.grid_layers.empty())
    throw ParamError("grid_channel", "is empty, but grid_layers lists " +
                                         std::to_string(p.grid_layers.size()) +
                                         " layer(s); expected the channel of their grids (e.g. "
                                         "TERRAMRF_GRID)");
  if (!p.grid_origins_channel.empty() && ch.grid.empty())
    throw ParamError("grid_origins_channel",
                     "is " + p.grid_origins_channel +
                         ", but grid_channel is empty; the origins describe the layers of grids "
                         "read from a grid channel");
  for (const std::string& l : p.grid_layers)
    if (l.empty() || (l[0] == '@' && l != artefacts::kLabels))
      throw ParamError("grid_layers", "lists '" + l + "'; expected layer names, or '" +
                                          artefacts::kLabels + "' for the grids' label layer");
  if (!p.cameras.empty() && ch.images.empty())
    throw ParamError("images_channel", "is empty, but cameras lists " +
                                           std::to_string(p.cameras.size()) +
                                           " camera(s); expected e.g. TERRAMRF_GRID_IMAGE");
  if (!p.cameras.empty() && ch.camera_info.empty())
    throw ParamError("camera_info_channel",
                     "is empty, but cameras lists " + std::to_string(p.cameras.size()) +
                         " camera(s) whose calibration it carries; expected e.g. "
                         "TERRAMRF_GRID_CAMERA_INFO");
}

std::vector<std::string> scanWrites(const ScanChannelParams& p) {
  std::vector<std::string> w = p.grid_layers;
  if (!p.channels.pose.empty()) w.push_back(artefacts::kPose);
  return w;
}

ScanOptions scanOptions(const ScanChannelParams& p, const LabelSet& labels, bool drop_no_return,
                        const std::string& source_path) {
  ScanOptions o;
  o.labels = &labels;
  o.pose_channel = p.channels.pose;
  o.drop_no_return = drop_no_return;
  o.source_path = source_path;
  o.cameras = p.cameras;
  o.images_channel = p.channels.images;
  o.camera_info_channel = p.channels.camera_info;
  o.grid_channel = p.channels.grid;
  o.grid_layers = p.grid_layers;
  return o;
}

}  // namespace terramrf
