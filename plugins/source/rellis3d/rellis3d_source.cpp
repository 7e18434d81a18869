// Source plugin "rellis3d": RELLIS-3D off-road frames (Ouster OS1-64 scan + labels, camera image
// + pixel labels, intrinsics, LiDAR-camera extrinsics).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "terramrf/adapters/opencv_image.hpp"
#include "terramrf/io/calibration_check.hpp"
#include "terramrf/io/kitti.hpp"
#include "terramrf/io/label_map.hpp"
#include "terramrf/io/rellis.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {
namespace {

/// "frame000104-1581624663_149.jpg" -> 1581624663.149 [s]; -1 if the name carries no stamp.
double stampFromImageName(const std::string& path) {
  const std::string stem = std::filesystem::path(path).stem().string();
  const auto dash = stem.find('-');
  if (dash == std::string::npos) return -1;
  std::string s = stem.substr(dash + 1);
  const auto us = s.find('_');
  if (us == std::string::npos) return -1;
  try {
    return std::stod(s.substr(0, us)) + std::stod("0." + s.substr(us + 1));
  } catch (const std::exception&) {
    return -1;
  }
}

class Rellis3dSource : public Source {
 public:
  void declare(ParamDecl& d) override {
    d.add(
         "path", path_,
         "folder with NNNNNN.bin/.label, frameNNNNNN-*.jpg/.png, camera_info.txt, "
         "transforms.yaml, or a sequence folder of the full release (os1_cloud_node_kitti_bin/...)")
        .required()
        .existingPath();
    d.add("label_map", label_map_,
          "label-map YAML for scan and pixel labels (empty: configs/label_maps/rellis3d.yaml)")
        .existingPath();
    d.add("use_labels", use_labels_, "read <id>.label when it exists");
    d.add("use_images", use_images_,
          "read the camera image with camera_info.txt and transforms.yaml (missing files are "
          "errors)");
    d.add("image_size", image_size_,
          "with use_images: [width, height] of the images the calibration was made for; another "
          "size is an error. Empty: not checked exactly (the files store no size), but the "
          "principal point must lie within 10 % of the width and height of the image's centre")
        .unit("px");
    d.add("use_image_labels", use_image_labels_,
          "with use_images: map the pixel label image (when it exists) into the camera's truth");
    d.add("drop_no_return", drop_no_return_,
          "drop points exactly at (0, 0, 0): Ouster no-returns (~52k of 131k in 000104), counted");
    d.add("rings", rings_,
          "rings of the organised scan, stored column by column: ring = index % rings")
        .unit("1")
        .range(1, 1024);
  }

  void configure(const PluginContext& ctx) override {
    layout_ = resolveRellisLayout(path_);
    stamped_.clear();
    for (const RellisFrameFiles& fr : layout_.frames) {
      const double stamp = fr.image.empty() ? -1 : stampFromImageName(fr.image);
      if (stamp >= 0) stamped_.emplace_back(std::atof(fr.id.c_str()), stamp);
    }
    expected_image_size_ = imageSizeParam(image_size_);
    const LabelSet defaults = LabelSet::defaults();
    const LabelSet& labels = ctx.labels ? *ctx.labels : defaults;
    map_.reset();
    if (use_labels_ || (use_images_ && use_image_labels_)) {
      const std::string file = label_map_.empty() ? shippedLabelMap("rellis3d.yaml") : label_map_;
      try {
        map_ = std::make_unique<LabelMap>(LabelMap::load(file, labels));
      } catch (const InputError& e) {
        throw ParamError("label_map", e.what());
      }
      // The file actually read, so resolved configs and model provenance name it, not "".
      label_map_ = file;
    }
  }

  std::size_t size() const override { return layout_.frames.size(); }
  std::string frameId(std::size_t i) const override { return layout_.frames.at(i).id; }

  /// rellisCamera names its one camera so.
  std::vector<std::string> cameraNames() const override {
    return use_images_ ? std::vector<std::string>{"pylon_camera"} : std::vector<std::string>{};
  }

  Frame read(std::size_t i) override {
    if (i >= size())
      throw std::out_of_range("rellis3d: frame " + std::to_string(i) + " of " +
                              std::to_string(size()));
    const RellisFrameFiles& files = layout_.frames[i];
    Frame f;
    f.id = files.id;
    f.source_path = files.scan;
    const ScanReadInfo info = readKittiScan(files.scan, f.points, drop_no_return_);
    f.dropped_nonfinite_points = info.dropped_nonfinite;
    f.dropped_no_return_points = info.dropped_no_return;
    organisedRings(f.points, info, rings_, files.scan);  // checks the scan is organised
    if (use_labels_ && !files.label.empty())
      readKittiLabels(files.label, files.scan, info, map_.get(), f.truth);
    f.timestamp_s = frameTime(files);
    if (use_images_) {
      if (files.image.empty())
        throw InputError(
            (std::filesystem::path(layout_.root) / ("frame" + files.id + "-*.jpg")).string(),
            "camera image missing (use_images is on)");
      const std::string info_file =
          layout_.camera_info.empty() ? layout_.root + "/camera_info.txt" : layout_.camera_info;
      const std::string tf_file =
          layout_.transforms.empty() ? layout_.root + "/transforms.yaml" : layout_.transforms;
      CameraImage cam;
      auto image = std::make_shared<Image>(readImage(files.image));
      cam.model = rellisCamera(info_file, tf_file, image->width, image->height);
      cam.source_path = files.image;
      cam.image = image;
      checkCalibrationFitsImage(cam, expected_image_size_);
      if (use_image_labels_ && !files.image_label.empty()) {
        const Image raw = readImage(files.image_label);
        if (raw.channels != 1 || raw.width != image->width || raw.height != image->height)
          throw InputError(files.image_label,
                           "expected a 1-channel label image of " + std::to_string(image->width) +
                               "x" + std::to_string(image->height) + " px, got " +
                               std::to_string(raw.channels) + " channels " +
                               std::to_string(raw.width) + "x" + std::to_string(raw.height));
        auto truth = std::make_shared<Image>(raw.width, raw.height, 1);
        map_->mapAll(raw.data.data(), raw.data.size(), truth->data.data(), files.image_label);
        cam.truth = std::move(truth);
      }
      f.cameras.push_back(std::move(cam));
    }
    return f;
  }

 private:
  /// One time base per sequence. The image names carry the recording's epoch time; a frame
  /// without an image is placed from the nearest frame (by number; the earlier on a tie) that has
  /// one, at the Ouster's 10 Hz. Only when no frame has a stamped image is the base id × 0.1 s.
  /// (Each frame on its own base put image-less frames ~1.6e9 s from their neighbours.)
  double frameTime(const RellisFrameFiles& files) const {
    const double stamp = files.image.empty() ? -1 : stampFromImageName(files.image);
    if (stamp >= 0) return stamp;
    const double id = std::atof(files.id.c_str());
    if (stamped_.empty()) return 0.1 * id;
    const std::pair<double, double>* nearest = &stamped_.front();
    for (const auto& s : stamped_)
      if (std::abs(s.first - id) < std::abs(nearest->first - id)) nearest = &s;
    return nearest->second + 0.1 * (id - nearest->first);
  }

  std::string path_;
  std::string label_map_;
  bool use_labels_ = true;
  bool use_images_ = false;
  std::vector<double> image_size_;
  bool use_image_labels_ = true;
  bool drop_no_return_ = true;
  int rings_ = 64;

  RellisLayout layout_;
  std::vector<std::pair<double, double>> stamped_;  ///< frame number, image stamp [s]
  std::optional<ImageSize> expected_image_size_;
  std::unique_ptr<LabelMap> map_;
};

}  // namespace
}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::Rellis3dSource, terramrf::PluginKind::kSource, "rellis3d",
                "RELLIS-3D frames: organised Ouster scan + labels, camera image + pixel labels, "
                "calibration")
