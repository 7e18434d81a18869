// The LiDAR model against the world's ground truth: walls taller than the top beam reaches, the
// ditch seen as a negative obstacle, and motion distortion.
#include "terramrf/sim/lidar.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <algorithm>
#include <map>
#include <vector>

#include "terramrf/sim/trajectory.hpp"
#include "terramrf/sim/world.hpp"

namespace terramrf::sim {
namespace {

struct Scene {
  World world;
  Trajectory traj;
  LidarModel lidar;
  Frame frame;
  Scene(uint64_t seed, LidarParams lp = {})
      : world([seed] {
          WorldParams p;
          p.seed = seed;
          p.x_min_m = -130;
          p.x_max_m = 250;
          p.terrain_half_width_m = 140;
          return p;
        }()),
        traj(world, TrajectoryParams{}),
        lidar(world, lp) {
    lidar.scan([this](double tau) { return traj.pose(tau); }, 11, frame);
  }
};

int buildingAt(const World& w, const Eigen::Vector3d& p) {
  for (std::size_t k = 0; k < w.buildings().size(); ++k) {
    const Building& b = w.buildings()[k];
    const Eigen::Vector2d d = p.head<2>() - b.centre_m;
    const double c = std::cos(b.yaw_rad), s = std::sin(b.yaw_rad);
    if (std::abs(c * d.x() + s * d.y()) < b.half_size_m.x() + 0.2 &&
        std::abs(-s * d.x() + c * d.y()) < b.half_size_m.y() + 0.2)
      return int(k);
  }
  return -1;
}

TEST(SimLidar, WallsTallerThanTheTopBeamReaches) {
  for (uint64_t seed : {1, 2, 3}) {
    const Scene s(seed);
    const Eigen::Isometry3d T = s.traj.pose(0);
    const double tan_top = std::tan(2.0 * M_PI / 180);
    std::map<int, std::pair<int, double>> hits;  // building -> points, max z
    for (std::size_t i = 0; i < s.frame.points.size(); ++i) {
      if (s.frame.truth.raw[i] != uint32_t(Material::kBuildingWall)) continue;
      const Eigen::Vector3d p =
          T * Eigen::Vector3d(s.frame.points.x[i], s.frame.points.y[i], s.frame.points.z[i]);
      const int b = buildingAt(s.world, p);
      ASSERT_GE(b, 0) << "wall point not on any building";
      auto& h = hits[b];
      ++h.first;
      h.second = std::max(h.second, p.z());
    }
    int clipped = 0;
    for (const auto& [b, h] : hits) {
      if (h.first < 200) continue;
      const Building& bd = s.world.buildings()[b];
      double far = 0;
      for (const auto& c : bd.corners())
        far = std::max(far, (c - T.translation().head<2>()).norm());
      const double reach = T.translation().z() + far * tan_top + 0.3;  // pitch margin
      if (bd.top_z_m > reach && h.second < bd.top_z_m - 1.0) ++clipped;
    }
    EXPECT_GE(clipped, 1) << "seed " << seed << ": no building taller than the top beam's reach";
  }
}

TEST(SimLidar, DitchPointsLieBelowTheRoad) {
  const Scene s(1);
  const Eigen::Isometry3d T = s.traj.pose(0);
  int floor = 0;
  for (std::size_t i = 0; i < s.frame.points.size(); ++i) {
    if (s.frame.truth.raw[i] != uint32_t(Material::kDitchFloor)) continue;
    const Eigen::Vector3d p =
        T * Eigen::Vector3d(s.frame.points.x[i], s.frame.points.y[i], s.frame.points.z[i]);
    EXPECT_NEAR(s.world.smoothHeight(p.x(), p.y()) - p.z(), 1.0, 0.15);
    ++floor;
  }
  EXPECT_GT(floor, 50);
}

TEST(SimLidar, PointsLieOnTheSurfacesTheyAreLabelledWith) {
  LidarParams lp;
  lp.range_noise_m = 0;
  lp.azimuth_step_deg = 0.5;
  const Scene s(2, lp);
  const Eigen::Isometry3d T = s.traj.pose(0);
  int ground = 0;
  for (std::size_t i = 0; i < s.frame.points.size(); ++i) {
    const Material m = Material(s.frame.truth.raw[i]);
    if (m != Material::kAsphalt && m != Material::kGrass && m != Material::kGravel) continue;
    const Eigen::Vector3d p =
        T * Eigen::Vector3d(s.frame.points.x[i], s.frame.points.y[i], s.frame.points.z[i]);
    ASSERT_NEAR(p.z(), s.world.terrainHeight(p.x(), p.y()), 0.02);
    EXPECT_EQ(s.world.groundMaterial(p.x(), p.y()), m);
    ++ground;
  }
  EXPECT_GT(ground, 5000);
}

// Grass and gravel returns come from a blade or stone top: the same beam as without a canopy,
// only shorter (by at most depth / 0.1, the incidence cap), and where the incidence is above the
// cap the return rises by about a uniform 0…depth (median depth / 2); asphalt is untouched.
TEST(SimLidar, GrassAndGravelReturnFromWithinTheirDepth) {
  LidarParams soil;
  soil.range_noise_m = 0;
  soil.azimuth_step_deg = 0.5;
  LidarParams canopy = soil;
  canopy.grass_depth_m = 0.05;
  canopy.gravel_depth_m = 0.02;
  const Scene a(2, soil), b(2, canopy);
  ASSERT_EQ(a.frame.points.size(), b.frame.points.size());
  std::map<Material, std::vector<double>> rise;  // [m]
  for (std::size_t i = 0; i < a.frame.points.size(); ++i) {
    const Material m = Material(a.frame.truth.raw[i]);
    ASSERT_EQ(uint32_t(m), b.frame.truth.raw[i]) << "point " << i;
    const Eigen::Vector3d pa(a.frame.points.x[i], a.frame.points.y[i], a.frame.points.z[i]);
    const Eigen::Vector3d pb(b.frame.points.x[i], b.frame.points.y[i], b.frame.points.z[i]);
    const double shorter = pa.norm() - pb.norm();
    if (m == Material::kAsphalt) ASSERT_EQ(shorter, 0.0) << "point " << i;
    if (m != Material::kGrass && m != Material::kGravel) continue;
    const double depth = m == Material::kGrass ? 0.05 : 0.02;
    ASSERT_GE(shorter, -1e-4) << "point " << i;
    ASSERT_LE(shorter, depth / 0.1 + 1e-4) << "point " << i;
    // Within 12 m the incidence stays above the cap (sin > 0.1 for a 1.73 m high sensor).
    if (pa.head<2>().norm() < 12) rise[m].push_back(pb.z() - pa.z());
  }
  for (auto [m, depth] : {std::pair{Material::kGrass, 0.05}, {Material::kGravel, 0.02}}) {
    std::vector<double>& v = rise[m];
    ASSERT_GT(v.size(), 300u) << materialName(m);
    std::sort(v.begin(), v.end());
    EXPECT_NEAR(v[v.size() / 2], depth / 2, depth * 0.1) << materialName(m);
    EXPECT_NEAR(v[v.size() / 10], depth / 10, depth * 0.1) << materialName(m);
    EXPECT_NEAR(v[v.size() * 9 / 10], depth * 0.9, depth * 0.15) << materialName(m);
  }
}

// A canopy return moves back along its beam only as far as its material reaches: it never hangs
// over the road or the ditch beside it with its own label. A deep canopy makes the shift up to
// 3 m (depth / 0.1), so without the bound many returns would cross an edge.
TEST(SimLidar, CanopyReturnsStayOverTheirMaterial) {
  LidarParams canopy;
  canopy.range_noise_m = 0;
  canopy.azimuth_step_deg = 0.5;
  canopy.grass_depth_m = 0.3;
  canopy.gravel_depth_m = 0.3;
  const Scene s(2, canopy);
  const Eigen::Isometry3d T = s.traj.pose(0);
  std::map<Material, int> seen;
  for (std::size_t i = 0; i < s.frame.points.size(); ++i) {
    const Material m = Material(s.frame.truth.raw[i]);
    if (m != Material::kGrass && m != Material::kGravel) continue;
    const Eigen::Vector3d p =
        T * Eigen::Vector3d(s.frame.points.x[i], s.frame.points.y[i], s.frame.points.z[i]);
    ASSERT_EQ(s.world.groundMaterial(p.x(), p.y()), m)
        << "point " << i << " at " << p.transpose() << " (" << materialName(m) << ")";
    ++seen[m];
  }
  EXPECT_GT(seen[Material::kGrass], 5000);
  EXPECT_GT(seen[Material::kGravel], 1000);
}

TEST(SimLidar, MotionDistortionShiftsLateColumns) {
  LidarParams a, b;
  a.azimuth_step_deg = b.azimuth_step_deg = 1.0;
  a.range_noise_m = b.range_noise_m = 0;
  a.dropout_prob = b.dropout_prob = 0;
  b.motion_distortion = true;
  const Scene sa(4, a), sb(4, b);
  // Column 0 is fired at the sweep start in both; late columns differ by the motion (~0.9 m).
  ASSERT_GT(sa.frame.points.size(), 1000u);
  EXPECT_EQ(sa.frame.points.x[0], sb.frame.points.x[0]);
  double diff = 0;
  std::size_t n = std::min(sa.frame.points.size(), sb.frame.points.size());
  for (std::size_t i = n - 200; i < n; ++i)
    diff = std::max(diff, double(std::abs(sa.frame.points.x[i] - sb.frame.points.x[i])));
  EXPECT_GT(diff, 0.1);
}

}  // namespace
}  // namespace terramrf::sim
