#pragma once
// KITTI / SemanticKITTI file formats and folder layouts, shared by the semantickitti source, the
// RELLIS-3D source (same .bin/.label formats) and tools.
//
// Formats: velodyne *.bin = little-endian float32 quadruples x, y, z [m], intensity; *.label =
// uint32 per point, semantic id = low 16 bits, instance = high 16 bits; calib.txt in the odometry
// variant (P0..P3, Tr) or the object variant (P0..P3, R0_rect, Tr_velo_to_cam, Tr_imu_to_velo),
// of which only the transform and the P of each camera read are required;
// poses.txt = one row-major 3×4 camera-0 pose per line.
#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "terramrf/camera.hpp"
#include "terramrf/frame.hpp"
#include "terramrf/io/label_map.hpp"
#include "terramrf/point_cloud.hpp"

namespace terramrf {

/// What readKittiScan kept and dropped; label files and organised ring layouts use it to drop the
/// same points.
struct ScanReadInfo {
  std::size_t raw_points = 0;         ///< points stored in the file (file size / 16)
  std::size_t dropped_nonfinite = 0;  ///< NaN/inf in x, y, z or intensity
  std::size_t dropped_no_return = 0;  ///< exactly (0, 0, 0): sensors store no-returns there
  std::vector<uint32_t> dropped;      ///< raw indices of all dropped points, ascending
  std::size_t droppedTotal() const { return dropped.size(); }
};

/// Reads a KITTI .bin scan into `cloud` (replacing its content; ring and time_s left empty).
/// Non-finite points, and points exactly at the origin if `drop_no_return`, are dropped and
/// counted. An empty file is a valid empty scan. Throws InputError naming the file if it cannot
/// be read or its size is not a multiple of 16 bytes.
ScanReadInfo readKittiScan(const std::string& bin_path, PointCloud& cloud,
                           bool drop_no_return = true);

/// Reads a .label file that belongs to `scan_path` read with `info`. Checks the label count
/// against the scan's count before dropping (InputError naming both files and both counts), then
/// drops the labels of dropped points. truth.raw = low 16 bits; truth.label = map(raw) when `map`
/// is given (unlisted id: InputError naming map, id and label file), else left empty.
void readKittiLabels(const std::string& label_path, const std::string& scan_path,
                     const ScanReadInfo& info, const LabelMap* map, PointLabels& truth);

/// Reads rings/<id>.bin (uint16 per raw point, 0 = top beam; written by KittiSequenceWriter for
/// simulated scans, not part of KITTI) into cloud.ring, dropping the entries of dropped points.
/// A count different from the scan's is an InputError naming both files and counts.
void readKittiRings(const std::string& ring_path, const std::string& scan_path,
                    const ScanReadInfo& info, PointCloud& cloud);

/// Removes the entries at the (ascending) raw indices `dropped`, keeping order.
template <class T>
void eraseIndices(std::vector<T>& v, const std::vector<uint32_t>& dropped) {
  if (dropped.empty()) return;
  std::size_t out = 0, d = 0;
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (d < dropped.size() && dropped[d] == i) {
      ++d;
      continue;
    }
    v[out++] = v[i];
  }
  v.resize(out);
}

using Matrix34d = Eigen::Matrix<double, 3, 4>;

struct KittiCalib {
  std::string path;
  bool object_format = false;  ///< has R0_rect / Tr_velo_to_cam (object benchmark)
  std::map<std::string, std::vector<double>> entries;  ///< every "KEY: numbers" line
  Matrix34d P[4];  ///< rectified projection matrices of cameras 0..3 (zero where has_P is false)
  bool has_P[4] = {false, false, false, false};  ///< the file has a 'Pi:' entry
  /// LiDAR -> rectified camera-0 frame: object R0_rect · Tr_velo_to_cam; odometry Tr (KITTI
  /// odometry's P_i already project from the rectified camera-0 frame).
  Eigen::Isometry3d T_cam_velo = Eigen::Isometry3d::Identity();
};

/// Reads calib.txt in either variant. Required: the LiDAR→camera transform (Tr, or R0_rect and
/// Tr_velo_to_cam); P0..P3 are read where present (has_P) and only required by kittiCamera for
/// the camera asked for. Throws InputError naming the file for a missing file, a missing
/// transform, an entry with the wrong number count (a P that is there included) or a word.
KittiCalib readKittiCalib(const std::string& path);

/// Camera model of camera `index` (2 = image_2, the left colour camera; 3 = image_3, the right
/// one): P = P_index, T_camera_lidar = calib.T_cam_velo, size [px] from the image (calib.txt
/// stores none; see checkCalibrationFitsImage), calibration = "<path> (P2, R0_rect,
/// Tr_velo_to_cam)" or "(P2, Tr)". A P_index that also rotates (left 3×3 not upper triangular)
/// is split into K [I | 0] and a camera-0 → camera transform folded into T_camera_lidar; a
/// singular one, or none in the file (has_P false), is an InputError naming the file.
CameraModel kittiCamera(const KittiCalib& calib, int index, int width_px, int height_px);

/// poses.txt: camera-0 poses (T_world_cam0), one per line. Throws InputError naming the file and
/// the line for a line that is not 12 numbers.
std::vector<Eigen::Isometry3d> readKittiPoses(const std::string& path);

/// LiDAR pose from a KITTI camera-0 pose: Tr⁻¹ · P · Tr, Tr = LiDAR -> camera-0.
Eigen::Isometry3d kittiLidarPose(const Eigen::Isometry3d& cam0_pose, const Eigen::Isometry3d& Tr);

/// times.txt: one timestamp [s] per line.
std::vector<double> readKittiTimes(const std::string& path);

/// Where the files of a KITTI-style dataset are. Frames are velodyne/*.bin in natural name order
/// (naturalLess: 9.bin before 10.bin).
struct KittiLayout {
  enum class Kind { kSequence, kObject };
  Kind kind = Kind::kSequence;
  std::string root;                ///< folder holding velodyne/
  std::string calib_file;          ///< sequence: calib.txt (may not exist)
  std::string poses_file;          ///< sequence: poses.txt or <dataset>/poses/NN.txt; "" if none
  std::string times_file;          ///< sequence: times.txt; "" if none
  std::vector<std::string> stems;  ///< frame ids (file stems), in natural order

  std::string scanPath(std::size_t i) const;
  std::string labelPath(std::size_t i) const;  ///< labels/<stem>.label (may not exist)
  /// <camera>/<stem>.png, e.g. image_2/000000.png (may not exist)
  std::string imagePath(std::size_t i, const std::string& camera = "image_2") const;
  std::string ringPath(std::size_t i) const;   ///< rings/<stem>.bin (may not exist)
  std::string calibPath(std::size_t i) const;  ///< object: calib/<stem>.txt, else calib_file
};

/// Accepts a sequence folder (holding velodyne/), a dataset root with sequences/NN/ (`sequence`
/// picks NN; may be empty when there is just one), a KITTI object `training` folder (velodyne/,
/// image_2/, calib/) or its parent. Throws ParamError("path" or "sequence", ...) otherwise, and
/// ParamError("sequence") for a non-empty `sequence` with a sequence folder of another name (a
/// sequence folder "00" takes "", "00" or "0") or with an object folder.
KittiLayout resolveKittiLayout(const std::string& path, const std::string& sequence);

}  // namespace terramrf
