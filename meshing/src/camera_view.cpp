#include "terramrf/meshing/camera_view.hpp"

#include <algorithm>
#include <limits>

namespace terramrf::meshing {

CameraView::CameraView(const CameraModel& cam, const Eigen::Isometry3d& T_wl, const PointCloud& pts,
                       int dilate)
    : cam_(cam), T_lidar_world_(T_wl.inverse()), T_world_lidar_(T_wl) {
  // P · T_cl · X = M X + p4 with M = K·R_cl (K = P's left 3×3), p4 = K·t_cl + P.col(3).
  const Eigen::Matrix3d K = cam.P.leftCols<3>();
  const Eigen::Matrix3d M = K * cam.T_camera_lidar.linear();
  const Eigen::Vector3d p4 = K * cam.T_camera_lidar.translation() + cam.P.col(3);
  M_inv_ = M.inverse();
  centre_w_ = T_wl * Eigen::Vector3d(-M_inv_ * p4);
  const int W = cam.width, H = cam.height;
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<float> raw(std::size_t(W) * H, inf);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Eigen::Vector3d pl(pts.x[i], pts.y[i], pts.z[i]);
    const auto uv = cam.project(pl);
    if (!uv) continue;
    const float d = float((cam.T_camera_lidar * pl).z());
    const int u = int(uv->x() + 0.5), v = int(uv->y() + 0.5);
    if (u >= W || v >= H) continue;
    float& slot = raw[std::size_t(v) * W + u];
    slot = std::min(slot, d);
  }
  // Separable min filter (square window of side 2·dilate + 1).
  std::vector<float> tmp(raw.size(), inf);
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      float m = inf;
      for (int k = std::max(0, u - dilate); k <= std::min(W - 1, u + dilate); ++k)
        m = std::min(m, raw[std::size_t(v) * W + k]);
      tmp[std::size_t(v) * W + u] = m;
    }
  depth_.assign(raw.size(), inf);
  depth_above_.assign(raw.size(), inf);
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      float m = inf;
      for (int k = std::max(0, v - dilate); k <= v; ++k)
        m = std::min(m, tmp[std::size_t(k) * W + u]);
      depth_above_[std::size_t(v) * W + u] = m;
      for (int k = v + 1; k <= std::min(H - 1, v + dilate); ++k)
        m = std::min(m, tmp[std::size_t(k) * W + u]);
      depth_[std::size_t(v) * W + u] = m;
    }
}

std::optional<Eigen::Vector2d> CameraView::project(const Eigen::Vector3d& pw, double* depth) const {
  const Eigen::Vector3d pl = T_lidar_world_ * pw;
  const auto uv = cam_.project(pl);
  if (uv && depth) *depth = (cam_.T_camera_lidar * pl).z();
  return uv;
}

Eigen::Vector3d CameraView::ray(double u, double v) const {
  const Eigen::Vector3d d_lidar = M_inv_ * Eigen::Vector3d(u, v, 1.0);
  return (T_world_lidar_.linear() * d_lidar).normalized();
}

}  // namespace terramrf::meshing
