#include "terramrf/camera.hpp"

namespace terramrf {

std::optional<Eigen::Vector2d> CameraModel::projectUnbounded(const Eigen::Vector3d& p_lidar) const {
  const Eigen::Vector3d pc = T_camera_lidar * p_lidar;
  if (pc.z() <= 1e-6) return std::nullopt;
  const auto& d = distortion;
  Eigen::Vector3d q;
  if (d[0] == 0 && d[1] == 0 && d[2] == 0 && d[3] == 0 && d[4] == 0) {
    q = P * pc.homogeneous();
  } else {
    // Distortion acts on normalised coordinates; P's last column (KITTI baseline) is kept.
    const double x = pc.x() / pc.z(), y = pc.y() / pc.z();
    const double r2 = x * x + y * y;
    const double radial = 1 + d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2;
    const double xd = x * radial + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x);
    const double yd = y * radial + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y;
    q = P * Eigen::Vector4d(xd * pc.z(), yd * pc.z(), pc.z(), 1.0);
  }
  if (q.z() <= 1e-9) return std::nullopt;
  return Eigen::Vector2d(q.x() / q.z(), q.y() / q.z());
}

std::optional<Eigen::Vector2d> CameraModel::project(const Eigen::Vector3d& p_lidar) const {
  auto uv = projectUnbounded(p_lidar);
  if (!uv) return uv;
  // Pixel centres sit at integer coordinates, so pixel (0, 0) covers [−0.5, 0.5)².
  if (!(uv->x() >= -0.5 && uv->y() >= -0.5 && uv->x() < width - 0.5 && uv->y() < height - 0.5))
    return std::nullopt;
  return uv;
}

}  // namespace terramrf
