#pragma once
// Finds the sensor in a LiDAR cloud stored shifted from it (Open3D-ML's SemanticKITTI scan 000700
// lies 100 m off), so that readers can put the sensor back at the origin, where ring recovery's
// elevations and the grid expect it.
#include <Eigen/Core>
#include <string>

#include "terramrf/frame.hpp"
#include "terramrf/point_cloud.hpp"

namespace terramrf {

/// Where a rotating LiDAR's cloud puts the sensor, from the innermost ground ring: the nearest
/// points around the sensor form a circle (bent to an off-centre ellipse by ground slope, which
/// is corrected from the ring's plane). Accuracy ~0.3 m on KITTI.
struct SensorOriginEstimate {
  bool ok = false;
  Eigen::Vector2d origin_m = Eigen::Vector2d::Zero();  ///< sensor x, y in the cloud frame [m]
  double ring_radius_m = 0;                            ///< radius of the innermost ground ring [m]
  int inliers = 0;                                     ///< points on that ring
  std::string note;                                    ///< why it failed
};
SensorOriginEstimate estimateSensorOrigin(const PointCloud& cloud);

/// Adds (dx, dy) [m] to every point.
void translateXY(PointCloud& cloud, double dx_m, double dy_m);

/// A reader's `recentre: auto`: moves frame `f`'s points so that the sensor origin its cloud
/// shows (estimateSensorOrigin) is at (0, 0), and its cameras' extrinsics, pose and truth pose
/// with them, so each still takes the points where it did. A shift shorter than `min_shift_m`
/// is left alone silently (the estimate is good to ~0.3 m). Says on stderr, prefixed by
/// `reader`, the shift made, or that none could be estimated and why (the cloud is then left
/// as stored). Returns whether the points moved.
bool recentreOnSensor(Frame& f, double min_shift_m, const std::string& reader);

}  // namespace terramrf
