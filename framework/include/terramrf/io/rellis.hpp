#pragma once
// RELLIS-3D (Ouster OS1-64 + Basler camera, off-road). Scans and labels use the KITTI .bin /
// SemanticKITTI .label formats (kitti.hpp); this adds the layout, the organised ring order and
// the camera calibration files.
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "terramrf/camera.hpp"
#include "terramrf/io/kitti.hpp"

namespace terramrf {

struct RellisFrameFiles {
  std::string id;           ///< scan stem, e.g. "000104"
  std::string scan;         ///< <id>.bin
  std::string label;        ///< <id>.label ("" if absent)
  std::string image;        ///< frame<id>-<stamp>.jpg ("" if absent)
  std::string image_label;  ///< frame<id>-<stamp>.png, RELLIS ids per pixel ("" if absent)
};

struct RellisLayout {
  std::string root;
  std::string camera_info;               ///< camera_info.txt ("" if absent)
  std::string transforms;                ///< transforms.yaml ("" if absent)
  std::vector<RellisFrameFiles> frames;  ///< by id in natural order (9 before 10)
};

/// Accepts the flat example layout (NNNNNN.bin, NNNNNN.label, frameNNNNNN-*.jpg/.png,
/// camera_info.txt, transforms.yaml in one folder) or a sequence folder of the full release
/// (os1_cloud_node_kitti_bin/, os1_cloud_node_semantickitti_label_id/, pylon_camera_node/,
/// pylon_camera_node_label_id/; calibration files in the folder or its parent). Scans whose stem
/// is not all digits (vel000104.bin, the Velodyne scan) are not frames. Throws ParamError("path").
RellisLayout resolveRellisLayout(const std::string& path);

/// Largest elevation spread [°] of the returns of one ring that organisedRings accepts: far above
/// an organised scan's (000104: < 1e-5°; beam-origin offsets add < 0.3° beyond 1 m) and far
/// below a scan in another order's (VLP-32C vel000104.bin cut to 64-point columns: 35–40°).
constexpr double kOrganisedRingSpreadDeg = 2.0;

/// Ring of each kept point of an organised scan stored column by column (`rings` values per
/// azimuth column, top beam first): ring = raw index % rings. RELLIS Ouster scans are 2048
/// columns × 64 rings in this order (checked on 000104: elevation spread within a ring ~1e-6°).
/// Checked, InputError naming `scan_path`: the raw point count is a whole number of columns, and
/// the scan is organised — per ring, the elevation spread of its returns (no-returns at the
/// origin ignored) is at most kOrganisedRingSpreadDeg; the error names the worst ring.
void organisedRings(PointCloud& cloud, const ScanReadInfo& info, int rings,
                    const std::string& scan_path);

/// camera_info.txt: "fx fy cx cy" [px] -> P = K [I | 0]. Exactly four finite numbers (the
/// release's file has just these, no distortion); more (distortion coefficients that would be
/// dropped), fewer, a word or non-positive focal lengths: InputError naming the file (and line).
Matrix34d readRellisIntrinsics(const std::string& path);

/// transforms.yaml: `os1_cloud_node-pylon_camera_node: {q: {w, x, y, z}, t: {x, y, z}}`. The file
/// gives the camera's pose in the LiDAR frame (checked: with it inverted, 77% of the labelled
/// points of 000104 that land in the image hit a pixel of the same class, 0% otherwise); returns
/// T_camera_lidar. Throws InputError naming the file.
Eigen::Isometry3d readRellisCameraFromLidar(const std::string& path);

/// Camera model "pylon_camera" from the two calibration files and the image size [px] (the files
/// store none; see checkCalibrationFitsImage); calibration names both files.
CameraModel rellisCamera(const std::string& camera_info, const std::string& transforms,
                         int width_px, int height_px);

}  // namespace terramrf
