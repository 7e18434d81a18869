#include "terramrf/lcm/scan_messages.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <utility>

#include "terramrf/errors.hpp"
#include "terramrf/lcm/camera_codec.hpp"
#include "terramrf/lcm/grid_codec.hpp"
#include "terramrf/lcm/labels_codec.hpp"
#include "terramrf/lcm/message_peek.hpp"
#include "terramrf/lcm/origins_codec.hpp"
#include "terramrf/lcm/pose_codec.hpp"
#include "terramrf/lcm/sensor_codec.hpp"
#include "terramrf/plugin.hpp"
#include "terramrf/text_format.hpp"

namespace terramrf {

void dropUnusablePoints(Frame& f, bool drop_no_return) {
  PointCloud& c = f.points;
  const bool labelled = !f.truth.label.empty(), raw = !f.truth.raw.empty();
  const bool rings = c.hasRing(), times = !c.time_s.empty();
  std::size_t kept = 0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    if (!std::isfinite(c.x[i]) || !std::isfinite(c.y[i]) || !std::isfinite(c.z[i]) ||
        !std::isfinite(c.intensity[i])) {
      ++f.dropped_nonfinite_points;
      continue;
    }
    if (drop_no_return && c.x[i] == 0 && c.y[i] == 0 && c.z[i] == 0) {
      ++f.dropped_no_return_points;
      continue;
    }
    c.x[kept] = c.x[i];
    c.y[kept] = c.y[i];
    c.z[kept] = c.z[i];
    c.intensity[kept] = c.intensity[i];
    if (rings) c.ring[kept] = c.ring[i];
    if (times) c.time_s[kept] = c.time_s[i];
    if (labelled) f.truth.label[kept] = f.truth.label[i];
    if (raw) f.truth.raw[kept] = f.truth.raw[i];
    ++kept;
  }
  if (kept == c.size()) return;
  c.x.resize(kept);
  c.y.resize(kept);
  c.z.resize(kept);
  c.intensity.resize(kept);
  if (rings) c.ring.resize(kept);
  if (times) c.time_s.resize(kept);
  if (labelled) f.truth.label.resize(kept);
  if (raw) f.truth.raw.resize(kept);
}

namespace {

struct Decoded {
  std::vector<std::pair<DecodedImage, std::string>> images, truths;  // with their sources
  std::vector<std::pair<DecodedCameraInfo, std::string>> infos;
};

// Messages of the listed cameras only: one of a camera not asked for is not decoded (a damaged
// one must not fail the scan). A camera name that cannot be peeked is decoded, so that the
// decoder says what is wrong with the message.
bool listed(const ScanMessage& s, const std::vector<std::string>& cameras) {
  const auto stamp = peekMessageStamp(s.bytes.data(), s.bytes.size());
  return !stamp || stamp->camera.empty() ||
         std::find(cameras.begin(), cameras.end(), stamp->camera) != cameras.end();
}

// Camera `name` of the scan: its one image_t and its one camera_info_t.
CameraImage camera(const ScanMessages& m, Decoded& d, const ScanOptions& o,
                   const std::string& name) {
  DecodedImage* image = nullptr;
  DecodedCameraInfo* info = nullptr;
  std::string image_source, info_source;
  for (auto& [img, source] : d.images) {
    if (img.camera != name) continue;
    if (image)
      throw InputError(source, "a second image_t of camera '" + name + "' for scan '" + m.id +
                                   "' (the first: " + image_source + "); expected one");
    image = &img;
    image_source = source;
  }
  for (auto& [inf, source] : d.infos) {
    if (inf.model.name != name) continue;
    if (info)
      throw InputError(source, "a second camera_info_t of camera '" + name + "' for scan '" +
                                   m.id + "' (the first: " + info_source + "); expected one");
    info = &inf;
    info_source = source;
  }
  if (!image || !info) {
    std::string missing;
    if (!image) missing = "image_t on channel " + o.images_channel;
    if (!info)
      missing += (missing.empty() ? "" : " and no ") + std::string("camera_info_t on channel ") +
                 o.camera_info_channel;
    throw InputError(m.points.source, "scan '" + m.id + "' has no " + missing + " for camera '" +
                                          name +
                                          "' (cameras lists it, so every scan needs its image "
                                          "and calibration)");
  }
  if (image->image.width != info->model.width || image->image.height != info->model.height) {
    throw InputError(image_source,
                     "image of camera '" + name + "' is " + std::to_string(image->image.width) +
                         " x " + std::to_string(image->image.height) + " px, its calibration (" +
                         info_source + (info->model.calibration.empty()
                                            ? ""
                                            : ", from " + info->model.calibration) +
                         ") is for " + std::to_string(info->model.width) + " x " +
                         std::to_string(info->model.height) + " px");
  }
  CameraImage c;
  for (auto& [truth, source] : d.truths) {
    if (truth.camera != name) continue;
    if (c.truth)
      throw InputError(source, "a second truth image of camera '" + name + "' for scan '" +
                                   m.id + "'; expected one");
    if (truth.image.channels != 1 || truth.image.width != image->image.width ||
        truth.image.height != image->image.height)
      throw InputError(source, "truth image of camera '" + name + "' is " +
                                   std::to_string(truth.image.width) + " x " +
                                   std::to_string(truth.image.height) + " x " +
                                   std::to_string(truth.image.channels) +
                                   "; expected one channel of class ids, the size of its image (" +
                                   std::to_string(image->image.width) + " x " +
                                   std::to_string(image->image.height) + ")");
    c.truth = std::make_shared<Image>(std::move(truth.image));
  }
  c.model = std::move(info->model);
  c.image = std::make_shared<Image>(std::move(image->image));
  c.source_path = image_source;
  return c;
}

// The layers of a scan's terrain_grid_t that the source declares (options.grid_layers), with its
// label layer in the run's class ids.
std::shared_ptr<const TerrainGrid> receivedGrid(const ScanMessage& g, const ScanOptions& o,
                                                const LabelSet& labels, const std::string& id) {
  DecodedGrid d = decodeGrid(g.bytes.data(), g.bytes.size(), g.source);
  // Its cells must be the scan's: a grid in a map frame would put every value on another cell.
  if (d.header.coordinate_frame != "lidar")
    throw InputError(g.source, "grid of scan '" + id + "' in frame '" + d.header.coordinate_frame +
                                   "'; expected \"lidar\", the frame of the scan's points, "
                                   "around which the run's grid is centred");
  auto grid = std::make_shared<TerrainGrid>(d.grid.geometry());
  for (const std::string& l : o.grid_layers) {
    const bool have = l == artefacts::kLabels ? d.has_labels : d.grid.has(l);
    if (!have)
      throw InputError(
          g.source,
          "terrain_grid_t of scan '" + id + "' has no " +
              (l == artefacts::kLabels ? std::string("label layer") : "layer '" + l + "'") +
              " (grid_layers lists it); its layers: " + joinNames(d.grid.layerNames()) +
              (d.has_labels ? ", and labels" : ", no labels"));
    if (l != artefacts::kLabels) grid->add(l) = std::move(d.grid.layer(l));
  }
  // Its labels only when asked for: a stage after the source that reads no '@labels' must not
  // start from another process's classification without saying so.
  if (std::find(o.grid_layers.begin(), o.grid_layers.end(), artefacts::kLabels) !=
      o.grid_layers.end()) {
    mapLabelsByName(d.grid.labels(), d.label_names, labels, g.source, "terrain_grid_t");
    grid->labels() = std::move(d.grid.labels());
  }
  return grid;
}

}  // namespace

Frame frameFromMessages(const ScanMessages& m, const ScanOptions& o) {
  static const LabelSet kDefaults = LabelSet::defaults();
  const LabelSet& labels = o.labels ? *o.labels : kDefaults;
  Frame f;
  f.id = m.id;
  f.source_path = o.source_path;
  {
    const ScanMessage& p = m.points;
    DecodedPointCloud cloud = decodePointCloud(p.bytes.data(), p.bytes.size(), p.source);
    if (cloud.header.coordinate_frame != "lidar") {
      throw InputError(p.source, "point cloud in frame '" + cloud.header.coordinate_frame +
                                     "'; expected \"lidar\" (x forward, y left, z up): the "
                                     "grid is centred on the sensor");
    }
    f.timestamp_s = cloud.header.timestamp_s;
    f.points = std::move(cloud.cloud);
  }
  if (m.labels) {
    const ScanMessage& l = *m.labels;
    f.truth = mapPointLabels(decodePointLabels(l.bytes.data(), l.bytes.size(), l.source), labels,
                             l.source);
    if (f.truth.label.size() != f.points.size()) {
      throw InputError(l.source, "point_labels_t has " + std::to_string(f.truth.label.size()) +
                                     " labels for the " + std::to_string(f.points.size()) +
                                     " points of scan '" + f.id +
                                     "'; expected one per point, in the cloud's order");
    }
  }
  if (m.pose) {
    const ScanMessage& p = *m.pose;
    setFramePose(f, decodePose(p.bytes.data(), p.bytes.size(), p.source), p.source);
  } else if (!o.pose_channel.empty()) {
    throw InputError(m.points.source, "no pose_t on channel " + o.pose_channel + " for scan '" +
                                          f.id +
                                          "'; a pose channel is read, so every scan needs its "
                                          "pose");
  }
  if (m.truth_pose) {
    const ScanMessage& t = *m.truth_pose;
    const PoseMessage p = decodePose(t.bytes.data(), t.bytes.size(), t.source);
    if (p.child_frame != "lidar")
      throw InputError(t.source, "ground-truth pose of '" + p.child_frame +
                                     "'; expected the LiDAR's (child_frame \"lidar\")");
    f.truth_pose = p.pose;
  }
  if (m.grid) {
    f.grid = receivedGrid(*m.grid, o, labels, f.id);
    if (m.grid_origins) {
      const ScanMessage& g = *m.grid_origins;
      const DecodedLayerOrigins d = decodeLayerOrigins(g.bytes.data(), g.bytes.size(), g.source);
      for (const std::string& l : o.grid_layers)
        if (const auto it = d.origins.find(l); it != d.origins.end()) f.layer_origins.insert(*it);
    }
  } else if (!o.grid_channel.empty()) {
    throw InputError(m.points.source, "no terrain_grid_t on channel " + o.grid_channel +
                                          " for scan '" + f.id +
                                          "'; a grid channel is read, so every scan needs its "
                                          "grid");
  }
  dropUnusablePoints(f, o.drop_no_return);
  for (const ScanMessage& s : m.imu)
    f.imu.push_back(decodeImu(s.bytes.data(), s.bytes.size(), s.source));
  for (const ScanMessage& s : m.gps)
    f.gps.push_back(decodeGps(s.bytes.data(), s.bytes.size(), s.source));
  for (const ScanMessage& s : m.odometry)
    f.odometry.push_back(decodeOdometry(s.bytes.data(), s.bytes.size(), s.source));
  if (!o.cameras.empty()) {
    Decoded d;  // each message decoded once, whatever the number of cameras
    for (const ScanMessage& s : m.images)
      if (listed(s, o.cameras))
        d.images.emplace_back(decodeImage(s.bytes.data(), s.bytes.size(), s.source), s.source);
    for (const ScanMessage& s : m.camera_infos)
      if (listed(s, o.cameras))
        d.infos.emplace_back(decodeCameraInfo(s.bytes.data(), s.bytes.size(), s.source),
                             s.source);
    for (const ScanMessage& s : m.image_truths)
      if (listed(s, o.cameras))
        d.truths.emplace_back(decodeImage(s.bytes.data(), s.bytes.size(), s.source), s.source);
    for (const std::string& name : o.cameras) f.cameras.push_back(camera(m, d, o, name));
  }
  // In time order, as the other sources give them, whatever order the publishers' messages came
  // in.
  const auto byTime = [](const auto& a, const auto& b) { return a.t_s < b.t_s; };
  std::stable_sort(f.imu.begin(), f.imu.end(), byTime);
  std::stable_sort(f.gps.begin(), f.gps.end(), byTime);
  std::stable_sort(f.odometry.begin(), f.odometry.end(), byTime);
  return f;
}

}  // namespace terramrf
