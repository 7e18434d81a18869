#include "terramrf/camera.hpp"

#include <algorithm>
#include <cmath>

namespace terramrf {
namespace {

/// Whether the radial distortion r ↦ r (1 + k1 r² + k2 r⁴ + k3 r⁶) still grows at every radius up
/// to r² = s. Beyond its first turning point the polynomial folds far off-axis points back into
/// the image, where they would take the colour of pixels they never saw.
bool radialMonotoneUpTo(double k1, double k2, double k3, double s) {
  // d(r_d)/dr = g(r²) with g(s) = 1 + 3 k1 s + 5 k2 s² + 7 k3 s³, g(0) = 1: positive on [0, s]
  // iff positive at s and at its interior minima (roots of g').
  auto g = [&](double t) { return 1 + t * (3 * k1 + t * (5 * k2 + t * 7 * k3)); };
  if (!(g(s) > 0)) return false;
  const double a = 21 * k3, b = 10 * k2, c = 3 * k1;  // g'(t) = a t² + b t + c
  double roots[2];
  int n = 0;
  if (std::abs(a) < 1e-300) {
    if (std::abs(b) > 1e-300) roots[n++] = -c / b;
  } else {
    const double disc = b * b - 4 * a * c;
    if (disc >= 0) {
      roots[n++] = (-b - std::sqrt(disc)) / (2 * a);
      roots[n++] = (-b + std::sqrt(disc)) / (2 * a);
    }
  }
  for (int i = 0; i < n; ++i)
    if (roots[i] > 0 && roots[i] < s && !(g(roots[i]) > 0)) return false;
  return true;
}

/// Whether the polynomial c[0] + c[1] t + … + c[6] t⁶ is positive on [0, 1]. Bernstein form: all
/// coefficients positive proves it, an end coefficient (the value there) ≤ 0 refutes it, anything
/// else is halved (de Casteljau) and looked at again. A minimum within rounding of zero is not
/// resolved within `depth` halvings and counts as not positive: near a fold is as bad as at it.
bool positiveOnUnitInterval(const double (&c)[7], int depth = 40) {
  // b_k = Σ_{i ≤ k} C(k, i) / C(6, i) · c_i.
  static constexpr double kBinom[7][7] = {{1},
                                          {1, 1},
                                          {1, 2, 1},
                                          {1, 3, 3, 1},
                                          {1, 4, 6, 4, 1},
                                          {1, 5, 10, 10, 5, 1},
                                          {1, 6, 15, 20, 15, 6, 1}};
  double b[7];
  for (int k = 0; k <= 6; ++k) {
    b[k] = 0;
    for (int i = 0; i <= k; ++i) b[k] += kBinom[k][i] / kBinom[6][i] * c[i];
  }
  struct Local {
    static bool positive(const double (&b)[7], int depth) {
      if (!(b[0] > 0 && b[6] > 0)) return false;
      if (std::all_of(b, b + 7, [](double v) { return v > 0; })) return true;
      if (depth == 0) return false;
      double left[7], right[7], w[7];
      std::copy(b, b + 7, w);
      for (int r = 0; r <= 6; ++r) {
        left[r] = w[0];
        right[6 - r] = w[6 - r];
        for (int k = 0; k < 6 - r; ++k) w[k] = 0.5 * (w[k] + w[k + 1]);
      }
      return positive(left, depth - 1) && positive(right, depth - 1);
    }
  };
  return Local::positive(b, depth);
}

/// Whether the distortion keeps moving the normalised point (x, y) outward along its ray all the
/// way from the axis: the component of the distorted point along the ray, f(ρ) = ρ R(ρ²) +
/// 3 (p1 sin θ + p2 cos θ) ρ² at radius ρ, must grow on [0, r]. Its slope in t = ρ / r is
/// h(t) = 1 + 6 b t + 3 k1 s t² + 5 k2 s² t⁴ + 7 k3 s³ t⁶ with s = r², b = p1 y + p2 x. The
/// tangential term 3 b t r grows without bound, so for b < 0 it folds far points back through the
/// centre even where the radial polynomial alone keeps growing; for b ≥ 0, h ≥ the radial slope.
bool monotoneAlongRay(const std::array<double, 5>& d, double x, double y) {
  const double s = x * x + y * y;
  const double b = d[2] * y + d[3] * x;
  if (!radialMonotoneUpTo(d[0], d[1], d[4], s)) return false;
  if (b >= 0) return true;
  const double c[7] = {1, 6 * b, 3 * d[0] * s, 0, 5 * d[1] * s * s, 0, 7 * d[4] * s * s * s};
  return positiveOnUnitInterval(c);
}

}  // namespace

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
    if (!monotoneAlongRay(d, x, y)) return std::nullopt;
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
