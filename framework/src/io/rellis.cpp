#include "terramrf/io/rellis.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <vector>

#include "fs_checks.hpp"
#include "terramrf/errors.hpp"
#include "terramrf/io/natural_order.hpp"
#include "terramrf/yaml_keys.hpp"
#include "text_numbers.hpp"

namespace terramrf {
namespace fs = std::filesystem;
namespace {

bool allDigits(const std::string& s) {
  return !s.empty() &&
         std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c); });
}

using io_detail::isDir;
using io_detail::isFile;

/// A frame number without its zero padding ("000104" → "104", "0000" → "0"): image and scan
/// names pad differently, and numbers too long for an integer must still compare.
std::string frameNumber(const std::string& digits) {
  const std::size_t first = digits.find_first_not_of('0');
  return first == std::string::npos ? "0" : digits.substr(first);
}

/// frame<id>-<stamp>.<ext> files of `dir`, keyed by frameNumber(id). Two files of one frame
/// (frame104-….jpg and frame000104-….jpg, or two stamps) are an error: which one a frame got
/// depended on the order the file system lists the folder in.
std::map<std::string, std::string> cameraFiles(const fs::path& dir, const std::string& ext,
                                               const std::string& what) {
  std::map<std::string, std::string> out;
  if (!isDir(dir)) return out;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!e.is_regular_file() || e.path().extension() != ext) continue;
    const std::string stem = e.path().stem().string();
    if (stem.rfind("frame", 0) != 0) continue;
    const auto dash = stem.find('-');
    const std::string id = stem.substr(5, dash == std::string::npos ? std::string::npos : dash - 5);
    if (!allDigits(id)) continue;
    const auto [it, added] = out.emplace(frameNumber(id), e.path().string());
    if (added) continue;
    // Named in a fixed order, whichever the folder listed first.
    const std::string a = std::min(it->second, e.path().string());
    const std::string b = std::max(it->second, e.path().string());
    throw ParamError("path", "'" + a + "' and '" + b + "' are both " + what + " of frame " +
                                 it->first +
                                 "; expected one per frame number (frame<number>-<stamp>" + ext +
                                 ", the number's zero padding ignored): remove one");
  }
  return out;
}

std::string firstExisting(const std::vector<fs::path>& candidates) {
  for (const auto& c : candidates)
    if (isFile(c)) return c.string();
  return "";
}

}  // namespace

RellisLayout resolveRellisLayout(const std::string& path) {
  const fs::path p(path);
  if (!isDir(p)) throw ParamError("path", "'" + path + "' is not a folder");
  RellisLayout L;
  L.root = p.string();
  fs::path scans = p, labels = p, images = p, image_labels = p;
  if (isDir(p / "os1_cloud_node_kitti_bin")) {
    scans = p / "os1_cloud_node_kitti_bin";
    labels = p / "os1_cloud_node_semantickitti_label_id";
    images = p / "pylon_camera_node";
    image_labels = p / "pylon_camera_node_label_id";
  }
  const auto jpgs = cameraFiles(images, ".jpg", "images");
  const auto pngs = cameraFiles(image_labels, ".png", "image labels");
  for (const auto& e : fs::directory_iterator(scans)) {
    if (!e.is_regular_file() || e.path().extension() != ".bin") continue;
    const std::string id = e.path().stem().string();
    if (!allDigits(id)) continue;
    RellisFrameFiles f;
    f.id = id;
    f.scan = e.path().string();
    const fs::path lab = labels / (id + ".label");
    if (isFile(lab)) f.label = lab.string();
    // Image file names carry the frame number without zero padding rules fixed: match by value.
    if (auto it = jpgs.find(frameNumber(id)); it != jpgs.end()) f.image = it->second;
    if (auto it = pngs.find(frameNumber(id)); it != pngs.end()) f.image_label = it->second;
    L.frames.push_back(std::move(f));
  }
  // Natural order: the full release pads ids to six digits, but other copies need not.
  std::sort(
      L.frames.begin(), L.frames.end(),
      [](const RellisFrameFiles& a, const RellisFrameFiles& b) { return naturalLess(a.id, b.id); });
  if (L.frames.empty())
    throw ParamError("path", "no RELLIS-3D scans (NNNNNN.bin) in '" + scans.string() + "'");
  L.camera_info = firstExisting({p / "camera_info.txt", p.parent_path() / "camera_info.txt"});
  L.transforms = firstExisting({p / "transforms.yaml", p.parent_path() / "transforms.yaml"});
  return L;
}

void organisedRings(PointCloud& cloud, const ScanReadInfo& info, int rings,
                    const std::string& scan_path) {
  const std::string layout =
      "organised scan of " + std::to_string(rings) + " rings stored column by column";
  if (rings < 1 || info.raw_points % std::size_t(rings) != 0)
    throw InputError(scan_path, std::to_string(info.raw_points) +
                                    " points is not a whole number of columns; expected an " +
                                    layout + " (RELLIS-3D Ouster: 2048 columns x 64 rings)");
  cloud.ring.resize(cloud.size());
  std::size_t out = 0, d = 0;
  for (std::size_t i = 0; i < info.raw_points && out < cloud.ring.size(); ++i) {
    if (d < info.dropped.size() && info.dropped[d] == i) {
      ++d;
      continue;
    }
    cloud.ring[out++] = static_cast<uint16_t>(i % rings);
  }
  // A whole number of columns does not make a scan organised. In one that is, a ring is one beam
  // and its returns share an elevation (000104: < 1e-5° per ring); any other order — a Velodyne
  // scan in firing order, an Ouster scan stored ring by ring — mixes beams in every "ring" (tens
  // of degrees). The spread of z / ρ (tan of the elevation) per ring tells them apart for one
  // division and square root a point; no-returns at the origin have no elevation.
  std::vector<double> lo(std::size_t(rings), std::numeric_limits<double>::infinity());
  std::vector<double> hi(std::size_t(rings), -std::numeric_limits<double>::infinity());
  for (std::size_t k = 0; k < cloud.size(); ++k) {
    const double x = cloud.x[k], y = cloud.y[k], z = cloud.z[k];
    const double rho = std::sqrt(x * x + y * y);
    if (!(rho > 0)) continue;  // the origin, or straight above or below: no elevation
    const double t = z / rho;
    const uint16_t r = cloud.ring[k];
    lo[r] = std::min(lo[r], t);
    hi[r] = std::max(hi[r], t);
  }
  int worst = -1;
  double worst_deg = 0;
  for (int r = 0; r < rings; ++r) {
    if (!(hi[r] > lo[r])) continue;
    const double deg = (std::atan(hi[r]) - std::atan(lo[r])) * 180 / M_PI;
    if (deg > worst_deg) worst_deg = deg, worst = r;
  }
  if (worst_deg > kOrganisedRingSpreadDeg) {
    char spread[32], most[32];
    std::snprintf(spread, sizeof spread, "%.2f", worst_deg);
    std::snprintf(most, sizeof most, "%g", kOrganisedRingSpreadDeg);
    throw InputError(
        scan_path, "not an " + layout + ": ring " + std::to_string(worst) + " (raw index % " +
                       std::to_string(rings) + " = " + std::to_string(worst) + ") spans " + spread +
                       "° of elevation among its returns; expected at most " + most +
                       "° (one beam; "
                       "RELLIS-3D 000104: < 0.00001°). Rings from the index would mix beams: "
                       "is this a Velodyne scan (vel*.bin) or another layout, or is `rings` not "
                       "the sensor's?");
  }
}

Matrix34d readRellisIntrinsics(const std::string& path) {
  std::ifstream in(path);
  if (!isFile(path) || !in) throw InputError(path, "camera intrinsics file does not exist");
  // Every number is read: a file with more than the four (distortion coefficients, a full K)
  // would otherwise lose them silently and project with a model other than the one calibrated.
  std::vector<double> v;
  std::string line, tok;
  for (int lineno = 1; std::getline(in, line); ++lineno) {
    std::istringstream ss(line);
    while (ss >> tok) {
      const std::optional<double> x = io_detail::finiteNumber(tok);
      if (!x)
        throw InputError(path, "line " + std::to_string(lineno) + ": '" + tok +
                                   "' is not a finite number; expected 'fx fy cx cy' [px]");
      v.push_back(*x);
    }
  }
  if (v.size() != 4)
    throw InputError(path, "has " + std::to_string(v.size()) +
                               " numbers; expected exactly 4, 'fx fy cx cy' [px]" +
                               (v.size() > 4 ? " (no distortion or other entries: they would be "
                                               "dropped, and the reader has the pinhole model "
                                               "only)"
                                             : ""));
  const double fx = v[0], fy = v[1], cx = v[2], cy = v[3];
  if (fx <= 0 || fy <= 0)
    throw InputError(path, "expected 'fx fy cx cy' [px] with positive focal lengths, got fx " +
                               std::to_string(fx) + ", fy " + std::to_string(fy));
  Matrix34d P = Matrix34d::Zero();
  P(0, 0) = fx;
  P(1, 1) = fy;
  P(0, 2) = cx;
  P(1, 2) = cy;
  P(2, 2) = 1;
  return P;
}

Eigen::Isometry3d readRellisCameraFromLidar(const std::string& path) {
  if (!isFile(path)) throw InputError(path, "LiDAR-camera transform file does not exist");
  const YAML::Node root = loadUserYaml(path);
  const char* kExpected =
      "expected 'os1_cloud_node-pylon_camera_node: {q: {w, x, y, z}, t: {x, y, z}}'";
  Eigen::Quaterniond q;
  Eigen::Vector3d tr;
  try {
    if (!root.IsMap()) throw InputError(path, kExpected);
    const YAML::Node t = root["os1_cloud_node-pylon_camera_node"];
    if (!t || !t.IsMap() || !t["q"] || !t["t"]) throw InputError(path, kExpected);
    q = Eigen::Quaterniond(t["q"]["w"].as<double>(), t["q"]["x"].as<double>(),
                           t["q"]["y"].as<double>(), t["q"]["z"].as<double>());
    tr = {t["t"]["x"].as<double>(), t["t"]["y"].as<double>(), t["t"]["z"].as<double>()};
  } catch (const YAML::Exception& e) {
    throwYamlInputError(path, e, "q needs w, x, y, z and t needs x, y, z numbers");
  }
  if (!q.coeffs().allFinite() || !tr.allFinite())
    throw InputError(path, "q and t must be finite numbers (found NaN or inf)");
  if (std::abs(q.norm() - 1.0) > 1e-3)
    throw InputError(path, "quaternion norm " + std::to_string(q.norm()) + " is not 1");
  Eigen::Isometry3d camera_in_lidar = Eigen::Isometry3d::Identity();
  camera_in_lidar.linear() = q.normalized().toRotationMatrix();
  camera_in_lidar.translation() = tr;
  return camera_in_lidar.inverse();
}

CameraModel rellisCamera(const std::string& camera_info, const std::string& transforms,
                         int width_px, int height_px) {
  CameraModel m;
  m.name = "pylon_camera";
  m.width = width_px;
  m.height = height_px;
  m.P = readRellisIntrinsics(camera_info);
  m.T_camera_lidar = readRellisCameraFromLidar(transforms);
  m.calibration =
      camera_info + " (fx fy cx cy) and " + transforms + " (os1_cloud_node-pylon_camera_node)";
  return m;
}

}  // namespace terramrf
