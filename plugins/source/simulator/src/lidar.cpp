#include "terramrf/sim/lidar.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "terramrf/sim/random.hpp"

namespace terramrf::sim {

namespace {
constexpr double kPi = 3.141592653589793;
}

const std::array<double, 64>& hdl64ElevationsDeg() {
  static const std::array<double, 64> a = [] {
    std::array<double, 64> e{};
    for (int k = 0; k < 32; ++k) e[k] = 2.0 - k / 3.0;
    for (int k = 0; k < 32; ++k) e[32 + k] = -8.83 - 0.5 * k;
    return e;
  }();
  return a;
}

LidarModel::LidarModel(const World& world, const LidarParams& params) : world_(&world), p_(params) {
  if (!(p_.azimuth_step_deg > 0.0 && p_.azimuth_step_deg <= 10.0))
    throw std::invalid_argument("azimuth_step_deg must be in (0, 10]");
  if (!(p_.max_range_m > p_.min_range_m && p_.min_range_m >= 0))
    throw std::invalid_argument("need 0 <= min_range_m < max_range_m");
  columns_ = int(std::lround(360.0 / p_.azimuth_step_deg));
  const auto& el = hdl64ElevationsDeg();
  for (int r = 0; r < 64; ++r) {
    cos_el_[r] = std::cos(el[r] * kPi / 180.0);
    sin_el_[r] = std::sin(el[r] * kPi / 180.0);
  }
}

double LidarModel::canopyShift(const RayHit& hit, const Eigen::Vector3d& dir,
                               double shift_m) const {
  // Blades and stones stand only on their own ground: a return moved back along the beam past the
  // material's edge (over a road, a ditch) would hang there with the wrong label. The beam meets
  // the canopy at that edge at the latest, so the shift ends there.
  auto same = [&](double s) {
    const Eigen::Vector3d q = hit.point - s * dir;
    return world_->groundMaterial(q.x(), q.y()) == hit.material;
  };
  if (same(shift_m)) return shift_m;
  double lo = 0.0, hi = shift_m;  // same(lo), !same(hi)
  for (int i = 0; i < 12; ++i) {
    const double mid = 0.5 * (lo + hi);
    (same(mid) ? lo : hi) = mid;
  }
  // A few millimetres inside the edge, so the point's float coordinates do not cross it.
  return std::max(0.0, lo - 0.005);
}

double LidarModel::columnAzimuth(int c) const {
  double a = kPi - c * (2 * kPi / columns_);
  if (a <= -kPi) a += 2 * kPi;
  return a;
}

void LidarModel::scan(const std::function<Eigen::Isometry3d(double)>& pose_at, uint64_t key,
                      Frame& frame) const {
  const int n_rays = columns_ * 64;
  PointCloud& pc = frame.points;
  pc.clear();
  pc.reserve(n_rays);
  pc.time_s.reserve(n_rays);
  frame.truth.label.clear();
  frame.truth.raw.clear();
  frame.truth.label.reserve(n_rays);
  frame.truth.raw.reserve(n_rays);
  // Ring order needs the whole sweep before emitting; column order is emitted as fired.
  struct Ray {
    float x, y, z, intensity;
    uint8_t material;  // kNone = no return
  };
  const bool buffer = p_.order == PointOrder::kRing;
  std::vector<Ray> rays(buffer ? n_rays : 0);
  auto emit = [&](int c, int r, const Ray& ray) {
    pc.push_back(ray.x, ray.y, ray.z, ray.intensity, uint16_t(r));
    pc.time_s.push_back(float(columnTime(c)));
    frame.truth.label.push_back(projectClass(Material(ray.material)));
    frame.truth.raw.push_back(ray.material);
  };

  RayScratch scratch = world_->makeScratch();
  Eigen::Isometry3d T = pose_at(0.0);
  for (int c = 0; c < columns_; ++c) {
    if (p_.motion_distortion && c > 0) T = pose_at(columnTime(c));
    const Eigen::Matrix3d& R = T.linear();
    const Eigen::Vector3d o = T.translation();
    const double az = columnAzimuth(c), ca = std::cos(az), sa = std::sin(az);
    for (int r = 0; r < 64; ++r) {
      const int idx = c * 64 + r;
      Rng rng(hashKeys(key, uint64_t(idx)));
      if (rng.chance(p_.dropout_prob)) continue;
      const Eigen::Vector3d dl(cos_el_[r] * ca, cos_el_[r] * sa, sin_el_[r]);
      const Eigen::Vector3d dw = R * dl;
      const RayHit hit = world_->castRay(o, dw, p_.min_range_m, p_.max_range_m,
                                         hashKeys(key, uint64_t(idx), 1), scratch);
      if (!hit.hit()) continue;
      const double cosi = std::abs(hit.normal.dot(dw));  // sine of the incidence on the surface
      double range = hit.t_m + p_.range_noise_m * rng.normal();
      const double depth = hit.material == Material::kGrass    ? p_.grass_depth_m
                           : hit.material == Material::kGravel ? p_.gravel_depth_m
                                                               : 0.0;
      if (depth > 0) range -= canopyShift(hit, dw, rng.uniform(0.0, depth) / std::max(0.1, cosi));
      if (range < p_.min_range_m || range > p_.max_range_m) continue;
      const double inten =
          reflectivity(hit.material) * (0.35 + 0.65 * cosi) + p_.intensity_noise * rng.normal();
      const Ray ray{float(dl.x() * range), float(dl.y() * range), float(dl.z() * range),
                    float(std::clamp(inten, 0.0, 1.0)), uint8_t(hit.material)};
      if (buffer)
        rays[idx] = ray;
      else
        emit(c, r, ray);
    }
  }
  if (buffer) {
    // Azimuth 0 (forward) first, then counter-clockwise: decreasing column index.
    const int c0 = columns_ / 2;
    for (int r = 0; r < 64; ++r) {
      for (int k = 0; k < columns_; ++k) {
        const int c = ((c0 - k) % columns_ + columns_) % columns_;
        if (rays[c * 64 + r].material != 0) emit(c, r, rays[c * 64 + r]);
      }
    }
  }
}

}  // namespace terramrf::sim
