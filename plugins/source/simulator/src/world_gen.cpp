// Procedural generation of the world from its seed: road, hills, ditches, objects, and the two
// acceleration structures (smooth-height table, 2D culling grid of primitives).
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "terramrf/sim/random.hpp"
#include "world_internal.hpp"

namespace terramrf::sim {

namespace {
constexpr double kTwoPi = 6.283185307179586;
// Hills: plane waves, amplitudes relative to hill_height_m and wavelength ranges [m].
constexpr double kHillRelAmp[4] = {1.0, 0.5, 0.15, 0.06};
constexpr double kHillWavelengthM[4][2] = {{180, 260}, {90, 130}, {40, 60}, {20, 30}};

std::array<uint8_t, 3> pick(Rng& rng, std::initializer_list<std::array<uint8_t, 3>> palette) {
  const std::size_t i = std::min(palette.size() - 1, std::size_t(rng.uniform() * palette.size()));
  return *(palette.begin() + i);
}
}  // namespace

double World::roadGradeBound(double hill_height_m) {
  // The road follows the two longest waves (roadProfile()); along any direction a wave's slope
  // is at most amplitude · 2π / wavelength.
  double g = 0;
  for (int k = 0; k < 2; ++k) g += hill_height_m * kHillRelAmp[k] * kTwoPi / kHillWavelengthM[k][0];
  return g;
}

double World::terrainTableBytes(const WorldParams& p) {
  // As buildTerrainTable() sizes it: the strip, widened by the road's bends (the centre line
  // swings by up to 1.15 · road_curve_m each way) and the block lattice's rounding.
  const double margin = 2 * p.terrain_cell_m * kBlockCells;
  const double nx = (p.x_max_m - p.x_min_m + margin) / p.terrain_cell_m + 2;
  const double ny =
      (2 * p.terrain_half_width_m + 2.3 * p.road_curve_m + margin) / p.terrain_cell_m + 2;
  return nx * ny * sizeof(float);
}

std::array<Eigen::Vector2d, 4> Building::corners() const {
  const Eigen::Vector2d ax(std::cos(yaw_rad), std::sin(yaw_rad)), ay(-ax.y(), ax.x());
  const Eigen::Vector2d u = ax * half_size_m.x(), v = ay * half_size_m.y();
  return {centre_m - u - v, centre_m + u - v, centre_m + u + v, centre_m - u + v};
}

World::World(const WorldParams& params) : p_(params) {
  auto need = [](bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument("sim::World: " + what);
  };
  need(p_.x_max_m > p_.x_min_m + 50, "x_max_m must exceed x_min_m by at least 50 m");
  need(p_.road_width_m > 2 && p_.shoulder_m >= 0, "road_width_m > 2 m and shoulder_m >= 0");
  need(p_.terrain_cell_m > 0.05 && p_.terrain_cell_m <= 5, "terrain_cell_m in (0.05, 5] m");
  need(p_.terrain_half_width_m >= p_.object_half_width_m, "terrain must cover the objects");
  need(p_.ditch_width_m > 2 * kDitchWallM, "ditch_width_m must exceed 0.5 m");
  need(p_.rough_noise_m >= 0 && p_.hill_height_m >= 0 && p_.ditch_depth_m >= 0,
       "noise, hill and ditch sizes must be >= 0");

  Rng rng(hashKeys(p_.seed, uint64_t(Stream::kWorld)));
  // Long gentle bends plus a shorter wiggle; slopes stay below ~20° of heading change.
  road_amp_ = {p_.road_curve_m, 0.15 * p_.road_curve_m};
  road_freq_ = {kTwoPi / rng.uniform(250, 400), kTwoPi / rng.uniform(90, 150)};
  road_phase_ = {rng.uniform(0, kTwoPi), rng.uniform(0, kTwoPi)};
  // Hills: a few plane waves; with the default 2 m the steepest slope stays around 10°.
  for (int k = 0; k < 4; ++k) {
    const double f = kTwoPi / rng.uniform(kHillWavelengthM[k][0], kHillWavelengthM[k][1]);
    const double dir = rng.uniform(0, kTwoPi);
    hills_.push_back({p_.hill_height_m * kHillRelAmp[k], f * std::cos(dir), f * std::sin(dir),
                      rng.uniform(0, kTwoPi)});
  }
  noise_seed_ = uint32_t(rng.next() >> 32);
  rough_lattice_.resize(kRoughLattice * kRoughLattice);
  for (float& v : rough_lattice_) v = float(rng.uniform(-1.0, 1.0));

  // Centre-line table for the hot path.
  // All tables sit on global lattices (integer multiples of their spacing), so two worlds of the
  // same seed but different extents interpolate identical values at a place.
  const int64_t cl_i0 = int64_t(std::floor((p_.x_min_m - 10) / cl_dx_));
  cl_x0_ = double(cl_i0) * cl_dx_;
  const int ncl = int(std::ceil((p_.x_max_m - p_.x_min_m + 20) / cl_dx_)) + 2;
  cl_y_.resize(ncl);
  cl_inv_norm_.resize(ncl);
  for (int i = 0; i < ncl; ++i) {
    const double x = double(cl_i0 + i) * cl_dx_, s = roadCentreSlope(x);
    cl_y_[i] = float(roadCentreY(x));
    cl_inv_norm_[i] = float(1.0 / std::sqrt(1.0 + s * s));
  }

  // Ditches on the right side (y < road): one starts just ahead of x = 0 so the first frames of a
  // run starting there see a negative obstacle; more follow in both directions.
  {
    Ditch proto;
    proto.depth_m = p_.ditch_depth_m;
    proto.half_width_m = 0.5 * p_.ditch_width_m;
    proto.floor_half_width_m = std::max(0.05, proto.half_width_m - kDitchWallM);
    proto.offset_m = -(0.5 * p_.road_width_m + p_.ditch_gap_m + proto.half_width_m);
    // Separate streams ahead of and behind the first ditch, so the ditches at a place do not
    // depend on how far the strip reaches.
    const double first = rng.uniform(5, 15);
    Rng ahead(hashKeys(p_.seed, uint64_t(Stream::kWorld), 3));
    for (double x = first; x < p_.x_max_m;) {
      Ditch d = proto;
      d.x_begin_m = x;
      d.x_end_m = x + ahead.uniform(40, 80);
      ditches_.push_back(d);
      x = d.x_end_m + ahead.uniform(25, 70);
    }
    Rng behind(hashKeys(p_.seed, uint64_t(Stream::kWorld), 4));
    for (double x = first - behind.uniform(25, 70); x > p_.x_min_m;) {
      Ditch d = proto;
      d.x_end_m = x;
      d.x_begin_m = x - behind.uniform(30, 80);
      ditches_.push_back(d);
      x = d.x_begin_m - behind.uniform(25, 70);
    }
    std::sort(ditches_.begin(), ditches_.end(),
              [](const Ditch& a, const Ditch& b) { return a.x_begin_m < b.x_begin_m; });
    ditch_at_.assign(std::size_t(std::ceil(p_.x_max_m - cl_x0_)) + 2, -1);
    for (std::size_t k = 0; k < ditches_.size(); ++k) {
      const int i0 = std::max(0, int(std::floor(ditches_[k].x_begin_m - cl_x0_)));
      const int i1 =
          std::min(int(ditch_at_.size()) - 1, int(std::floor(ditches_[k].x_end_m - cl_x0_)));
      for (int i = i0; i <= i1; ++i) ditch_at_[i] = int16_t(k);
    }
  }

  buildTerrainTable();
  generateObjects();
  buildCullingGrid();
}

void World::buildTerrainTable() {
  const double cell = p_.terrain_cell_m;
  double cmin = 1e300, cmax = -1e300;
  for (float c : cl_y_) {
    cmin = std::min(cmin, double(c));
    cmax = std::max(cmax, double(c));
  }
  // Origin on the block lattice too, so blocks (and the marcher's steps) agree between worlds.
  const double block = cell * kBlockCells;
  const int64_t ix0 = int64_t(std::floor(p_.x_min_m / block)) * kBlockCells;
  const int64_t iy0 = int64_t(std::floor((cmin - p_.terrain_half_width_m) / block)) * kBlockCells;
  tb_x0_ = double(ix0) * cell;
  tb_y0_ = double(iy0) * cell;
  tb_nx_ = int(std::ceil((p_.x_max_m - tb_x0_) / cell)) + 2;
  tb_ny_ = int(std::ceil((cmax + p_.terrain_half_width_m - tb_y0_) / cell)) + 2;
  tb_h_.assign(std::size_t(tb_nx_) * tb_ny_, 0.0f);
  tb_inv_cell_ = 1.0 / cell;
  tb_fx_max_ = double(tb_nx_ - 1) - 1e-9;
  tb_fy_max_ = double(tb_ny_ - 1) - 1e-9;
  // Same function as smoothHeight(), with the road's height profile tabulated (0.1 m, linear;
  // error ~1e-5 m) so the ~10⁶ nodes cost a few sines each.
  constexpr double kProfileDx = 0.1;
  const int64_t ip0 = int64_t(std::floor((p_.x_min_m - kRoadBlendM - 40) / kProfileDx));
  const double px0 = double(ip0) * kProfileDx;
  const int np = int(std::ceil((p_.x_max_m - px0 + kRoadBlendM + 40) / kProfileDx)) + 2;
  std::vector<double> profile(np);
  for (int i = 0; i < np; ++i) {
    const double x = double(ip0 + i) * kProfileDx;
    profile[i] = roadProfile(x);
  }
  auto roadZ = [&](double x) {
    const double f = std::clamp((x - px0) / kProfileDx, 0.0, double(np - 2));
    const int i = int(f);
    return profile[i] + (f - i) * (profile[i + 1] - profile[i]);
  };
  const double d0 = 0.5 * p_.road_width_m + p_.shoulder_m;
  for (int ix = 0; ix < tb_nx_; ++ix) {
    const double x = double(ix0 + ix) * cell;
    const double cy = roadCentreY(x), s = roadCentreSlope(x), inv = 1.0 / std::sqrt(1 + s * s);
    for (int iy = 0; iy < tb_ny_; ++iy) {
      const double y = double(iy0 + iy) * cell;
      const double lat = (y - cy) * inv;
      const double t = std::clamp((std::abs(lat) - d0) / kRoadBlendM, 0.0, 1.0);
      const double blend = t * t * (3 - 2 * t);
      double h;
      if (blend >= 1.0) {
        h = naturalHeight(x, y);
      } else {
        const double road_z = roadZ(x + lat * s * inv);
        h = blend > 0 ? road_z + (naturalHeight(x, y) - road_z) * blend : road_z;
      }
      tb_h_[std::size_t(iy) * tb_nx_ + ix] = float(h);
    }
  }
  // Gradient bound of the bilinear interpolant: per cell, |∂h/∂x| is at most the larger of the
  // two x-edge differences (same for y).
  double g2 = 0;
  tb_min_h_ = 1e300;
  tb_max_h_ = -1e300;
  for (int iy = 0; iy + 1 < tb_ny_; ++iy) {
    for (int ix = 0; ix + 1 < tb_nx_; ++ix) {
      const float* r0 = &tb_h_[std::size_t(iy) * tb_nx_ + ix];
      const float* r1 = r0 + tb_nx_;
      const double gx = std::max(std::abs(r0[1] - r0[0]), std::abs(r1[1] - r1[0]));
      const double gy = std::max(std::abs(r1[0] - r0[0]), std::abs(r1[1] - r0[1]));
      g2 = std::max(g2, gx * gx + gy * gy);
      tb_min_h_ = std::min(tb_min_h_, double(r0[0]));
      tb_max_h_ = std::max(tb_max_h_, double(r0[0]));
    }
  }
  slope_bound_ = 1.02 * std::sqrt(g2) / cell + 1e-3;

  // Coarse blocks: max height over the block's nodes (borders included) and gradient bound.
  const int ncx = tb_nx_ - 1, ncy = tb_ny_ - 1;
  bk_nx_ = (ncx + kBlockCells - 1) / kBlockCells;
  bk_ny_ = (ncy + kBlockCells - 1) / kBlockCells;
  bk_max_.assign(std::size_t(bk_nx_) * bk_ny_, -1e30f);
  bk_slope_.assign(std::size_t(bk_nx_) * bk_ny_, 0.0f);
  for (int iy = 0; iy < ncy; ++iy) {
    for (int ix = 0; ix < ncx; ++ix) {
      const float* r0 = &tb_h_[std::size_t(iy) * tb_nx_ + ix];
      const float* r1 = r0 + tb_nx_;
      const double gx = std::max(std::abs(r0[1] - r0[0]), std::abs(r1[1] - r1[0]));
      const double gy = std::max(std::abs(r1[0] - r0[0]), std::abs(r1[1] - r0[1]));
      const std::size_t b = std::size_t(iy / kBlockCells) * bk_nx_ + ix / kBlockCells;
      bk_max_[b] = std::max({bk_max_[b], r0[0], r0[1], r1[0], r1[1]});
      bk_slope_[b] =
          std::max(bk_slope_[b], float(1.02 * std::sqrt(gx * gx + gy * gy) / cell + 1e-3));
    }
  }
}

// ---- objects ----------------------------------------------------------------------------------

namespace {
struct Disc {
  Eigen::Vector2d c;
  double r;
};
}  // namespace

// Objects are generated per 60 m chunk along x, each chunk from its own random stream and kept
// inside its chunk, so what stands at a place depends only on the seed — not on how long the
// generated strip is (which follows frames, ranges and the camera setting).
void World::generateObjects() {
  constexpr double kChunkM = 60.0;
  const double half = 0.5 * p_.road_width_m;
  const double d0 = half + p_.shoulder_m;
  const double density = std::max(0.0, p_.obstacle_density);
  const uint64_t world_key = hashKeys(p_.seed, uint64_t(Stream::kWorld));
  std::vector<Disc> discs;
  double chunk_a = 0, chunk_b = 0;  // current chunk [m]

  // Point at lateral offset `lat` (left positive) from the centre line at x.
  auto at = [&](double x, double lat) {
    const double s = roadCentreSlope(x), inv = 1.0 / std::sqrt(1 + s * s);
    return Eigen::Vector2d(x - lat * s * inv, roadCentreY(x) + lat * inv);
  };
  auto distToBuilding = [](const Building& b, const Eigen::Vector2d& p) {
    const Eigen::Vector2d d = p - b.centre_m;
    const double c = std::cos(b.yaw_rad), s = std::sin(b.yaw_rad);
    const double lx = std::abs(c * d.x() + s * d.y()) - b.half_size_m.x();
    const double ly = std::abs(-s * d.x() + c * d.y()) - b.half_size_m.y();
    return Eigen::Vector2d(std::max(lx, 0.0), std::max(ly, 0.0)).norm() +
           std::min(std::max(lx, ly), 0.0);
  };
  // Inside the current chunk (with margin) and the generated strip.
  auto inChunk = [&](double x_lo, double x_hi, double margin) {
    return x_lo >= std::max(chunk_a + margin, p_.x_min_m) &&
           x_hi <= std::min(chunk_b - margin, p_.x_max_m);
  };
  // Keeps objects off the road, the shoulder and the ditches.
  auto clearOfRoad = [&](const Eigen::Vector2d& p, double r) {
    const double lat = lateralOffset(p.x(), p.y());
    if (std::abs(lat) - r < d0 + 0.5) return false;
    for (const Ditch& d : ditches_) {
      if (p.x() + r > d.x_begin_m - 0.5 && p.x() - r < d.x_end_m + 0.5 &&
          std::abs(lat - d.offset_m) < d.half_width_m + r + 0.5)
        return false;
    }
    return std::abs(lat) + r < p_.object_half_width_m && inChunk(p.x() - r, p.x() + r, 0.3);
  };
  // How far the outline of building `b` (on `side`: +1 left, -1 right) reaches into the road,
  // shoulder or ditch plus the 0.5 m margin clearOfRoad() keeps [m]; <= 0 when clear. Walls are
  // sampled every ~1 m: a bend or the building's own yaw can bring the middle or a corner of a
  // wall closer than its centre line.
  auto intrusion = [&](const Building& b, double side) {
    double worst = -1e300;
    const auto c = b.corners();
    for (int e = 0; e < 4; ++e) {
      const Eigen::Vector2d a = c[e], edge = c[(e + 1) % 4] - a;
      const int n = 1 + int(edge.norm());
      for (int i = 0; i <= n; ++i) {
        const Eigen::Vector2d q = a + edge * (double(i) / n);
        double need = d0 + 0.5;
        if (side < 0)  // the ditches lie on the right
          for (const Ditch& d : ditches_)
            if (q.x() > d.x_begin_m - 0.5 && q.x() < d.x_end_m + 0.5)
              need = std::max(need, -d.offset_m + d.half_width_m + 0.5);
        worst = std::max(worst, need - side * lateralOffset(q.x(), q.y()));
      }
    }
    return worst;
  };
  auto free = [&](const Eigen::Vector2d& p, double r, double building_margin) {
    for (const Building& b : buildings_)
      if (distToBuilding(b, p) < r + building_margin) return false;
    for (const Disc& d : discs)
      if ((d.c - p).norm() < r + d.r) return false;
    return true;
  };
  auto groundMin = [&](const Eigen::Vector2d& c, double r) {
    double m = terrainHeight(c.x(), c.y());
    for (int k = 0; k < 8; ++k) {
      const double a = k * kTwoPi / 8;
      m = std::min(m, terrainHeight(c.x() + r * std::cos(a), c.y() + r * std::sin(a)));
    }
    return m;
  };

  const int k0 = int(std::floor(p_.x_min_m / kChunkM)), k1 = int(std::floor(p_.x_max_m / kChunkM));

  // ---- pass 1: buildings (3 m inside their chunk, so chunks never interact) ----
  int landmark = -1;
  double width_needed = 0;  // half width the last building refused for the strip's width needed
  for (int k = k0; k <= k1; ++k) {
    chunk_a = k * kChunkM;
    chunk_b = chunk_a + kChunkM;
    for (double side : {+1.0, -1.0}) {
      Rng rng(hashKeys(world_key, 1000, uint64_t(int64_t(k)), side > 0));
      auto tryBuilding = [&](double x, bool close, double min_h, double max_h) {
        Building b;
        b.half_size_m = {0.5 * rng.uniform(8, 20), 0.5 * rng.uniform(7, 14)};
        const double near = close ? rng.uniform(7.5, 10) : rng.uniform(10, 45);
        const double xc = x + b.half_size_m.x();
        b.centre_m = at(xc, side * (near + b.half_size_m.y()));
        b.yaw_rad = std::atan(roadCentreSlope(xc)) + rng.uniform(-0.08, 0.08);
        // "Close" means 7.5–10 m from the centre line, which clears a default road, shoulder and
        // ditch; a wider road pushes the building out until it is clear (worlds with the default
        // widths never need it: their walls keep >= 0.75 m beyond the margin, seeds 1–40).
        double push = 0;
        for (int it = 0; it < 4; ++it) {
          const double in = intrusion(b, side);
          if (in <= 0) break;
          push += in + 0.01;
          b.centre_m = at(xc, side * (near + push + b.half_size_m.y()));
        }
        const double h = rng.uniform(min_h, max_h);
        b.wall_rgb = pick(
            rng,
            {{205, 190, 160}, {150, 72, 55}, {160, 160, 165}, {226, 222, 214}, {214, 190, 120}});
        b.roof_rgb = pick(rng, {{110, 50, 40}, {82, 82, 88}, {60, 60, 66}});
        if (push > 0 && intrusion(b, side) > 0) return -1;
        const double lat = std::abs(lateralOffset(b.centre_m.x(), b.centre_m.y()));
        if (lat + b.half_size_m.norm() > p_.object_half_width_m) {
          width_needed = lat + b.half_size_m.norm();
          return -1;
        }
        double cx0 = 1e300, cx1 = -1e300;
        for (const auto& c : b.corners()) {
          cx0 = std::min(cx0, c.x());
          cx1 = std::max(cx1, c.x());
        }
        if (!inChunk(cx0, cx1, 3.0)) return -1;
        for (const Building& o : buildings_)
          if ((o.centre_m - b.centre_m).norm() < o.half_size_m.norm() + b.half_size_m.norm() + 2)
            return -1;
        double gmin = terrainHeight(b.centre_m.x(), b.centre_m.y());
        for (const auto& c : b.corners()) gmin = std::min(gmin, terrainHeight(c.x(), c.y()));
        b.ground_z_m = terrainHeight(b.centre_m.x(), b.centre_m.y());
        b.base_z_m = gmin - 0.5;
        b.top_z_m = b.ground_z_m + h;
        buildings_.push_back(b);
        return int(buildings_.size()) - 1;
      };
      // A landmark: tall, close to the road on the left, a little ahead of x = 0, so the first
      // frames always see a wall taller than the top beam reaches. obstacle_density 0 asks for no
      // objects at all, the landmark (and the trees beside it) included.
      if (k == 0 && side > 0 && density > 0) {
        width_needed = 0;
        landmark = tryBuilding(rng.uniform(15, 25), true, 10, 15);
        if (landmark < 0) landmark_width_needed_m_ = width_needed;
      }
      for (double x = chunk_a + rng.uniform(0, 15); x < chunk_b;) {
        const bool place = density > 0 && rng.chance(std::min(1.0, 0.6 * density));
        const bool close = rng.chance(0.4);
        if (place) tryBuilding(x, close, close ? 8 : 3, close ? 15 : 12);
        x += rng.uniform(18, 40) / std::max(density, 0.2);
      }
    }
  }

  // ---- pass 2: trees, rocks, cars per chunk (kept inside it, so discs never cross chunks) ----
  const std::size_t n_buildings = buildings_.size();
  for (int k = k0; k <= k1; ++k) {
    chunk_a = k * kChunkM;
    chunk_b = chunk_a + kChunkM;
    Rng rng(hashKeys(world_key, 2000, uint64_t(int64_t(k))));
    auto makeTree = [&](const Eigen::Vector2d& p, int near_building) {
      Tree t;
      t.position_m = p;
      t.ground_z_m = terrainHeight(p.x(), p.y());
      t.trunk_radius_m = rng.uniform(0.12, 0.3);
      t.crown_radius_m = rng.uniform(1.5, 3.2);
      t.crown_half_height_m = t.crown_radius_m * rng.uniform(0.9, 1.4);
      const double trunk_visible = rng.uniform(1.8, 3.5);
      t.crown_centre_m = {p.x(), p.y(), t.ground_z_m + trunk_visible + t.crown_half_height_m};
      t.trunk_top_z_m = t.crown_centre_m.z();
      t.near_building = near_building;
      return t;
    };

    // Trees next to this chunk's buildings (crowns overlap the walls in the camera view).
    for (std::size_t bi = 0; bi < n_buildings; ++bi) {
      const Building b = buildings_[bi];
      if (b.centre_m.x() < chunk_a || b.centre_m.x() >= chunk_b) continue;
      const bool is_landmark = int(bi) == landmark;
      if (!is_landmark && !rng.chance(0.6)) continue;
      const int n = is_landmark ? 2 : 1 + int(rng.uniform() * 3);
      for (int t = 0; t < n; ++t) {
        for (int attempt = 0; attempt < 6; ++attempt) {
          // A point beside a random wall, 1.5–3 m out.
          const int face = int(rng.uniform() * 4);
          const double along = rng.uniform(-0.8, 0.8), out = rng.uniform(1.5, 3.0);
          Eigen::Vector2d l;
          if (face < 2)
            l = {along * b.half_size_m.x(), (face == 0 ? 1 : -1) * (b.half_size_m.y() + out)};
          else
            l = {(face == 2 ? 1 : -1) * (b.half_size_m.x() + out), along * b.half_size_m.y()};
          const double c = std::cos(b.yaw_rad), s = std::sin(b.yaw_rad);
          const Eigen::Vector2d p =
              b.centre_m + Eigen::Vector2d(c * l.x() - s * l.y(), s * l.x() + c * l.y());
          if (!clearOfRoad(p, 1.0) || !free(p, 0.5, 1.0)) continue;
          trees_.push_back(makeTree(p, int(bi)));
          discs.push_back({p, 0.8});
          break;
        }
      }
    }

    // Scattered trees, denser near the road.
    const int n_trees = int(std::lround(density * kChunkM / 100.0 * 14));
    for (int a = 0, placed = 0; a < 20 * n_trees && placed < n_trees; ++a) {
      const double x = rng.uniform(chunk_a, chunk_b);
      const double side = rng.chance(0.5) ? 1.0 : -1.0;
      const double u = rng.uniform();
      const double lat = side * (d0 + 2.5 + u * u * (p_.object_half_width_m - d0 - 3));
      const Eigen::Vector2d p = at(x, lat);
      if (!clearOfRoad(p, 1.5) || !free(p, 1.0, 1.5)) continue;
      trees_.push_back(makeTree(p, -1));
      discs.push_back({p, 1.0});
      ++placed;
    }

    // Rocks: every other one close to the road.
    const int n_rocks = int(std::lround(density * kChunkM / 100.0 * 6));
    for (int a = 0, placed = 0; a < 20 * n_rocks && placed < n_rocks; ++a) {
      Rock r;
      const double rx = rng.uniform(0.3, 1.2);
      r.radii_m = {rx, rx * rng.uniform(0.6, 1.2), rx * rng.uniform(0.4, 0.8)};
      const double x = rng.uniform(chunk_a, chunk_b);
      const double side = rng.chance(0.5) ? 1.0 : -1.0;
      const double lat = side * (a % 2 == 0 ? d0 + rng.uniform(0.8, 6)
                                            : d0 + rng.uniform(6, p_.object_half_width_m - d0));
      const double sink = rng.uniform(0.2, 0.6);
      const Eigen::Vector2d p = at(x, lat);
      const double rr = std::max(r.radii_m.x(), r.radii_m.y());
      if (!clearOfRoad(p, rr) || !free(p, rr, 0.5)) continue;
      r.centre_m = {p.x(), p.y(), groundMin(p, rr) + r.radii_m.z() * sink};
      rocks_.push_back(r);
      discs.push_back({p, rr});
      ++placed;
    }

    // Parked cars: along the left road edge and in building yards. A road-edge car stands in the
    // oncoming (left) lane with its left wheels on the shoulder; where that lane is narrower than
    // the widest car (road_width_m < 3.2 m) it would reach into the driving lane, so none parks.
    constexpr double kCarMaxHalfWidthM = 0.95;  // makeCar() draws 0.85–0.95 m
    const bool edge_parking = half - 0.65 - kCarMaxHalfWidthM >= 0;
    auto makeCar = [&](const Eigen::Vector2d& p, double yaw) {
      Car c;
      c.centre_m = p;
      c.yaw_rad = yaw;
      c.half_size_m = {rng.uniform(2.0, 2.4), rng.uniform(0.85, 0.95)};
      c.ground_z_m = terrainHeight(p.x(), p.y());
      c.top_z_m = c.ground_z_m + rng.uniform(1.4, 1.6);
      c.rgb = pick(rng, {{180, 30, 30},
                         {30, 60, 150},
                         {220, 220, 220},
                         {30, 30, 32},
                         {140, 140, 145},
                         {40, 110, 60},
                         {200, 170, 40}});
      return c;
    };
    for (double x = chunk_a + rng.uniform(0, 30); x < chunk_b; x += rng.uniform(25, 60)) {
      const bool place = rng.chance(std::min(1.0, 0.5 * density));
      const double yaw = std::atan(roadCentreSlope(x)) + rng.uniform(-0.03, 0.03);
      const Eigen::Vector2d p = at(x, half + 0.3 - 0.95);  // right wheels on the asphalt
      if (!place || !edge_parking || !inChunk(p.x() - 2.4, p.x() + 2.4, 0.3) || !free(p, 2.4, 0.5))
        continue;
      cars_.push_back(makeCar(p, yaw));
      discs.push_back({p, 2.4});
    }
    for (std::size_t bi = 0; bi < n_buildings; ++bi) {
      const Building b = buildings_[bi];
      if (b.centre_m.x() < chunk_a || b.centre_m.x() >= chunk_b) continue;
      if (!rng.chance(std::min(1.0, 0.35 * density))) continue;
      // In the yard, on the side facing the road.
      const double c = std::cos(b.yaw_rad), s = std::sin(b.yaw_rad);
      const Eigen::Vector2d ay(-s, c);
      const double side = lateralOffset(b.centre_m.x(), b.centre_m.y()) > 0 ? -1.0 : 1.0;
      const double shift = rng.uniform(-0.5, 0.5), yaw = b.yaw_rad + rng.uniform(-0.2, 0.2);
      const Eigen::Vector2d p = b.centre_m + ay * side * (b.half_size_m.y() + 2.0) +
                                Eigen::Vector2d(c, s) * shift * b.half_size_m.x();
      if (!clearOfRoad(p, 2.4) || !free(p, 2.4, 0.3)) continue;
      cars_.push_back(makeCar(p, yaw));
      discs.push_back({p, 2.4});
    }
  }
}

void World::buildCullingGrid() {
  using P = detail::Primitive;
  prims_.clear();
  auto box = [&](P::Owner owner, int idx, Material m, const Eigen::Vector2d& c, double yaw,
                 const Eigen::Vector2d& h, double z0, double z1, double grow) {
    P p;
    p.type = P::kBox;
    p.owner = owner;
    p.owner_index = idx;
    p.material = m;
    p.cx = c.x();
    p.cy = c.y();
    p.cs = std::cos(yaw);
    p.sn = std::sin(yaw);
    p.hx = h.x();
    p.hy = h.y();
    p.z0 = z0;
    p.z1 = z1;
    const double ex = std::abs(p.cs) * h.x() + std::abs(p.sn) * h.y() + grow;
    const double ey = std::abs(p.sn) * h.x() + std::abs(p.cs) * h.y() + grow;
    p.min_x = c.x() - ex;
    p.max_x = c.x() + ex;
    p.min_y = c.y() - ey;
    p.max_y = c.y() + ey;
    prims_.push_back(p);
  };
  auto ellipsoid = [&](P::Owner owner, int idx, Material m, const Eigen::Vector3d& c,
                       const Eigen::Vector3d& r, bool porous) {
    P p;
    p.type = P::kEllipsoid;
    p.owner = owner;
    p.owner_index = idx;
    p.material = m;
    p.porous = porous;
    p.cx = c.x();
    p.cy = c.y();
    p.cz = c.z();
    p.inv_radii = r.cwiseInverse();
    p.z0 = c.z() - r.z();
    p.z1 = c.z() + r.z();
    p.min_x = c.x() - r.x();
    p.max_x = c.x() + r.x();
    p.min_y = c.y() - r.y();
    p.max_y = c.y() + r.y();
    prims_.push_back(p);
  };
  for (int i = 0; i < int(buildings_.size()); ++i) {
    const Building& b = buildings_[i];
    // Bounds grown by the yard so groundMaterial() finds the building from the yard.
    box(P::kBuilding, i, Material::kBuildingWall, b.centre_m, b.yaw_rad, b.half_size_m, b.base_z_m,
        b.top_z_m, kYardM);
  }
  for (int i = 0; i < int(trees_.size()); ++i) {
    const Tree& t = trees_[i];
    P p;
    p.type = P::kCylinder;
    p.owner = P::kTree;
    p.owner_index = i;
    p.material = Material::kTreeTrunk;
    p.cx = t.position_m.x();
    p.cy = t.position_m.y();
    p.hx = t.trunk_radius_m;
    p.z0 = t.ground_z_m - 0.5;
    p.z1 = t.trunk_top_z_m;
    p.min_x = p.cx - p.hx;
    p.max_x = p.cx + p.hx;
    p.min_y = p.cy - p.hx;
    p.max_y = p.cy + p.hx;
    prims_.push_back(p);
    ellipsoid(P::kTree, i, Material::kTreeCrown, t.crown_centre_m,
              {t.crown_radius_m, t.crown_radius_m, t.crown_half_height_m}, true);
  }
  for (int i = 0; i < int(rocks_.size()); ++i)
    ellipsoid(P::kRock, i, Material::kRock, rocks_[i].centre_m, rocks_[i].radii_m, false);
  for (int i = 0; i < int(cars_.size()); ++i) {
    const Car& c = cars_[i];
    const double body_top = c.ground_z_m + 0.62 * (c.top_z_m - c.ground_z_m);
    box(P::kCar, i, Material::kCar, c.centre_m, c.yaw_rad, c.half_size_m, c.ground_z_m + 0.25,
        body_top, 0);
    const Eigen::Vector2d back(std::cos(c.yaw_rad), std::sin(c.yaw_rad));
    box(P::kCarCabin, i, Material::kCar, c.centre_m - back * 0.1 * c.half_size_m.x(), c.yaw_rad,
        {0.55 * c.half_size_m.x(), 0.9 * c.half_size_m.y()}, body_top, c.top_z_m, 0);
  }

  // Uniform grid over the primitives' bounds, CSR lists.
  cg_nx_ = cg_ny_ = 0;
  cg_offsets_.assign(1, 0);
  cg_items_.clear();
  prim_max_z_ = -1e300;
  if (prims_.empty()) return;
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (const P& p : prims_) {
    x0 = std::min(x0, p.min_x);
    y0 = std::min(y0, p.min_y);
    x1 = std::max(x1, p.max_x);
    y1 = std::max(y1, p.max_y);
    prim_max_z_ = std::max(prim_max_z_, p.z1);
  }
  cg_x0_ = x0 - 1;
  cg_y0_ = y0 - 1;
  cg_nx_ = int(std::ceil((x1 - x0 + 2) / cg_cell_));
  cg_ny_ = int(std::ceil((y1 - y0 + 2) / cg_cell_));
  const std::size_t ncell = std::size_t(cg_nx_) * cg_ny_;
  std::vector<uint32_t> count(ncell + 1, 0);
  auto cells = [&](const P& p, auto&& f) {
    const int ix0 = std::max(0, int((p.min_x - cg_x0_) / cg_cell_));
    const int ix1 = std::min(cg_nx_ - 1, int((p.max_x - cg_x0_) / cg_cell_));
    const int iy0 = std::max(0, int((p.min_y - cg_y0_) / cg_cell_));
    const int iy1 = std::min(cg_ny_ - 1, int((p.max_y - cg_y0_) / cg_cell_));
    for (int iy = iy0; iy <= iy1; ++iy)
      for (int ix = ix0; ix <= ix1; ++ix) f(std::size_t(iy) * cg_nx_ + ix);
  };
  for (const P& p : prims_) cells(p, [&](std::size_t c) { ++count[c + 1]; });
  for (std::size_t c = 0; c < ncell; ++c) count[c + 1] += count[c];
  cg_offsets_ = count;
  cg_items_.resize(count[ncell]);
  cg_zmin_.assign(ncell, 1e30f);
  cg_zmax_.assign(ncell, -1e30f);
  std::vector<uint32_t> fill(count.begin(), count.end() - 1);
  for (uint32_t i = 0; i < prims_.size(); ++i) {
    cells(prims_[i], [&](std::size_t c) {
      cg_items_[fill[c]++] = i;
      cg_zmin_[c] = std::min(cg_zmin_[c], float(prims_[i].z0));
      cg_zmax_[c] = std::max(cg_zmax_[c], float(prims_[i].z1));
    });
  }
}

}  // namespace terramrf::sim
