#include "terramrf/io/sensor_origin.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace terramrf {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2 * kPi;

}  // namespace

void translateXY(PointCloud& cloud, double dx_m, double dy_m) {
  const float dx = static_cast<float>(dx_m), dy = static_cast<float>(dy_m);
  for (auto& v : cloud.x) v += dx;
  for (auto& v : cloud.y) v += dy;
}

bool recentreOnSensor(Frame& f, double min_shift_m, const std::string& reader) {
  const SensorOriginEstimate est = estimateSensorOrigin(f.points);
  if (!est.ok) {
    // Asked for and not done: the scan may be off-centre, and the grid, ring recovery and
    // features would all see it there. Said, like the shift when it is applied.
    std::fprintf(stderr,
                 "%s: %s: recentre: auto could not estimate the sensor origin (%s); the cloud is "
                 "left as stored\n",
                 reader.c_str(), f.source_path.c_str(), est.note.c_str());
    return false;
  }
  // Within the estimate's accuracy of (0, 0): deliberately left alone, silently.
  if (est.origin_m.norm() < min_shift_m) return false;
  const Eigen::Vector2d shift = -est.origin_m;
  translateXY(f.points, shift.x(), shift.y());
  // Camera projections and the poses stay valid for the moved points.
  Eigen::Isometry3d undo = Eigen::Isometry3d::Identity();
  undo.translation() = Eigen::Vector3d(-shift.x(), -shift.y(), 0);
  for (auto& cam : f.cameras) cam.model.T_camera_lidar = cam.model.T_camera_lidar * undo;
  if (f.pose) f.pose = *f.pose * undo;
  if (f.truth_pose) f.truth_pose = *f.truth_pose * undo;
  std::fprintf(stderr,
               "%s: frame %s: sensor origin estimated at (%.2f, %.2f) m from the innermost ground "
               "ring; cloud shifted by (%.2f, %.2f) m\n",
               reader.c_str(), f.id.c_str(), est.origin_m.x(), est.origin_m.y(), shift.x(),
               shift.y());
  return true;
}

SensorOriginEstimate estimateSensorOrigin(const PointCloud& c) {
  SensorOriginEstimate est;
  const std::size_t n = c.size();
  if (n < 500) {
    est.note = "too few points (" + std::to_string(n) + ")";
    return est;
  }
  // 1. Coarse: point density is highest within ~10 m of a rotating LiDAR. Densest 17×17 m
  //    window of a 1 m occupancy grid (summed-area table).
  double xmin = c.x[0], xmax = xmin, ymin = c.y[0], ymax = ymin;
  for (std::size_t i = 0; i < n; ++i) {
    xmin = std::min<double>(xmin, c.x[i]), xmax = std::max<double>(xmax, c.x[i]);
    ymin = std::min<double>(ymin, c.y[i]), ymax = std::max<double>(ymax, c.y[i]);
  }
  const double cell = std::max({1.0, (xmax - xmin) / 1000.0, (ymax - ymin) / 1000.0});
  const int nx = int((xmax - xmin) / cell) + 1, ny = int((ymax - ymin) / cell) + 1;
  std::vector<double> sat(std::size_t(nx + 1) * (ny + 1), 0.0);
  auto S = [&](int ix, int iy) -> double& { return sat[std::size_t(iy) * (nx + 1) + ix]; };
  for (std::size_t i = 0; i < n; ++i) {
    const int ix = std::min(nx - 1, int((c.x[i] - xmin) / cell));
    const int iy = std::min(ny - 1, int((c.y[i] - ymin) / cell));
    S(ix + 1, iy + 1) += 1;
  }
  for (int iy = 1; iy <= ny; ++iy)
    for (int ix = 1; ix <= nx; ++ix) S(ix, iy) += S(ix - 1, iy) + S(ix, iy - 1) - S(ix - 1, iy - 1);
  const int R = std::max(1, int(8.0 / cell));
  double best = -1;
  Eigen::Vector2d centre(0, 0);
  for (int iy = 0; iy < ny; ++iy) {
    for (int ix = 0; ix < nx; ++ix) {
      const int x0 = std::max(0, ix - R), x1 = std::min(nx, ix + R + 1);
      const int y0 = std::max(0, iy - R), y1 = std::min(ny, iy + R + 1);
      const double s = S(x1, y1) - S(x0, y1) - S(x1, y0) + S(x0, y0);
      if (s > best) best = s, centre = {xmin + (ix + 0.5) * cell, ymin + (iy + 0.5) * cell};
    }
  }
  // 2. Fine: the nearest point in each 2° azimuth sector lies on the innermost ground ring, a
  //    circle around the sensor. Fit it (Kåsa), drop outliers (near objects), re-sector, repeat.
  constexpr int kSectors = 180;
  constexpr double kSearchRadius = 15.0;  // [m]
  std::vector<int> nearest(kSectors);
  std::vector<double> nearest_r(kSectors);
  std::vector<int> sel;
  double radius = 0;
  for (int iter = 0; iter < 8; ++iter) {
    std::fill(nearest.begin(), nearest.end(), -1);
    std::fill(nearest_r.begin(), nearest_r.end(), kSearchRadius);
    for (std::size_t i = 0; i < n; ++i) {
      const double dx = c.x[i] - centre.x(), dy = c.y[i] - centre.y();
      const double r = std::hypot(dx, dy);
      if (r >= kSearchRadius) continue;
      const int s = std::min(kSectors - 1, int((std::atan2(dy, dx) + kPi) / kTwoPi * kSectors));
      if (r < nearest_r[s]) nearest_r[s] = r, nearest[s] = int(i);
    }
    sel.clear();
    for (int s : nearest)
      if (s >= 0) sel.push_back(s);
    Eigen::Vector2d fitted = centre;
    for (int trim = 0; trim < 3 && sel.size() >= 10; ++trim) {
      Eigen::MatrixXd A(sel.size(), 3);
      Eigen::VectorXd b(sel.size());
      for (std::size_t k = 0; k < sel.size(); ++k) {
        const double x = c.x[sel[k]] - centre.x(), y = c.y[sel[k]] - centre.y();
        A.row(k) << x, y, 1.0;
        b(k) = x * x + y * y;
      }
      const Eigen::Vector3d s = A.colPivHouseholderQr().solve(b);
      const Eigen::Vector2d cc(s(0) / 2, s(1) / 2);
      radius = std::sqrt(std::max(0.0, s(2) + cc.squaredNorm()));
      fitted = centre + cc;
      std::vector<double> res(sel.size());
      for (std::size_t k = 0; k < sel.size(); ++k)
        res[k] = std::fabs(std::hypot(c.x[sel[k]] - fitted.x(), c.y[sel[k]] - fitted.y()) - radius);
      std::vector<double> tmp(res);
      std::nth_element(tmp.begin(), tmp.begin() + tmp.size() / 2, tmp.end());
      const double tol = std::max(0.2, 3 * tmp[tmp.size() / 2]);
      std::vector<int> keep;
      for (std::size_t k = 0; k < sel.size(); ++k)
        if (res[k] < tol) keep.push_back(sel[k]);
      sel.swap(keep);
    }
    const double moved = (fitted - centre).norm();
    centre = fitted;
    if (moved < 1e-3) break;
  }
  if (sel.size() < 40) {
    est.note = "no ring of near points around the densest area (" + std::to_string(sel.size()) +
               " on a circle)";
    return est;
  }
  // 3. Slope: on ground rising along g the ring comes closer on that side, which moves the
  //    fitted circle by -(R²/h)·g from the sensor (h = sensor height above the ground).
  Eigen::MatrixXd A(sel.size(), 3);
  Eigen::VectorXd zb(sel.size());
  for (std::size_t k = 0; k < sel.size(); ++k) {
    A.row(k) << 1.0, c.x[sel[k]] - centre.x(), c.y[sel[k]] - centre.y();
    zb(k) = c.z[sel[k]];
  }
  const Eigen::Vector3d plane = A.colPivHouseholderQr().solve(zb);
  const double h = -plane(0);
  if (h > 0.3) {
    Eigen::Vector2d corr = (radius * radius / h) * Eigen::Vector2d(plane(1), plane(2));
    if (corr.norm() > 1.5) corr *= 1.5 / corr.norm();
    centre += corr;
  }
  est.ok = true;
  est.origin_m = centre;
  est.ring_radius_m = radius;
  est.inliers = int(sel.size());
  return est;
}

}  // namespace terramrf
