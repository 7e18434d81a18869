#include "terramrf/sim/camera.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>

#include "terramrf/sim/random.hpp"

namespace terramrf::sim {

namespace {
const Eigen::Vector3f kHorizon(200, 214, 232), kZenith(88, 138, 204);
const Eigen::Vector3d kSun = Eigen::Vector3d(0.45, 0.25, 0.86).normalized();
constexpr double kHazeM = 700.0;  // e-folding distance of aerial perspective [m]

Eigen::Vector3f sky(const Eigen::Vector3d& d) {
  const float e = float(std::sqrt(std::max(0.0, d.z())));
  return kHorizon + (kZenith - kHorizon) * std::min(1.0f, 1.6f * e);
}
}  // namespace

CameraRenderer::CameraRenderer(const World& world, const CameraParams& params)
    : world_(&world), p_(params) {
  if (p_.width < 16 || p_.height < 16 || !(p_.fx > 1))
    throw std::invalid_argument("bad camera size/fx");
  const double th = p_.pitch_deg * 3.141592653589793 / 180.0;
  const double yaw = p_.yaw_deg * 3.141592653589793 / 180.0;
  // Camera axes (x right, y down, z optical) expressed in the LiDAR frame.
  const Eigen::Vector3d zc(std::cos(th) * std::cos(yaw), std::cos(th) * std::sin(yaw),
                           -std::sin(th));
  const Eigen::Vector3d xc(std::sin(yaw), -std::cos(yaw), 0);
  const Eigen::Vector3d yc = zc.cross(xc);
  Eigen::Matrix3d R_lc;
  R_lc << xc, yc, zc;
  T_lidar_camera_ = Eigen::Isometry3d::Identity();
  T_lidar_camera_.linear() = R_lc;
  T_lidar_camera_.translation() =
      Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * p_.position_lidar_m;

  model_.name = p_.name;
  model_.width = p_.width;
  model_.height = p_.height;
  model_.P.setZero();
  model_.P(0, 0) = p_.fx;
  model_.P(1, 1) = p_.fx;
  model_.P(0, 2) = 0.5 * p_.width;
  model_.P(1, 2) = 0.5 * p_.height;
  model_.P(2, 2) = 1.0;
  model_.T_camera_lidar = T_lidar_camera_.inverse();
}

CameraImage CameraRenderer::render(const Eigen::Isometry3d& T_world_lidar, uint64_t key) const {
  const int W = p_.width, H = p_.height;
  auto rgb = std::make_shared<Image>(W, H, 3);
  auto truth = std::make_shared<Image>(W, H, 1);
  const Eigen::Isometry3d T_wc = T_world_lidar * T_lidar_camera_;
  const Eigen::Matrix3d R = T_wc.linear();
  const Eigen::Vector3d o = T_wc.translation();
  const double cx = model_.P(0, 2), cy = model_.P(1, 2), f = p_.fx;
  RayScratch scratch = world_->makeScratch();
  const float noise_amp = float(p_.pixel_noise * std::sqrt(3.0));  // uniform noise with σ
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      // Pixel centres at integer coordinates, matching CameraModel::project().
      const Eigen::Vector3d dc((u - cx) / f, (v - cy) / f, 1.0);
      const Eigen::Vector3d d = (R * dc).normalized();
      const uint64_t pix = uint64_t(v) * W + u;
      const RayHit hit = world_->castRay(o, d, 0.05, p_.far_m, hashKeys(key, pix, 1), scratch);
      Eigen::Vector3f c;
      LabelId cls = labels::kUnknown;
      if (hit.hit()) {
        Eigen::Vector3d n = hit.normal;
        if (n.dot(d) > 0) n = -n;
        const float light = float(0.5 + 0.6 * std::max(0.0, n.dot(kSun)));
        const float haze = float(1.0 - std::exp(-hit.t_m / kHazeM));
        c = world_->albedo(hit) * light;
        c += (kHorizon - c) * haze;
        cls = projectClass(hit.material);
      } else {
        c = sky(d);
      }
      const uint64_t nz = hashKeys(key, pix, 2);
      uint8_t* px = rgb->at(u, v);
      for (int k = 0; k < 3; ++k) {
        const float e = noise_amp * (float((nz >> (16 * k)) & 0xFFFF) * (2.0f / 65535.0f) - 1.0f);
        px[k] = uint8_t(std::lround(std::clamp(c[k] + e, 0.0f, 255.0f)));
      }
      *truth->at(u, v) = cls;
    }
  }
  CameraImage out;
  out.model = model_;
  out.image = rgb;
  out.truth = truth;
  out.source_path = "simulator";
  return out;
}

}  // namespace terramrf::sim
