#pragma once
// The per-point lookup point → pixel of camera_fusion for a camera without distortion: one 3 × 4
// product per point (M = P · T_camera_lidar): the maths of CameraModel::project, which multiplies
// by T_camera_lidar and P in turn (so the two can round apart in the last bit).
#include <cstddef>
#include <cstdint>

namespace terramrf {

struct PinholeScan {
  const float *x, *y, *z;  ///< LiDAR points [m]
  std::size_t n = 0;
  double zc[4];    ///< row 3 of T_camera_lidar: the camera z of a point (must exceed 1e-6)
  double M[3][4];  ///< P · T_camera_lidar
  int width = 0, height = 0;  ///< image [px]
  int32_t* pix = nullptr;  ///< out: v·width + u of the nearest pixel centre, −1 if not visible
  float* depth = nullptr;  ///< out, optional: w = row 3 of M · [X; 1] if visible, else 0
};

/// Fills s.pix (and s.depth) for every point; returns the number of visible points. A point is
/// visible when it is in front of the camera (camera z > 1e-6, w > 1e-9) and (u, v) = (x/w, y/w)
/// lies in [−0.5, width − 0.5) × [−0.5, height − 0.5). Every copy (SSE2, AVX2) performs the same
/// IEEE operations, so the same pixels and depths.
std::size_t projectPinhole(const PinholeScan& s);

}  // namespace terramrf
