#include "terramrf/lcm/camera_codec.hpp"

#include <cmath>
#include <stdexcept>
#include <terramrf_msgs/camera_info_t.hpp>

#include "lcm_bytes.hpp"
#include "terramrf/errors.hpp"

namespace terramrf {

namespace {
// The calibration readers' tolerance (io's kRotationTolerance): what they accept records and
// replays.
constexpr double kRotationTolerance = 1e-3;

double rotationError(const Eigen::Matrix3d& R) {
  return (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
}
}  // namespace

MessageBytes encodeCameraInfo(const CameraModel& c, const MessageHeader& header) {
  if (rotationError(c.T_camera_lidar.linear()) > kRotationTolerance ||
      c.T_camera_lidar.linear().determinant() < 0)
    throw std::invalid_argument("encodeCameraInfo: camera '" + c.name +
                                "': T_camera_lidar's rotation is not a rotation");

  terramrf_msgs::camera_info_t m;
  m.utime = toUtime(header.timestamp_s);
  m.frame_id = header.frame_id;
  m.camera = c.name;
  m.width = c.width;
  m.height = c.height;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 4; ++k) m.P[4 * r + k] = c.P(r, k);
  for (int i = 0; i < 5; ++i) m.distortion[i] = c.distortion[i];
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 4; ++k) m.T_camera_lidar[4 * r + k] = c.T_camera_lidar.matrix()(r, k);
  m.calibration = c.calibration;
  return lcm_detail::encodeMessage(m, "camera_info_t");
}

DecodedCameraInfo decodeCameraInfo(const void* data, std::size_t size, const std::string& source) {
  const auto m = lcm_detail::decodeMessage<terramrf_msgs::camera_info_t>(data, size, source,
                                                                          "camera_info_t");
  if (m.width <= 0 || m.height <= 0) {
    throw InputError(source, "camera_info_t: camera '" + m.camera + "' is " +
                                 std::to_string(m.width) + " x " + std::to_string(m.height) +
                                 " px; expected a positive size");
  }
  bool finite = true;
  for (double v : m.P) finite = finite && std::isfinite(v);
  for (double v : m.distortion) finite = finite && std::isfinite(v);
  for (double v : m.T_camera_lidar) finite = finite && std::isfinite(v);
  if (!finite) throw InputError(source, "camera_info_t: camera '" + m.camera + "': a non-finite number");
  Eigen::Matrix<double, 3, 4> T;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 4; ++k) T(r, k) = m.T_camera_lidar[4 * r + k];
  const Eigen::Matrix3d R = T.leftCols<3>();
  const double off = rotationError(R);
  if (off > kRotationTolerance || R.determinant() < 0) {
    throw InputError(source, "camera_info_t: camera '" + m.camera +
                                 "': T_camera_lidar's rotation is not a rotation (|RᵀR − I| = " +
                                 std::to_string(off) + ", det " + std::to_string(R.determinant()) +
                                 ")");
  }
  Eigen::Matrix<double, 3, 4> P;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 4; ++k) P(r, k) = m.P[4 * r + k];
  // A singular left 3×3 (an all-zero P, a row missing) projects every point nowhere, silently.
  if (!(std::abs(P.leftCols<3>().determinant()) > 1e-12)) {
    throw InputError(source, "camera_info_t: camera '" + m.camera +
                                 "': the projection matrix P is singular (its left 3 x 3 has "
                                 "determinant " + std::to_string(P.leftCols<3>().determinant()) +
                                 "); expected intrinsics such as [fx 0 cx; 0 fy cy; 0 0 1]");
  }
  DecodedCameraInfo out;
  out.header.frame_id = m.frame_id;
  out.header.timestamp_s = fromUtime(m.utime);
  CameraModel& c = out.model;
  c.name = m.camera;
  c.width = m.width;
  c.height = m.height;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 4; ++k) c.P(r, k) = m.P[4 * r + k];
  for (int i = 0; i < 5; ++i) c.distortion[i] = m.distortion[i];
  c.T_camera_lidar.matrix().topRows<3>() = T;
  c.calibration = m.calibration;
  return out;
}

}  // namespace terramrf
