#include "terramrf/lcm/scan_channels.hpp"

#include <utility>

#include "terramrf/errors.hpp"

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
  return o;
}

}  // namespace terramrf
