#pragma once
#include <Eigen/Geometry>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "terramrf/camera.hpp"
#include "terramrf/label_set.hpp"
#include "terramrf/point_cloud.hpp"
#include "terramrf/terrain_grid.hpp"

namespace terramrf {

struct ImuSample {
  double t_s = 0;                            ///< timestamp [s]
  Eigen::Vector3d gyro_rad_s = Eigen::Vector3d::Zero();   ///< angular rate, body frame [rad/s]
  Eigen::Vector3d accel_m_s2 = Eigen::Vector3d::Zero();   ///< specific force, body frame [m/s²]
};

struct GpsSample {
  double t_s = 0;                            ///< timestamp [s]
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();   ///< local north-west-up [m]
  double sigma_m = 1.0;                      ///< 1σ horizontal accuracy [m]
};

struct OdometrySample {
  double t_s = 0;            ///< timestamp [s]
  double speed_m_s = 0;      ///< forward speed [m/s]
  double yaw_rate_rad_s = 0; ///< [rad/s]
};

/// Per-point ground truth, already mapped to project classes.
struct PointLabels {
  std::vector<LabelId> label;  ///< project class per point (labels::kUnknown = not scored)
  std::vector<uint32_t> raw;   ///< dataset id per point (low 16 bits of SemanticKITTI labels)
  bool empty() const { return label.empty(); }
};

/// One LiDAR sweep with everything recorded alongside it.
struct Frame {
  std::string id;          ///< e.g. "000042" (file stem); used in output names and messages
  std::string source_path; ///< file the points came from (for error messages)
  double timestamp_s = 0;  ///< [s]
  PointCloud points;       ///< LiDAR frame (x forward, y left, z up) [m]
  std::vector<CameraImage> cameras;
  std::vector<ImuSample> imu;        ///< since the previous frame
  std::vector<GpsSample> gps;        ///< since the previous frame
  std::vector<OdometrySample> odometry;
  PointLabels truth;                 ///< optional
  /// The LiDAR pose in the world frame (T_world_lidar: maps LiDAR-frame points into the world)
  /// that the pipeline uses: what the textured mesh and temporal fusion place the scan with (the
  /// KITTI writer too, for a frame without truth_pose). The source fills it with the pose its data
  /// records (truth_pose when that is ground truth); an egomotion stage replaces it with its
  /// estimate. Absent when unknown.
  std::optional<Eigen::Isometry3d> pose;
  /// Uncertainty of `pose`, when its producer knows it: 6×6 over (x, y, z, roll, pitch, yaw),
  /// the LiDAR origin's position and small rotations about the world's x, y and z axes, both in
  /// the world frame (as ROS's PoseWithCovariance and LCM's pose_t) [m², rad², m·rad]. Whoever
  /// writes `pose` sets or clears it: a covariance of another pose is worse than none.
  std::optional<Eigen::Matrix<double, 6, 6>> pose_covariance;
  /// The ground-truth LiDAR pose (T_world_lidar, the world frame of `pose`), when the source has
  /// one: the simulator's trajectory, SemanticKITTI's poses.txt (the dataset's reference poses).
  /// Written by sources only, never by an egomotion stage (the runner fails a frame whose
  /// egomotion stages change it), so that the estimate in `pose` can be scored against it
  /// (egomotion.*_error metrics). A pose a file merely records (a PCD VIEWPOINT) is `pose` only.
  std::optional<Eigen::Isometry3d> truth_pose;
  /// Points dropped while reading, reported by the runner (runPipeline): those with NaN/inf in a
  /// coordinate or the intensity — a damaged or badly converted file, warned about per frame —
  /// and no-returns stored at the origin (normal for organised scans: ~52k of 131k in a RELLIS-3D
  /// Ouster scan), counted in the run's summary.
  std::size_t dropped_nonfinite_points = 0;
  std::size_t dropped_no_return_points = 0;
  /// Grid layers computed elsewhere (another process's stages, received as terrain_grid_t), from
  /// a source that lists their names in writes(): the runner starts the frame's grid from them
  /// (and its label layer) instead of an empty one, then bins `points` as usually, so stages
  /// after it (an energy and an optimiser) use them as if computed here. Its geometry must be
  /// the run's. Null when the source made none (every reader of files).
  std::shared_ptr<const TerrainGrid> grid;
  /// How the layers of `grid` were computed, where they came with it (layer -> origin record, as
  /// PluginContext::layer_origins; an LCM sender's layer_origins_t): an energy checks its model
  /// against them per frame, for sources that cannot know them before the first frame (a live
  /// stream). Empty when unknown.
  std::map<std::string, std::string> layer_origins;
};

/// Camera `i` of `f` as outputs name it in file names: its model's name, or "camera<i>" when it
/// has none.
inline std::string cameraName(const Frame& f, std::size_t i) {
  const std::string& name = f.cameras[i].model.name;
  return name.empty() ? "camera" + std::to_string(i) : name;
}

}  // namespace terramrf
