#pragma once
// Writes frames as a KITTI odometry / SemanticKITTI sequence folder, e.g. for
// `terramrf simulate --out DIR`:
//
//   velodyne/NNNNNN.bin      float32 x y z intensity per point (LiDAR frame)
//   labels/NNNNNN.label      uint32 per point: raw dataset id (instance 0), if truth.raw is set
//   rings/NNNNNN.bin         uint16 ring per point (0 = top beam), if the frame has rings; not part
//                            of KITTI (its .bin has no rings) — ground truth for ring recovery
//   image_2/NNNNNN.png       the camera named "image_2" (else the first camera), RGB
//   image_2_truth/NNNNNN.png its per-pixel truth (project LabelId), if present
//   image_3/, image_3_truth/ the frame's other camera, if it has two
//   calib.txt                P0..P3 and Tr: Tr = image_2's T_camera_lidar (velo→cam0), P0 = P1 =
//                            P2 = its P; P3 = the other camera's P · T_camera_lidar · Tr⁻¹ (it may
//                            be turned: the reader splits the rotation off), else P2
//   poses.txt                camera-0 poses T_w_cam0 = Tr · T_w_lidar · Tr⁻¹ (so LiDAR pose =
//                            Tr⁻¹ · P · Tr), in the frames' world frame (first pose not identity);
//                            T_w_lidar is the frame's truth_pose, else its pose: the reader takes
//                            poses.txt for the dataset's truth
//   times.txt                frame timestamp [s] per line
//   imu.txt, gps.txt, odometry.txt   all samples, one per line, columns in a '#' header line
//
// Files are numbered by write order (000000, 000001, ...) so they stay aligned with the lines of
// poses.txt / times.txt even when a frame id is not numeric. Without any camera, calib.txt gets
// P = [I | 0] and Tr = identity (poses.txt then holds the LiDAR poses). Every file is written
// atomically; the per-sequence text files are written by finish().
#include <Eigen/Geometry>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "terramrf/camera.hpp"
#include "terramrf/frame.hpp"

namespace terramrf {

class KittiSequenceWriter {
 public:
  /// `dir` is created if needed; existing files of the same names are replaced.
  explicit KittiSequenceWriter(std::string dir);
  /// Calls finish() if it was not called (errors are swallowed there; call finish() to see them).
  ~KittiSequenceWriter();
  KittiSequenceWriter(const KittiSequenceWriter&) = delete;
  KittiSequenceWriter& operator=(const KittiSequenceWriter&) = delete;

  /// Writes one frame's files. Throws std::runtime_error naming the frame when its arrays
  /// disagree in length, the camera calibration changes within the sequence, a frame has more
  /// than two cameras or a distorted one (calib.txt holds neither), or only some frames carry
  /// a pose; file errors name the path.
  void write(const Frame& frame);
  /// Writes calib.txt, times.txt, poses.txt (if frames have poses), imu.txt, gps.txt and
  /// odometry.txt. Idempotent.
  void finish();

  const std::string& dir() const { return dir_; }
  std::size_t frames() const { return count_; }

  /// File stem of the i-th written frame ("000042").
  static std::string stem(std::size_t i);

 private:
  std::string dir_;
  std::size_t count_ = 0;
  bool finished_ = false;
  /// Calibration source: the first frame's cameras, image_2 first (empty: no camera).
  std::vector<CameraModel> cameras_;
  bool cameras_set_ = false;
  std::vector<double> times_;
  std::vector<Eigen::Isometry3d> lidar_poses_;
  std::size_t frames_without_pose_ = 0;
  std::string imu_, gps_, odometry_;  ///< accumulated sample lines
};

}  // namespace terramrf
