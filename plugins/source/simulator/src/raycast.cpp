// Ray casting: analytic primitives found through a uniform 2D grid (2D DDA walk), then the
// heightfield by conservative sphere tracing against an upper envelope of the terrain.
#include <algorithm>
#include <cmath>
#include <cstring>

#include "terramrf/sim/random.hpp"
#include "world_internal.hpp"

namespace terramrf::sim {

RayScratch World::makeScratch() const {
  RayScratch s;
  s.stamp_.assign(prims_.size(), 0);
  return s;
}

RayHit World::castRay(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min,
                      double t_max, uint64_t ray_key, RayScratch& scratch) const {
  RayHit best;
  best.t_m = t_max;
  // Terrain first: most rays end on the ground, which then bounds the primitive walk.
  castTerrain(o, d, t_min, best);
  castPrimitives(o, d, t_min, ray_key, scratch, best);
  if (!best.hit()) best.t_m = std::numeric_limits<double>::infinity();
  return best;
}

bool World::intersect(const detail::Primitive& pr, const Eigen::Vector3d& o,
                      const Eigen::Vector3d& d, double t_min, double t_max, uint64_t ray_key,
                      int index, RayHit& hit) const {
  using P = detail::Primitive;
  switch (pr.type) {
    case P::kBox: {
      const double dx = o.x() - pr.cx, dy = o.y() - pr.cy;
      const double lo[3] = {pr.cs * dx + pr.sn * dy, -pr.sn * dx + pr.cs * dy, o.z()};
      const double ld[3] = {pr.cs * d.x() + pr.sn * d.y(), -pr.sn * d.x() + pr.cs * d.y(), d.z()};
      const double lmin[3] = {-pr.hx, -pr.hy, pr.z0}, lmax[3] = {pr.hx, pr.hy, pr.z1};
      double tn = -INFINITY, tf = INFINITY;
      int axis = -1;
      double sign = 0;
      for (int a = 0; a < 3; ++a) {
        if (std::abs(ld[a]) < 1e-12) {
          if (lo[a] < lmin[a] || lo[a] > lmax[a]) return false;
          continue;
        }
        const double inv = 1.0 / ld[a];
        double t1 = (lmin[a] - lo[a]) * inv, t2 = (lmax[a] - lo[a]) * inv;
        if (t1 > t2) std::swap(t1, t2);
        if (t1 > tn) {
          tn = t1;
          axis = a;
          sign = ld[a] > 0 ? -1.0 : 1.0;
        }
        tf = std::min(tf, t2);
      }
      if (tn > tf || tn <= t_min || tn >= t_max || axis < 0) return false;
      hit.t_m = tn;
      hit.primitive = index;
      if (axis == 2) {
        hit.normal = {0, 0, sign};
      } else {
        const double nx = axis == 0 ? sign : 0, ny = axis == 1 ? sign : 0;
        hit.normal = {pr.cs * nx - pr.sn * ny, pr.sn * nx + pr.cs * ny, 0};
      }
      hit.material = pr.material;
      if (pr.owner == P::kBuilding && axis == 2 && sign > 0) hit.material = Material::kBuildingRoof;
      hit.point = o + tn * d;
      return true;
    }
    case P::kCylinder: {
      const double dx = o.x() - pr.cx, dy = o.y() - pr.cy;
      const double a = d.x() * d.x() + d.y() * d.y();
      if (a < 1e-12) return false;
      const double b = dx * d.x() + dy * d.y(), c = dx * dx + dy * dy - pr.hx * pr.hx;
      const double disc = b * b - a * c;
      if (disc < 0) return false;
      const double t = (-b - std::sqrt(disc)) / a;
      if (t <= t_min || t >= t_max) return false;
      const double z = o.z() + t * d.z();
      if (z < pr.z0 || z > pr.z1) return false;
      hit.t_m = t;
      hit.primitive = index;
      hit.point = o + t * d;
      hit.normal = {(hit.point.x() - pr.cx) / pr.hx, (hit.point.y() - pr.cy) / pr.hx, 0};
      hit.material = pr.material;
      return true;
    }
    case P::kEllipsoid: {
      const Eigen::Vector3d q =
          (o - Eigen::Vector3d(pr.cx, pr.cy, pr.cz)).cwiseProduct(pr.inv_radii);
      const Eigen::Vector3d e = d.cwiseProduct(pr.inv_radii);
      const double a = e.squaredNorm(), b = q.dot(e), c = q.squaredNorm() - 1.0;
      const double disc = b * b - a * c;
      if (disc < 0) return false;
      const double s = std::sqrt(disc);
      const double t0 = (-b - s) / a, t1 = (-b + s) / a;
      if (t1 <= t_min) return false;
      double t;
      if (pr.porous) {
        // Foliage as a random medium: exponential free path with rate crown_density_per_m. Keyed
        // by the crown's position (not its index) so it does not depend on the world's extent.
        uint64_t cx_bits, cy_bits;
        std::memcpy(&cx_bits, &pr.cx, 8);
        std::memcpy(&cy_bits, &pr.cy, 8);
        const double u = toUnit(hashKeys(ray_key, cx_bits, cy_bits, 0xC0));
        t = std::max(t0, t_min) - std::log1p(-u) / p_.crown_density_per_m;
        if (t >= t1) return false;
      } else {
        t = t0;
        if (t <= t_min) return false;
      }
      if (t >= t_max) return false;
      hit.t_m = t;
      hit.primitive = index;
      hit.point = o + t * d;
      const Eigen::Vector3d g = (hit.point - Eigen::Vector3d(pr.cx, pr.cy, pr.cz))
                                    .cwiseProduct(pr.inv_radii)
                                    .cwiseProduct(pr.inv_radii);
      hit.normal = g.squaredNorm() > 1e-18 ? g.normalized() : Eigen::Vector3d(-d);
      hit.material = pr.material;
      return true;
    }
  }
  return false;
}

void World::castPrimitives(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min,
                           uint64_t ray_key, RayScratch& s, RayHit& best) const {
  if (prims_.empty() || cg_nx_ == 0) return;
  if (s.stamp_.size() != prims_.size()) {
    s.stamp_.assign(prims_.size(), 0);
    s.counter_ = 0;
  }
  if (++s.counter_ == 0) {
    std::fill(s.stamp_.begin(), s.stamp_.end(), 0);
    s.counter_ = 1;
  }
  const uint32_t stamp = s.counter_;

  // Clip the ray to the grid's xy box.
  const double gx1 = cg_x0_ + cg_nx_ * cg_cell_, gy1 = cg_y0_ + cg_ny_ * cg_cell_;
  double t0 = t_min, t1 = best.t_m;
  auto clip = [&](double oo, double dd, double lo, double hi) {
    if (std::abs(dd) < 1e-15) return oo >= lo && oo <= hi;
    double a = (lo - oo) / dd, b = (hi - oo) / dd;
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
    return t0 <= t1;
  };
  if (!clip(o.x(), d.x(), cg_x0_, gx1) || !clip(o.y(), d.y(), cg_y0_, gy1)) return;
  // Nothing above the tallest primitive.
  if (d.z() >= 0 && o.z() + t0 * d.z() > prim_max_z_) return;

  const Eigen::Vector3d p = o + t0 * d;
  int ix = std::clamp(int((p.x() - cg_x0_) / cg_cell_), 0, cg_nx_ - 1);
  int iy = std::clamp(int((p.y() - cg_y0_) / cg_cell_), 0, cg_ny_ - 1);
  const int sx = d.x() > 0 ? 1 : -1, sy = d.y() > 0 ? 1 : -1;
  const double inf = std::numeric_limits<double>::infinity();
  const double ddx = std::abs(d.x()) > 1e-15 ? cg_cell_ / std::abs(d.x()) : inf;
  const double ddy = std::abs(d.y()) > 1e-15 ? cg_cell_ / std::abs(d.y()) : inf;
  double tx = ddx == inf ? inf : (cg_x0_ + (ix + (sx > 0)) * cg_cell_ - o.x()) / d.x();
  double ty = ddy == inf ? inf : (cg_y0_ + (iy + (sy > 0)) * cg_cell_ - o.y()) / d.y();
  double t_cell = t0;
  while (true) {
    const double t_exit = std::min({tx, ty, t1});
    const std::size_t c = std::size_t(iy) * cg_nx_ + ix;
    if (cg_offsets_[c] != cg_offsets_[c + 1]) {
      const double te = std::min(t_exit, best.t_m);
      const double za = o.z() + t_cell * d.z(), zb = o.z() + te * d.z();
      if (std::min(za, zb) <= cg_zmax_[c] && std::max(za, zb) >= cg_zmin_[c]) {
        for (uint32_t k = cg_offsets_[c]; k < cg_offsets_[c + 1]; ++k) {
          const uint32_t i = cg_items_[k];
          if (s.stamp_[i] == stamp) continue;
          s.stamp_[i] = stamp;
          RayHit h;
          if (intersect(prims_[i], o, d, t_min, best.t_m, ray_key, int(i), h)) best = h;
        }
      }
    }
    if (best.hit() && best.t_m <= t_exit) return;
    if (t_exit >= t1) return;
    if (tx < ty) {
      ix += sx;
      t_cell = tx;
      tx += ddx;
      if (ix < 0 || ix >= cg_nx_) return;
    } else {
      iy += sy;
      t_cell = ty;
      ty += ddy;
      if (iy < 0 || iy >= cg_ny_) return;
    }
    if (d.z() >= 0 && o.z() + t_cell * d.z() > prim_max_z_) return;
  }
}

namespace {
constexpr double kEps = 0.01;  // switch from sphere steps to fine steps within this gap [m]
}  // namespace

bool World::marchBlock(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double ta, double tb,
                       double rate, MarchState& st, RayHit& best) const {
  const double envelope = p_.rough_noise_m;  // roughness never exceeds it; the ditch only cuts
  double t = ta;
  while (t < tb) {
    const double x = o.x() + t * d.x(), y = o.y() + t * d.y(), z = o.z() + t * d.z();
    const double hs = tableHeight(x, y);
    const double gap = z - (hs + envelope);
    if (gap > kEps) {
      st.t_above = t;
      st.f_above = -1;
      st.above_known = true;
      if (rate <= 0) return false;  // cannot get closer within this block
      t += gap / rate;
      continue;
    }
    const double lat = lateralFast(x, y);
    const double h = hs + roughness(x, y, lat) - ditchDepth(x, lat);
    if (z <= h) {
      double hit_t = t;
      if (st.above_known) {
        // Bisect down to 5 cm, then interpolate linearly: the result is within a few mm on this
        // smooth-at-5-cm ground, well below the 2 cm range noise.
        auto f = [&](double m) {
          const double qx = o.x() + m * d.x(), qy = o.y() + m * d.y();
          return o.z() + m * d.z() - terrainHeight(qx, qy);
        };
        double lo = st.t_above, hi = t;
        double f_lo = st.f_above > 0 ? st.f_above : f(lo), f_hi = z - h;
        while (hi - lo > 0.05) {
          const double m = 0.5 * (lo + hi), fm = f(m);
          if (fm > 0) {
            lo = m;
            f_lo = fm;
          } else {
            hi = m;
            f_hi = fm;
          }
        }
        hit_t = f_lo > 0 && f_lo - f_hi > 1e-12 ? lo + (hi - lo) * f_lo / (f_lo - f_hi) : hi;
      }  // else the ray started below the ground: report its start
      if (hit_t >= best.t_m) return false;
      best.t_m = hit_t;
      best.primitive = -1;
      best.point = o + hit_t * d;
      best.material = groundMaterial(best.point.x(), best.point.y());
      best.normal = terrainNormal(best.point.x(), best.point.y(), best.point.z());
      return true;
    }
    st.t_above = t;
    st.f_above = z - h;
    st.above_known = true;
    // Fine steps near the ground: a few cm close by, coarser far away where the sensors' own
    // sampling is coarser anyway (a skipped bump crest costs at most a couple of cm).
    t += 0.04 + 0.004 * t;
  }
  return false;
}

void World::castTerrain(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min,
                        RayHit& best) const {
  const double envelope = p_.rough_noise_m;
  const double cell = p_.terrain_cell_m, bsize = cell * kBlockCells;
  // Clip to the tabulated strip; there is no terrain for ray casting outside it.
  double t0 = t_min, t1 = best.t_m;
  auto clip = [&](double oo, double dd, double lo, double hi) {
    if (std::abs(dd) < 1e-15) return oo >= lo && oo <= hi;
    double a = (lo - oo) / dd, b = (hi - oo) / dd;
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
    return t0 < t1;
  };
  if (!clip(o.x(), d.x(), tb_x0_, tb_x0_ + (tb_nx_ - 1) * cell) ||
      !clip(o.y(), d.y(), tb_y0_, tb_y0_ + (tb_ny_ - 1) * cell))
    return;
  const double top = tb_max_h_ + envelope + kEps;
  if (d.z() >= 0 && o.z() + t0 * d.z() > top) return;
  const double hor = std::hypot(d.x(), d.y());

  // 2D DDA over the coarse blocks.
  const double ux = (o.x() + t0 * d.x() - tb_x0_) / bsize,
               uy = (o.y() + t0 * d.y() - tb_y0_) / bsize;
  int bx = std::clamp(int(ux), 0, bk_nx_ - 1), by = std::clamp(int(uy), 0, bk_ny_ - 1);
  const int sx = d.x() > 0 ? 1 : -1, sy = d.y() > 0 ? 1 : -1;
  const double inf = std::numeric_limits<double>::infinity();
  const double ddx = std::abs(d.x()) > 1e-15 ? bsize / std::abs(d.x()) : inf;
  const double ddy = std::abs(d.y()) > 1e-15 ? bsize / std::abs(d.y()) : inf;
  double tx = ddx == inf ? inf : (tb_x0_ + (bx + (sx > 0)) * bsize - o.x()) / d.x();
  double ty = ddy == inf ? inf : (tb_y0_ + (by + (sy > 0)) * bsize - o.y()) / d.y();
  double ta = t0;
  MarchState st;
  st.t_above = t0;
  while (true) {
    const double tb = std::min({tx, ty, t1});
    const std::size_t b = std::size_t(by) * bk_nx_ + bx;
    const double za = o.z() + ta * d.z(), zb = o.z() + tb * d.z();
    if (std::min(za, zb) > bk_max_[b] + envelope + kEps) {
      st.t_above = tb;  // the whole segment passes above this block
      st.f_above = -1;
      st.above_known = true;
    } else if (marchBlock(o, d, ta, tb, bk_slope_[b] * hor - d.z(), st, best)) {
      return;
    }
    if (tb >= t1) return;
    if (d.z() >= 0 && zb > top) return;
    if (tx < ty) {
      bx += sx;
      ta = tx;
      tx += ddx;
      if (bx < 0 || bx >= bk_nx_) return;
    } else {
      by += sy;
      ta = ty;
      ty += ddy;
      if (by < 0 || by >= bk_ny_) return;
    }
  }
}

int World::hitObject(const RayHit& hit, detail::Primitive::Owner* owner) const {
  if (hit.primitive < 0 || hit.primitive >= int(prims_.size())) return -1;
  const detail::Primitive& p = prims_[hit.primitive];
  if (owner) *owner = p.owner == detail::Primitive::kCarCabin ? detail::Primitive::kCar : p.owner;
  return p.owner_index;
}

}  // namespace terramrf::sim
