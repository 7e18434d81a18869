#pragma once
// A simulated drive for the meshing tests: the simulator's world, trajectory, LiDAR and a
// 512 × 256 camera (the paper's image size), frames built as the simulator source builds them.
#include <memory>

#include "terramrf/frame.hpp"
#include "terramrf/sim/camera.hpp"
#include "terramrf/sim/lidar.hpp"
#include "terramrf/sim/random.hpp"
#include "terramrf/sim/trajectory.hpp"
#include "terramrf/sim/world.hpp"

namespace terramrf::test {

struct SimScene {
  sim::World world;
  sim::Trajectory traj;
  sim::LidarModel lidar;
  sim::CameraRenderer camera;
  uint64_t seed;
  double period_s = 0.1;

  static sim::WorldParams worldParams(uint64_t seed) {
    sim::WorldParams p;
    p.seed = seed;
    p.x_min_m = -130;
    p.x_max_m = 260;
    p.terrain_half_width_m = 140;
    return p;
  }
  static sim::CameraParams cameraParams() {
    sim::CameraParams c;
    c.width = 512;
    c.height = 256;
    c.fx = 296;  // the simulator's 640 px / 370 px field of view at 512 px
    return c;
  }
  static sim::LidarParams lidarParams() {
    sim::LidarParams l;
    l.azimuth_step_deg = 0.18;  // half the columns: faster tests, same vertical geometry
    return l;
  }

  explicit SimScene(uint64_t s, sim::TrajectoryParams tp = {})
      : world(worldParams(s)),
        traj(world, tp),
        lidar(world, lidarParams()),
        camera(world, cameraParams()),
        seed(s) {}

  Frame frame(std::size_t i, bool with_camera = true) const {
    Frame f;
    f.id = std::to_string(i);
    const double t = double(i) * period_s;
    f.timestamp_s = t;
    lidar.scan([&](double tau) { return traj.pose(t + tau); },
               sim::hashKeys(seed, uint64_t(sim::Stream::kLidar), i), f);
    f.pose = traj.pose(t);
    if (with_camera)
      f.cameras.push_back(camera.render(*f.pose, sim::hashKeys(seed, uint64_t(sim::Stream::kCamera), i)));
    return f;
  }
};

}  // namespace terramrf::test
