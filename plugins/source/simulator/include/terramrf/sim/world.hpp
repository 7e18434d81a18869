#pragma once
// The procedural world of the simulator: a road winding through gently sloped, rough terrain with
// a ditch beside it, buildings, trees, rocks and parked cars. Everything is generated from one
// seed. Besides ray casting (for the LiDAR and camera models) the world answers ground-truth
// queries (terrain height, class, building heights) for tests and for the meshing module.
//
// World frame: local north-west-up, x = north (the road runs roughly along +x), y = west (left
// of the driving direction), z = up, metres.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include "terramrf/label_set.hpp"
#include "terramrf/sim/materials.hpp"

namespace terramrf::sim {

struct WorldParams {
  uint64_t seed = 1;
  double x_min_m = -150;              ///< start of the generated strip along x [m]
  double x_max_m = 450;               ///< end of the generated strip along x [m]
  double object_half_width_m = 80;    ///< objects are placed within this distance of the road [m]
  double terrain_half_width_m = 230;  ///< tabulated terrain reaches this far from the road [m]
  double road_width_m = 6.5;          ///< asphalt width, two lanes [m]
  double shoulder_m = 0.8;            ///< gravel strip on each side of the asphalt [m]
  double road_curve_m = 12;           ///< lateral amplitude of the road's long bends [m]
  double hill_height_m = 2.0;         ///< amplitude of the terrain's hills [m]
  double rough_noise_m = 0.04;        ///< max small-scale height noise of grass/gravel [m]
  double ditch_depth_m = 1.0;         ///< [m]
  double ditch_width_m = 1.5;         ///< top width [m]
  double ditch_gap_m = 1.0;           ///< from the asphalt edge to the ditch's near edge [m]
  double obstacle_density = 1.0;      ///< scales the number of buildings, trees, rocks, cars [1]
  double crown_density_per_m = 0.6;   ///< hit rate of a ray inside a tree crown [1/m]
  double terrain_cell_m = 0.5;        ///< spacing of the tabulated smooth heightfield [m]
};

/// A box-shaped building standing on the terrain.
struct Building {
  Eigen::Vector2d centre_m = Eigen::Vector2d::Zero();
  double yaw_rad = 0;                                     ///< of the local x axis (length)
  Eigen::Vector2d half_size_m = Eigen::Vector2d::Zero();  ///< half length (local x), half depth (y)
  double base_z_m = 0;    ///< bottom of the box, buried below the lowest ground of the footprint
  double ground_z_m = 0;  ///< terrain height at the centre [m]
  double top_z_m = 0;     ///< flat roof [m]
  std::array<uint8_t, 3> wall_rgb{200, 190, 170};
  std::array<uint8_t, 3> roof_rgb{120, 60, 50};
  /// True height above the ground at the centre [m].
  double height_m() const { return top_z_m - ground_z_m; }
  /// Footprint corners, counter-clockwise [m].
  std::array<Eigen::Vector2d, 4> corners() const;
};

/// Trunk (vertical cylinder) plus a porous ellipsoidal crown.
struct Tree {
  Eigen::Vector2d position_m = Eigen::Vector2d::Zero();
  double ground_z_m = 0;
  double trunk_radius_m = 0.2;
  double trunk_top_z_m = 0;  ///< the trunk ends inside the crown
  Eigen::Vector3d crown_centre_m = Eigen::Vector3d::Zero();
  double crown_radius_m = 2;       ///< horizontal semi-axis
  double crown_half_height_m = 2;  ///< vertical semi-axis
  int near_building = -1;          ///< index of the building it was planted next to, or -1
};

/// A solid ellipsoid, partly buried.
struct Rock {
  Eigen::Vector3d centre_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d radii_m = Eigen::Vector3d::Ones();
};

/// A parked car: body box plus a narrower cabin box.
struct Car {
  Eigen::Vector2d centre_m = Eigen::Vector2d::Zero();
  double yaw_rad = 0;
  Eigen::Vector2d half_size_m{2.25, 0.9};
  double ground_z_m = 0;
  double top_z_m = 0;
  std::array<uint8_t, 3> rgb{180, 30, 30};
};

/// A trench beside the road (negative obstacle), on the right side of the driving direction.
struct Ditch {
  double x_begin_m = 0, x_end_m = 0;  ///< extent along x [m]
  double offset_m = 0;      ///< signed lateral offset of its centre line from the road's [m]
  double half_width_m = 0;  ///< at the top [m]
  double floor_half_width_m = 0;
  double depth_m = 0;
};

struct RayHit {
  double t_m = std::numeric_limits<double>::infinity();  ///< distance along the ray [m]
  Material material = Material::kNone;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< unit, facing the ray's origin side
  int primitive = -1;  ///< internal primitive index, -1 for the terrain
  bool hit() const { return material != Material::kNone; }
};

/// Per-caller scratch memory (so casting stays const and callers can run in parallel).
class RayScratch {
 private:
  friend class World;
  std::vector<uint32_t> stamp_;
  uint32_t counter_ = 0;
};

namespace detail {
/// An analytic primitive of the ray caster.
struct Primitive {
  enum Type : uint8_t { kBox, kCylinder, kEllipsoid };
  enum Owner : uint8_t { kBuilding, kTree, kRock, kCar, kCarCabin };
  Type type = kBox;
  Owner owner = kBuilding;
  Material material = Material::kNone;
  bool porous = false;
  int owner_index = 0;
  double cx = 0, cy = 0, cz = 0;                        ///< centre (cz: ellipsoid only)
  double cs = 1, sn = 0;                                ///< box yaw cos/sin
  double hx = 0, hy = 0;                                ///< box half sizes; cylinder radius in hx
  double z0 = 0, z1 = 0;                                ///< vertical extent (box, cylinder)
  Eigen::Vector3d inv_radii = Eigen::Vector3d::Ones();  ///< ellipsoid
  double min_x = 0, min_y = 0, max_x = 0, max_y = 0;    ///< xy bounds for the culling grid
};
}  // namespace detail

class World {
 public:
  explicit World(const WorldParams& params);

  const WorldParams& params() const { return p_; }
  /// Steepest grade the road can have with hills of this amplitude, whatever the seed [1]
  /// (hill_height_m · 2π / 90 m: 14 % for the default 2 m).
  static double roadGradeBound(double hill_height_m);
  /// Memory the smooth-height table of a world with these parameters takes, within a few
  /// percent [bytes]: ~5 KB per metre of strip with a 140 m half width, the most of the world.
  static double terrainTableBytes(const WorldParams& p);

  // ---- road ----
  /// y of the road's centre line at x [m] (analytic, smooth).
  double roadCentreY(double x) const;
  /// dy/dx of the centre line [1].
  double roadCentreSlope(double x) const;
  /// Signed distance of (x, y) from the centre line, left (+y side) positive [m].
  double lateralOffset(double x, double y) const;

  // ---- terrain (no objects) ----
  /// Smooth ground height without small-scale noise and without the ditch (analytic) [m].
  double smoothHeight(double x, double y) const;
  /// Ground height as the sensors see it: tabulated smooth height + roughness − ditch [m].
  double terrainHeight(double x, double y) const;
  /// Ground material at (x, y), ignoring objects.
  Material groundMaterial(double x, double y) const;
  /// Project class of the ground at (x, y), ignoring objects.
  LabelId groundClass(double x, double y) const { return projectClass(groundMaterial(x, y)); }

  // ---- top surface (terrain plus objects) ----
  /// Material of the highest surface above (x, y): an object's if one covers it, else the ground.
  Material topMaterial(double x, double y) const;
  /// Project class of topMaterial().
  LabelId classAt(double x, double y) const { return projectClass(topMaterial(x, y)); }
  /// Height of the highest surface above (x, y) (object tops, crowns included) [m].
  double surfaceHeight(double x, double y) const;

  // ---- objects (ground truth) ----
  const std::vector<Building>& buildings() const { return buildings_; }
  const std::vector<Tree>& trees() const { return trees_; }
  const std::vector<Rock>& rocks() const { return rocks_; }
  const std::vector<Car>& cars() const { return cars_; }
  const std::vector<Ditch>& ditches() const { return ditches_; }
  /// If the landmark building (tall, left of the road, 15–25 m ahead of x = 0) is missing because
  /// it did not fit within object_half_width_m: the distance from the road it needed [m]; else 0.
  double landmarkWidthNeeded_m() const { return landmark_width_needed_m_; }

  // ---- ray casting ----
  RayScratch makeScratch() const;
  /// Nearest surface along origin + t·dir (dir unit) for t in (t_min, t_max]. `ray_key` seeds
  /// the porous crowns' pass-through decision so a ray is reproducible.
  RayHit castRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min,
                 double t_max, uint64_t ray_key, RayScratch& scratch) const;
  /// Surface colour (linear 0..255 RGB, before lighting) at a hit, for the camera.
  Eigen::Vector3f albedo(const RayHit& hit) const;
  /// Owner object of a hit primitive (for tests): building/tree/rock/car index, or -1.
  int hitObject(const RayHit& hit, detail::Primitive::Owner* owner = nullptr) const;

  /// Upper bound of |∇| of the tabulated smooth heightfield [1] (used by the terrain marcher).
  double slopeBound() const { return slope_bound_; }

 private:
  // generation (world_gen.cpp)
  void buildTerrainTable();
  void generateObjects();
  void buildCullingGrid();
  // terrain helpers (terrain.cpp)
  double naturalHeight(double x, double y) const;
  double roadProfile(double x) const;  ///< height of the road's centre line at x [m]
  double tableHeight(double x, double y) const;
  float roughNoise(double x, double y) const;
  /// What the terrain marcher knows about the ray so far.
  struct MarchState {
    double t_above = 0;   ///< last distance known to be above the ground [m]
    double f_above = -1;  ///< ray z − ground there if evaluated (> 0), else −1 [m]
    bool above_known = false;
  };
  /// Sphere tracing within one table block; returns true when the ground was hit (sets best).
  bool marchBlock(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double ta, double tb,
                  double rate, MarchState& st, RayHit& best) const;
  double roughness(double x, double y, double lateral) const;
  /// Depth of the ditch at (x, lateral offset) [m]; sets *wall if on a wall.
  double ditchDepth(double x, double lateral, bool* wall = nullptr) const;
  double lateralFast(double x, double y) const;
  /// Normal of the ground at (x, y) whose height h is already known.
  Eigen::Vector3d terrainNormal(double x, double y, double h) const;
  // casting (raycast.cpp)
  void castPrimitives(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min,
                      uint64_t ray_key, RayScratch& s, RayHit& best) const;
  bool intersect(const detail::Primitive& pr, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                 double t_min, double t_max, uint64_t ray_key, int index, RayHit& hit) const;
  void castTerrain(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min,
                   RayHit& best) const;
  /// Primitive indices whose culling bounds contain (x, y).
  template <class F>
  void forEachPrimitiveAt(double x, double y, F&& f) const;

  WorldParams p_;
  // road: analytic centre line = Σ amp·sin(freq·x + phase)
  std::array<double, 2> road_amp_{}, road_freq_{}, road_phase_{};
  // hills: Σ amp·sin(fx·x + fy·y + phase)
  struct Wave {
    double amp, fx, fy, phase;
  };
  std::vector<Wave> hills_;
  uint32_t noise_seed_ = 0;
  double landmark_width_needed_m_ = 0;
  // centre-line table for fast lateral offsets
  double cl_x0_ = 0, cl_dx_ = 0.25;
  std::vector<float> cl_y_, cl_inv_norm_;
  // smooth heightfield table
  double tb_x0_ = 0, tb_y0_ = 0, tb_inv_cell_ = 2, tb_fx_max_ = 0, tb_fy_max_ = 0;
  int tb_nx_ = 0, tb_ny_ = 0;
  std::vector<float> tb_h_;
  double tb_min_h_ = 0, tb_max_h_ = 0;
  double slope_bound_ = 0.3;
  // coarse blocks of the table (kBlockCells² cells): max height and gradient bound, so the
  // marcher skips blocks the ray passes above and takes larger safe steps on flat ground
  int bk_nx_ = 0, bk_ny_ = 0;
  std::vector<float> bk_max_, bk_slope_;
  // lattice values of the roughness noise (a table is ~3× cheaper than hashing in the hot loop)
  std::vector<float> rough_lattice_;
  // index of the ditch overlapping [x, x + 1 m) relative to cl_x0_, or -1
  std::vector<int16_t> ditch_at_;
  // objects
  std::vector<Building> buildings_;
  std::vector<Tree> trees_;
  std::vector<Rock> rocks_;
  std::vector<Car> cars_;
  std::vector<Ditch> ditches_;
  std::vector<detail::Primitive> prims_;
  double prim_max_z_ = 0;
  // uniform 2D culling grid (CSR)
  double cg_x0_ = 0, cg_y0_ = 0, cg_cell_ = 4.0;
  int cg_nx_ = 0, cg_ny_ = 0;
  std::vector<uint32_t> cg_offsets_, cg_items_;
  std::vector<float> cg_zmin_, cg_zmax_;
};

}  // namespace terramrf::sim
