// Source plugin "semantickitti": KITTI odometry / SemanticKITTI sequences and KITTI object
// `training` folders (velodyne .bin, optional .label, calib, poses, image_2 / image_3 / …).
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

#include "terramrf/adapters/opencv_image.hpp"
#include "terramrf/io/calibration_check.hpp"
#include "terramrf/io/kitti.hpp"
#include "terramrf/io/label_map.hpp"
#include "terramrf/io/ring_recovery.hpp"
#include "terramrf/io/sensor_origin.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {
namespace {

class SemanticKittiSource : public Source {
 public:
  void declare(ParamDecl& d) override {
    d.add("path", path_,
          "sequence folder (holding velodyne/), dataset root with sequences/NN/, or KITTI object "
          "training folder (velodyne/, image_2/, calib/)")
        .required()
        .existingPath();
    d.add("sequence", sequence_,
          "sequence NN under <path>/sequences (empty: the only one). With a sequence folder as "
          "path it must be empty or that folder's name; with an object folder, empty");
    d.add("label_map", label_map_,
          "label-map YAML for labels/*.label (empty: configs/label_maps/semantickitti.yaml)")
        .existingPath();
    d.add("use_labels", use_labels_, "read labels/<id>.label when it exists");
    d.add("use_images", use_images_,
          "read each of `cameras` (<camera>/<id>.png) with its calibration (missing files are "
          "errors)");
    d.add("cameras", cameras_,
          "with use_images: the camera folders to read, each projected with its own P "
          "(image_0 … image_3: P0 … P3; KITTI's colour pair is image_2, image_3)")
        .unique();
    d.add("image_size", image_size_,
          "with use_images: [width, height] of the images the calibration was made for; another "
          "size is an error. Empty: not checked exactly (the files store no size), but the "
          "principal point must lie within 10 % of the width and height of the image's centre")
        .unit("px");
    d.add("use_poses", use_poses_,
          "LiDAR pose and truth pose from poses.txt (Tr^-1 P Tr with Tr from calib.txt) when the "
          "file exists");
    d.add("drop_no_return", drop_no_return_, "drop points exactly at (0, 0, 0) (counted)");
    d.add("recentre", recentre_,
          "none, or auto: estimate the sensor origin from the innermost ground ring and move the "
          "cloud so the sensor is at (0, 0) (Open3D-ML scan 000700 is stored ~100 m off)")
        .choices({"none", "auto"});
    d.add("recentre_min_m", recentre_min_m_,
          "auto recentring only applies shifts longer than this (the estimate is good to ~0.3 m)")
        .unit("m")
        .range(0, 1000);
    d.add("ring_method", ring_method_,
          "auto: rings/<id>.bin when it exists (simulated sequences), else recover; recover: "
          "scan order, elevation binning when the order carries no rings; elevation: always bin "
          "by elevation; none: leave rings empty")
        .choices({"auto", "recover", "elevation", "none"});
    d.add("rings", rings_, "lasers of the sensor (HDL-64E: 64)").unit("1").range(1, 1024);
    d.add("ring_z_offset_m", ring_z_offset_m_,
          "laser origin above the cloud origin for elevation binning (KITTI HDL-64E: 0.2)")
        .unit("m")
        .range(-5, 5);
  }

  void configure(const PluginContext& ctx) override {
    camera_index_.clear();
    if (use_images_ && cameras_.empty())
      throw ParamError("cameras", "is empty; expected at least one, e.g. [image_2]");
    for (const std::string& c : cameras_) {
      const bool known =
          c.size() == 7 && c.compare(0, 6, "image_") == 0 && c[6] >= '0' && c[6] <= '3';
      if (!known)
        throw ParamError("cameras", "unknown camera '" + c +
                                        "'; expected image_0, image_1, image_2 or image_3 (the "
                                        "calibration holds P0 … P3)");
      camera_index_.push_back(c[6] - '0');
    }
    layout_ = resolveKittiLayout(path_, sequence_);
    expected_image_size_ = imageSizeParam(image_size_);
    if (layout_.stems.empty())
      throw ParamError("path", "no .bin scans in '" + layout_.root + "/velodyne'");
    const LabelSet defaults = LabelSet::defaults();
    const LabelSet& labels = ctx.labels ? *ctx.labels : defaults;
    map_.reset();
    if (use_labels_) {
      const std::string file =
          label_map_.empty() ? shippedLabelMap("semantickitti.yaml") : label_map_;
      try {
        map_ = std::make_unique<LabelMap>(LabelMap::load(file, labels));
      } catch (const InputError& e) {
        throw ParamError("label_map", e.what());
      }
      // The file actually read, so resolved configs and model provenance name it, not "".
      label_map_ = file;
    }
    poses_.clear();
    times_.clear();
    calib_.reset();
    if (use_poses_ && !layout_.poses_file.empty()) {
      try {
        poses_ = readKittiPoses(layout_.poses_file);
      } catch (const InputError& e) {
        throw ParamError("use_poses", e.what());
      }
    }
    if (!layout_.times_file.empty()) {
      try {
        times_ = readKittiTimes(layout_.times_file);
      } catch (const InputError& e) {
        throw ParamError("path", e.what());
      }
    }
    ring_options_.rings = rings_;
    ring_options_.use_scan_order = ring_method_ != "elevation";
    ring_options_.z_offset_m = ring_z_offset_m_;
    ring_options_.measure_consistency = false;  // the rings are all a reader needs
    warned_ring_fallback_ = false;
  }

  std::size_t size() const override { return layout_.stems.size(); }
  std::string frameId(std::size_t i) const override { return layout_.stems.at(i); }

  /// The camera models are named after their folders (image_2 …).
  std::vector<std::string> cameraNames() const override {
    return use_images_ ? cameras_ : std::vector<std::string>{};
  }

  /// With a poses.txt read, every frame has its pose: one past the file's end is an InputError,
  /// never a frame without one. Stages that read the pose are checked against this.
  std::vector<std::string> writes() const override {
    return poses_.empty() ? std::vector<std::string>{} : std::vector<std::string>{artefacts::kPose};
  }

  Frame read(std::size_t i) override {
    if (i >= size())
      throw std::out_of_range("semantickitti: frame " + std::to_string(i) + " of " +
                              std::to_string(size()));
    Frame f;
    f.id = layout_.stems[i];
    f.source_path = layout_.scanPath(i);
    const ScanReadInfo info = readKittiScan(f.source_path, f.points, drop_no_return_);
    f.dropped_nonfinite_points = info.dropped_nonfinite;
    f.dropped_no_return_points = info.dropped_no_return;
    const std::string label_path = layout_.labelPath(i);
    if (map_ && std::filesystem::exists(label_path))
      readKittiLabels(label_path, f.source_path, info, map_.get(), f.truth);

    const long frame_no = frameNumber(f.id);
    if (!layout_.times_file.empty()) {
      // Line i is frame i. A frame past the end must not fall back to i × 0.1 s: that is another
      // time base than the file's (often seconds since the recording started, or epoch).
      if (frame_no < 0 || std::size_t(frame_no) >= times_.size())
        throw InputError(layout_.times_file,
                         "has " + std::to_string(times_.size()) +
                             " time(s), one per line, but frame " + f.id +
                             (frame_no < 0 ? " is not a frame number (no line of its own)"
                                           : " needs line " + std::to_string(frame_no + 1)) +
                             "; expected a time for every frame of the sequence");
      f.timestamp_s = times_[frame_no];
    } else if (layout_.kind == KittiLayout::Kind::kSequence && frame_no >= 0) {
      f.timestamp_s = 0.1 * frame_no;  // KITTI sweeps at 10 Hz
    }

    if (!poses_.empty()) {
      if (frame_no < 0 || std::size_t(frame_no) >= poses_.size())
        throw InputError(layout_.poses_file, "has " + std::to_string(poses_.size()) +
                                                 " poses; frame " + f.id + " has none");
      // The dataset's reference poses (KITTI's GPS/IMU, SemanticKITTI's SLAM-refined ones): the
      // truth an egomotion estimate is scored against, and `pose` until one replaces it.
      f.truth_pose = kittiLidarPose(poses_[frame_no], calib(i).T_cam_velo);
      f.pose = f.truth_pose;
    }
    for (std::size_t c = 0; use_images_ && c < cameras_.size(); ++c) {
      const std::string img = layout_.imagePath(i, cameras_[c]);
      if (!std::filesystem::exists(img))
        throw InputError(img, "camera image missing (use_images is on)");
      CameraImage cam;
      auto image = std::make_shared<Image>(readImage(img));
      cam.model = kittiCamera(calib(i), camera_index_[c], image->width, image->height);
      cam.image = std::move(image);
      cam.source_path = img;
      checkCalibrationFitsImage(cam, expected_image_size_);
      f.cameras.push_back(std::move(cam));
    }

    const std::string ring_file = layout_.ringPath(i);
    const bool rings_from_file = ring_method_ == "auto" && std::filesystem::exists(ring_file);
    if (rings_from_file) readKittiRings(ring_file, f.source_path, info, f.points);

    if (recentre_ == "auto") recentreOnSensor(f, recentre_min_m_, "semantickitti");
    if (ring_method_ != "none" && !rings_from_file) {
      const RingRecoveryStats st = recoverRings(f.points, ring_options_);
      if (st.method != RingMethod::kScanOrder && !warned_ring_fallback_ && !f.points.empty()) {
        warned_ring_fallback_ = true;
        std::fprintf(stderr, "semantickitti: %s: %s; rings %s\n", f.source_path.c_str(),
                     st.fallback_reason.c_str(),
                     st.method == RingMethod::kElevation ? "binned by elevation" : "left unknown");
      }
    }
    return f;
  }

 private:
  static long frameNumber(const std::string& stem) {
    char* end = nullptr;
    const long v = std::strtol(stem.c_str(), &end, 10);
    return (end && *end == 0 && !stem.empty()) ? v : -1;
  }

  /// Calibration of frame i (one file per sequence, or per frame for the object layout).
  const KittiCalib& calib(std::size_t i) {
    const std::string path = layout_.calibPath(i);
    if (!calib_ || calib_->path != path) {
      if (!std::filesystem::exists(path))
        throw InputError(path, "calibration missing (needed for " +
                                   std::string(use_images_ ? "the cameras" : "the LiDAR pose") +
                                   ")");
      calib_ = std::make_unique<KittiCalib>(readKittiCalib(path));
    }
    return *calib_;
  }

  std::string path_;
  std::string sequence_;
  std::string label_map_;
  bool use_labels_ = true;
  bool use_images_ = false;
  std::vector<std::string> cameras_{"image_2"};
  std::vector<double> image_size_;
  bool use_poses_ = true;
  bool drop_no_return_ = true;
  std::string recentre_ = "none";
  double recentre_min_m_ = 1.0;
  std::string ring_method_ = "auto";
  int rings_ = 64;
  double ring_z_offset_m_ = 0.2;

  std::vector<int> camera_index_;  ///< P index of each of cameras_
  KittiLayout layout_;
  std::optional<ImageSize> expected_image_size_;
  std::unique_ptr<LabelMap> map_;
  std::vector<Eigen::Isometry3d> poses_;
  std::vector<double> times_;
  std::unique_ptr<KittiCalib> calib_;
  RingRecoveryOptions ring_options_;
  bool warned_ring_fallback_ = false;
};

}  // namespace
}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::SemanticKittiSource, terramrf::PluginKind::kSource, "semantickitti",
                "KITTI odometry / SemanticKITTI sequences and KITTI object folders (.bin, .label, "
                "calib, poses, image_2 / image_3)")
