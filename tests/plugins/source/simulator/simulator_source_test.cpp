// The "simulator" source plugin as the pipeline sees it: determinism, HDL-64E geometry, classes,
// camera, sensor samples, parameter errors, and a (non-asserted) timing note.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"
#include "terramrf/sim/lidar.hpp"
#include "terramrf/sim/materials.hpp"
#include "terramrf/sim/simulation.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

std::unique_ptr<Plugin> makeSource(const std::string& params) {
  PluginRegistry reg({test::pluginDir()});
  auto p = reg.create("simulator");
  PluginContext ctx;
  setParams(*p, params, ctx);
  return p;
}
Source& src(std::unique_ptr<Plugin>& p) { return dynamic_cast<Source&>(*p); }

/// Frame 0 of the default configuration, read once for several tests.
const Frame& defaultFrame0() {
  static const Frame f = [] {
    auto p = makeSource("{frames: 5}");
    return src(p).read(0);
  }();
  return f;
}

void expectSameFrame(const Frame& a, const Frame& b) {
  ASSERT_EQ(a.points.size(), b.points.size());
  EXPECT_EQ(a.points.x, b.points.x);
  EXPECT_EQ(a.points.y, b.points.y);
  EXPECT_EQ(a.points.z, b.points.z);
  EXPECT_EQ(a.points.intensity, b.points.intensity);
  EXPECT_EQ(a.points.ring, b.points.ring);
  EXPECT_EQ(a.points.time_s, b.points.time_s);
  EXPECT_EQ(a.truth.label, b.truth.label);
  EXPECT_EQ(a.truth.raw, b.truth.raw);
  EXPECT_EQ(a.timestamp_s, b.timestamp_s);
  ASSERT_TRUE(a.pose && b.pose);
  EXPECT_TRUE(a.pose->isApprox(*b.pose, 0.0));
  ASSERT_TRUE(a.truth_pose && b.truth_pose);
  EXPECT_TRUE(a.truth_pose->isApprox(*b.truth_pose, 0.0));
  ASSERT_EQ(a.imu.size(), b.imu.size());
  for (std::size_t i = 0; i < a.imu.size(); ++i)
    EXPECT_EQ(a.imu[i].accel_m_s2, b.imu[i].accel_m_s2);
  ASSERT_EQ(a.gps.size(), b.gps.size());
  for (std::size_t i = 0; i < a.gps.size(); ++i)
    EXPECT_EQ(a.gps[i].position_m, b.gps[i].position_m);
  ASSERT_EQ(a.cameras.size(), b.cameras.size());
  for (std::size_t i = 0; i < a.cameras.size(); ++i) {
    EXPECT_EQ(a.cameras[i].image->data, b.cameras[i].image->data);
    EXPECT_EQ(a.cameras[i].truth->data, b.cameras[i].truth->data);
  }
}

TEST(SimulatorSource, DeterministicAndIndependentOfReadOrder) {
  const std::string params =
      "{frames: 4, seed: 5, camera_width: 160, camera_height: 64, camera_fx: 90}";
  auto a = makeSource(params), b = makeSource(params);
  EXPECT_EQ(src(a).size(), 4u);
  EXPECT_EQ(src(a).frameId(3), "000003");
  const Frame a1 = src(a).read(1), a2 = src(a).read(2);
  const Frame b2 = src(b).read(2), b1 = src(b).read(1);  // other order, other instance
  expectSameFrame(a1, b1);
  expectSameFrame(a2, b2);
  EXPECT_EQ(a2.id, "000002");
  EXPECT_DOUBLE_EQ(a2.timestamp_s, 0.2);
  // Another seed: another world and other noise.
  auto c = makeSource("{frames: 4, seed: 6, enable_camera: false}");
  const Frame c1 = src(c).read(1);
  EXPECT_NE(c1.points.size(), a1.points.size());
  EXPECT_FALSE(c1.pose->isApprox(*a1.pose, 1e-6));
  // Next frame moves ~0.9 m forward.
  EXPECT_NEAR((a2.pose->translation() - a1.pose->translation()).norm(), 0.9, 0.1);
}

// The strip is sized from frames, ranges and the camera; what is guaranteed of the LiDAR frames
// (docs/plugins/simulator.md): identical points, rings, times and poses; labels equal except a
// few points at a grass/gravel edge (with their intensities), other intensities but for a few
// last bits (the lattices' origins
// follow the strip, so a hit can differ by ~1e-14 m inside the float output). Seed 4 alone was
// tested and passed exactly; seeds 13 and 40 flip 2 and 8 labels (1–40: at most 8 of ~235k).
// Every simulated frame has the vehicle's pose, and the source says so: stages that read the
// pose (a temporal one) are checked against what the source declares. It declared nothing, so
// such a stage was refused over the simulator.
TEST(SimulatorSource, DeclaresThePoseEveryFrameHas) {
  auto p = makeSource("{frames: 2, enable_camera: false}");
  EXPECT_EQ(src(p).writes(), std::vector<std::string>{artefacts::kPose});
  EXPECT_TRUE(defaultFrame0().pose.has_value());
}

TEST(SimulatorSource, SeedMeansOneWorldWhateverTheFrameCountOrCamera) {
  const std::string tiny_camera = "camera_width: 64, camera_height: 64, camera_fx: 40";
  for (const auto& [seed, other] :
       std::vector<std::pair<int, std::string>>{{4, "frames: 300, " + tiny_camera},
                                                {13, "frames: 1, " + tiny_camera},
                                                {40, "frames: 1, " + tiny_camera},
                                                {36, "frames: 300, enable_camera: false"}}) {
    const std::string s = "seed: " + std::to_string(seed);
    auto a = makeSource("{frames: 1, enable_camera: false, " + s + "}");
    auto b = makeSource("{" + other + ", " + s + "}");
    const Frame fa = src(a).read(0), fb = src(b).read(0);
    ASSERT_EQ(fa.points.size(), fb.points.size()) << s;
    EXPECT_EQ(fa.points.x, fb.points.x) << s;
    EXPECT_EQ(fa.points.y, fb.points.y) << s;
    EXPECT_EQ(fa.points.z, fb.points.z) << s;
    EXPECT_EQ(fa.points.ring, fb.points.ring) << s;
    EXPECT_EQ(fa.points.time_s, fb.points.time_s) << s;
    EXPECT_TRUE(fa.pose->isApprox(*fb.pose, 0.0)) << s;
    std::size_t labels = 0, intensities = 0;
    using M = sim::Material;
    for (std::size_t i = 0; i < fa.points.size(); ++i) {
      const uint32_t ra = fa.truth.raw[i], rb = fb.truth.raw[i];
      if (ra != rb) {
        ++labels;
        EXPECT_TRUE((ra == uint32_t(M::kGrass) && rb == uint32_t(M::kGravel)) ||
                    (ra == uint32_t(M::kGravel) && rb == uint32_t(M::kGrass)))
            << s << " point " << i << ": " << ra << " vs " << rb;
      }
      if (ra == rb && fa.points.intensity[i] != fb.points.intensity[i]) {  // else reflectivity
        ++intensities;
        EXPECT_NEAR(fa.points.intensity[i], fb.points.intensity[i], 1e-6) << s << " point " << i;
      }
    }
    EXPECT_LE(labels, 10u) << s;
    EXPECT_LE(intensities, 12u) << s;
  }
}

TEST(SimulatorSource, LibraryRebuildsThePluginsWorld) {
  // A module that needs ground truth (meshing, evaluation) builds sim::Simulation from the same
  // params as the pipeline's source and gets the identical world and frames.
  const std::string params = "{frames: 3, seed: 9, enable_camera: false, azimuth_step_deg: 0.5}";
  auto p = makeSource(params);
  const sim::Simulation sim(sim::parseSimulationConfig(params));
  EXPECT_EQ(sim.size(), 3u);
  expectSameFrame(src(p).read(2), sim.frame(2));
  EXPECT_FALSE(sim.world().buildings().empty());
  const Eigen::Vector3d at = sim.frame(0).pose->translation();
  EXPECT_EQ(sim.world().classAt(at.x(), at.y()), labels::kRoad);
  EXPECT_THROW(sim::parseSimulationConfig("{frames: -1}"), std::exception);
  EXPECT_THROW(sim::parseSimulationConfig("{no_such_param: 1}"), std::exception);
}

// The simulator knows where the sensor was: the trajectory's pose at the frame's time is the
// frame's truth_pose (what an egomotion estimate is scored against), and its pose until an
// egomotion stage replaces it. No covariance: the source estimated nothing.
TEST(SimulatorSource, TruthPoseIsTheTrajectorysPoseAtTheFramesTime) {
  const std::string params = "{frames: 4, seed: 3, enable_camera: false, azimuth_step_deg: 1.0}";
  auto p = makeSource(params);
  const sim::Simulation sim(sim::parseSimulationConfig(params));
  for (std::size_t i = 0; i < 4; ++i) {
    const Frame f = src(p).read(i);
    ASSERT_TRUE(f.truth_pose.has_value()) << i;
    const Eigen::Isometry3d want = sim.trajectory().pose(sim.frameTime(i));
    EXPECT_TRUE(f.truth_pose->isApprox(want, 0.0)) << i << "\n" << f.truth_pose->matrix();
    ASSERT_TRUE(f.pose.has_value()) << i;
    EXPECT_TRUE(f.pose->isApprox(*f.truth_pose, 0.0)) << i;
    EXPECT_FALSE(f.pose_covariance.has_value()) << i;
  }
}

TEST(SimulatorSource, Hdl64eRingsAnglesAndScanOrder) {
  const Frame& f = defaultFrame0();
  ASSERT_TRUE(f.points.hasRing());
  ASSERT_TRUE(f.points.hasTime());
  const auto& el = sim::hdl64ElevationsDeg();
  EXPECT_NEAR(el.front(), 2.0, 1e-9);
  EXPECT_NEAR(el[31], -8.333, 1e-3);
  EXPECT_NEAR(el[32], -8.83, 1e-9);
  EXPECT_NEAR(el.back(), -24.33, 1e-9);
  for (int r = 1; r < 32; ++r) EXPECT_NEAR(el[r - 1] - el[r], 1.0 / 3.0, 1e-9);
  for (int r = 33; r < 64; ++r) EXPECT_NEAR(el[r - 1] - el[r], 0.5, 1e-9);
  std::set<uint16_t> rings;
  double max_err = 0;
  for (std::size_t i = 0; i < f.points.size(); ++i) {
    const uint16_t r = f.points.ring[i];
    ASSERT_LT(r, 64);
    rings.insert(r);
    const double e =
        std::atan2(f.points.z[i], std::hypot(f.points.x[i], f.points.y[i])) * 180 / M_PI;
    max_err = std::max(max_err, std::abs(e - el[r]));
    ASSERT_GE(f.points.time_s[i], 0.0f);
    ASSERT_LT(f.points.time_s[i], 0.1f);
  }
  EXPECT_EQ(rings.size(), 64u);
  EXPECT_LT(max_err, 0.01) << "elevation of each point = its ring's angle";
  // Column order: rings ascend within a column, time never decreases, ~4000 columns.
  std::size_t columns = 1;
  for (std::size_t i = 1; i < f.points.size(); ++i) {
    ASSERT_GE(f.points.time_s[i], f.points.time_s[i - 1]);
    if (f.points.time_s[i] > f.points.time_s[i - 1])
      ++columns;
    else
      ASSERT_GT(f.points.ring[i], f.points.ring[i - 1]);
  }
  EXPECT_GT(columns, 3900u);
  EXPECT_LE(columns, 4000u);
  // Range: every point within max range; the lowest ring sees the ground ~3.8 m away.
  double min_r63 = 1e9;
  for (std::size_t i = 0; i < f.points.size(); ++i) {
    const double r = std::sqrt(f.points.x[i] * f.points.x[i] + f.points.y[i] * f.points.y[i] +
                               f.points.z[i] * f.points.z[i]);
    ASSERT_LE(r, 100.0 + 1e-3);
    if (f.points.ring[i] == 63) min_r63 = std::min(min_r63, r);
  }
  EXPECT_NEAR(min_r63, 1.73 / std::sin(24.33 * M_PI / 180), 0.4);
}

// docs/plugins/simulator.md: the head spins clockwise seen from above and column 0 looks
// backwards; a point's time is its column's firing time. So every point's azimuth is
// π − 2π · time_s / 0.1 s (mod 2π): backwards at 0, left at 0.025 s, forward at 0.05 s, right at
// 0.075 s. Checked on every point of both orders (RingOrderIsKittiLike looks at two).
TEST(SimulatorSource, ScanIsClockwiseFromBehind) {
  for (const char* order : {"column", "ring"}) {
    auto p = makeSource(std::string("{frames: 1, enable_camera: false, azimuth_step_deg: 0.36, ") +
                        "point_order: " + order + "}");
    const Frame f = src(p).read(0);
    ASSERT_GT(f.points.size(), 10000u);
    const double step = 0.36 * M_PI / 180;
    double worst = 0;
    std::size_t quarter[4] = {0, 0, 0, 0};
    for (std::size_t i = 0; i < f.points.size(); ++i) {
      const double expected = M_PI - 2 * M_PI * f.points.time_s[i] / 0.1;
      const double az = std::atan2(f.points.y[i], f.points.x[i]);
      const double d = std::remainder(az - expected, 2 * M_PI);
      worst = std::max(worst, std::abs(d));
      // Which way the head looks: 0 behind, 1 left, 2 ahead, 3 right.
      const int q = std::min(3, int(f.points.time_s[i] / 0.025));
      const double dir[4][2] = {{-1, 0}, {0, 1}, {1, 0}, {0, -1}};
      quarter[q] += f.points.x[i] * dir[q][0] + f.points.y[i] * dir[q][1] > 0;
    }
    EXPECT_LT(worst, 0.5 * step + 1e-4) << order << ": azimuth off its column's time";
    for (int q = 0; q < 4; ++q) EXPECT_GT(quarter[q], 1000u) << order << " quarter " << q;
    // Column 0 (time 0) looks straight back; it is the first in column order.
    if (std::string(order) == "column") {
      EXPECT_EQ(f.points.time_s[0], 0.0f);
      EXPECT_LT(f.points.x[0], 0.0f);
      EXPECT_LT(std::abs(std::remainder(std::atan2(f.points.y[0], f.points.x[0]) - M_PI, 2 * M_PI)),
                0.5 * step + 1e-4);
    }
  }
}

TEST(SimulatorSource, RingOrderIsKittiLike) {
  auto p =
      makeSource("{frames: 1, enable_camera: false, point_order: ring, azimuth_step_deg: 0.36}");
  const Frame f = src(p).read(0);
  for (std::size_t i = 1; i < f.points.size(); ++i)
    ASSERT_GE(f.points.ring[i], f.points.ring[i - 1]);
  // Within a ring the azimuth sweeps counter-clockwise from 0 (forward).
  std::size_t i0 = 0;
  while (i0 < f.points.size() && f.points.ring[i0] != 40) ++i0;
  ASSERT_LT(i0 + 10, f.points.size());
  const double a0 = std::atan2(f.points.y[i0], f.points.x[i0]);
  const double a1 = std::atan2(f.points.y[i0 + 5], f.points.x[i0 + 5]);
  EXPECT_NEAR(a0, 0.0, 0.05);
  EXPECT_GT(a1, a0);
  EXPECT_EQ(f.points.size(), f.truth.label.size());
}

TEST(SimulatorSource, ClassesAndPointCount) {
  const Frame& f = defaultFrame0();
  const std::size_t n = f.points.size();
  EXPECT_GT(n, 150000u);
  EXPECT_LE(n, 64u * 4000u);
  ASSERT_EQ(f.truth.label.size(), n);
  ASSERT_EQ(f.truth.raw.size(), n);
  std::map<LabelId, std::size_t> cls;
  std::map<uint32_t, std::size_t> raw;
  for (std::size_t i = 0; i < n; ++i) {
    ++cls[f.truth.label[i]];
    ++raw[f.truth.raw[i]];
    ASSERT_EQ(f.truth.label[i], sim::projectClass(sim::Material(f.truth.raw[i])));
  }
  EXPECT_EQ(cls[labels::kUnknown], 0u) << "every return hits a labelled surface";
  EXPECT_GT(cls[labels::kRoad], n / 10);
  EXPECT_GT(cls[labels::kRough], n / 10);
  EXPECT_GT(cls[labels::kObstacle], n / 20);
  using M = sim::Material;
  for (M m : {M::kAsphalt, M::kLaneMarking, M::kGrass, M::kGravel, M::kBuildingWall, M::kTreeTrunk,
              M::kTreeCrown, M::kDitchFloor, M::kDitchWall})
    EXPECT_GT(raw[uint32_t(m)], 20u) << sim::materialName(m);
  // Intensity by material: lane markings are bright, asphalt dark.
  double mark = 0, asph = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (f.truth.raw[i] == uint32_t(M::kLaneMarking)) mark += f.points.intensity[i];
    if (f.truth.raw[i] == uint32_t(M::kAsphalt)) asph += f.points.intensity[i];
  }
  EXPECT_GT(mark / raw[uint32_t(M::kLaneMarking)], 3 * asph / raw[uint32_t(M::kAsphalt)]);
}

TEST(SimulatorSource, CameraImageAndPixelTruth) {
  const Frame& f = defaultFrame0();
  ASSERT_EQ(f.cameras.size(), 1u);
  const CameraImage& cam = f.cameras[0];
  EXPECT_EQ(cam.model.name, "image_2");
  ASSERT_TRUE(cam.image && cam.truth);
  EXPECT_EQ(cam.image->width, 640);
  EXPECT_EQ(cam.image->height, 256);
  EXPECT_EQ(cam.image->channels, 3);
  EXPECT_EQ(cam.truth->width, 640);
  EXPECT_EQ(cam.truth->height, 256);
  EXPECT_EQ(cam.truth->channels, 1);
  // P = K [I | 0].
  EXPECT_DOUBLE_EQ(cam.model.P(0, 0), 370.0);
  EXPECT_DOUBLE_EQ(cam.model.P(0, 3), 0.0);
  std::map<int, std::size_t> px;
  for (uint8_t v : cam.truth->data) ++px[v];
  EXPECT_GT(px[labels::kRoad], 5000u);
  EXPECT_GT(px[labels::kUnknown], 5000u) << "sky";
  EXPECT_GT(px[labels::kRough], 5000u);
  EXPECT_GT(px[labels::kObstacle], 1000u);
  // Top centre is sky (blue-ish, unknown); bottom centre is road (grey).
  const uint8_t* sky = cam.image->at(320, 2);
  EXPECT_GT(sky[2], sky[0]);
  EXPECT_EQ(*cam.truth->at(320, 2), labels::kUnknown);
  EXPECT_EQ(*cam.truth->at(300, 250), labels::kRoad);
  // LiDAR and camera see the same world through T_camera_lidar and P: the class of a point
  // equals the pixel truth where it projects (except at edges and parallax occlusions). The
  // agreement is 0.9935 over the ~44k points in view; it was asserted > 0.93, which a 5 px error
  // in P also passed (0.958), so the bound is tight now and the exact projection must beat half
  // a pixel off in u and in v (0.9915–0.9924; 2 px off: 0.975–0.981).
  auto agreement = [&](double du, double dv, std::size_t* n_in = nullptr) {
    std::size_t in = 0, agree = 0;
    for (std::size_t i = 0; i < f.points.size(); ++i) {
      const auto uv = cam.model.project({f.points.x[i], f.points.y[i], f.points.z[i]});
      if (!uv) continue;
      const int u = int(std::lround(uv->x() + du)), v = int(std::lround(uv->y() + dv));
      if (u < 0 || v < 0 || u >= 640 || v >= 256) continue;
      ++in;
      agree += *cam.truth->at(u, v) == f.truth.label[i];
    }
    if (n_in) *n_in = in;
    return double(agree) / std::max<std::size_t>(in, 1);
  };
  std::size_t in = 0;
  const double exact = agreement(0, 0, &in);
  EXPECT_GT(in, 20000u);
  EXPECT_GE(exact, 0.985) << in << " points";
  for (double shift : {-0.5, 0.5}) {
    EXPECT_GT(exact, agreement(shift, 0)) << "u shifted by " << shift << " px";
    EXPECT_GT(exact, agreement(0, shift)) << "v shifted by " << shift << " px";
  }
}

// A second yaw adds a camera looking that way (image_3): the rear one sees what lies behind the
// vehicle, its pixel truth agrees with the LiDAR points there, and the first camera is the same
// as in the one-camera rig.
TEST(SimulatorSource, RearCameraSeesBehindTheVehicle) {
  auto p = makeSource(
      "{frames: 2, camera_yaws_deg: [0, 180], camera_width: 320, "
      "camera_height: 128, camera_fx: 185}");
  const Frame f = src(p).read(1);
  ASSERT_EQ(f.cameras.size(), 2u);
  EXPECT_EQ(f.cameras[0].model.name, "image_2");
  EXPECT_EQ(f.cameras[1].model.name, "image_3");
  // Known before any frame is read (outputs name a failed frame's camera images with them).
  EXPECT_EQ(static_cast<Source&>(*p).cameraNames(),
            (std::vector<std::string>{"image_2", "image_3"}));
  EXPECT_TRUE(static_cast<Source&>(*makeSource("{enable_camera: false}")).cameraNames().empty());
  auto one = makeSource("{frames: 2, camera_width: 320, camera_height: 128, camera_fx: 185}");
  const Frame g = src(one).read(1);
  ASSERT_EQ(g.cameras.size(), 1u);
  EXPECT_EQ(g.cameras[0].image->data, f.cameras[0].image->data);
  const CameraModel& rear = f.cameras[1].model;
  EXPECT_FALSE(rear.project({10, 0, -1}).has_value());  // ahead
  EXPECT_TRUE(rear.project({-10, 0, -1}).has_value());  // behind, low: the road
  // The rear camera sits as far behind the LiDAR as the front one sits ahead of it.
  EXPECT_NEAR(
      (rear.T_camera_lidar.inverse().translation() - Eigen::Vector3d(-0.27, 0, -0.08)).norm(), 0.0,
      1e-9);
  std::size_t in = 0, agree = 0;
  for (std::size_t i = 0; i < f.points.size(); i += 5) {
    const auto uv = rear.project({f.points.x[i], f.points.y[i], f.points.z[i]});
    if (!uv) continue;
    EXPECT_LT(f.points.x[i], 0.3f);
    ++in;
    agree += *f.cameras[1].truth->at(int(std::lround(uv->x())), int(std::lround(uv->y()))) ==
             f.truth.label[i];
  }
  EXPECT_GT(in, 1000u);
  EXPECT_GT(double(agree) / in, 0.9) << agree << " of " << in;
  // KITTI's calibration holds two colour cameras.
  try {
    makeSource("{camera_yaws_deg: [0, 90, 180]}");
    FAIL() << "expected ParamError";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("camera_yaws_deg"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("has 3 entries; expected one or two"), std::string::npos)
        << e.what();
  }
}

TEST(SimulatorSource, SensorSamplesBetweenFrames) {
  auto p = makeSource("{frames: 6, enable_camera: false, azimuth_step_deg: 1.0}");
  std::size_t gps = 0;
  for (std::size_t i = 0; i < 6; ++i) {
    const Frame f = src(p).read(i);
    ASSERT_EQ(f.imu.size(), 10u) << "100 Hz IMU, 10 Hz frames";
    ASSERT_EQ(f.odometry.size(), 2u) << "20 Hz odometry";
    gps += f.gps.size();
    for (const ImuSample& s : f.imu) {
      EXPECT_GT(s.t_s, f.timestamp_s - 0.1 + 1e-9);
      EXPECT_LE(s.t_s, f.timestamp_s + 1e-9);
      EXPECT_NEAR(s.accel_m_s2.z(), 9.81, 1.0);  // + vertical curvature of the road
      EXPECT_LT(s.gyro_rad_s.norm(), 0.3);
    }
    for (const OdometrySample& o : f.odometry) EXPECT_NEAR(o.speed_m_s, 9.0, 1.2);
    for (const GpsSample& g : f.gps)
      EXPECT_LT((g.position_m - f.pose->translation()).head<2>().norm(), 8.0);
  }
  EXPECT_EQ(gps, 2u) << "2 Hz GPS over (−0.1, 0.5] s";
}

TEST(SimulatorSource, RejectsBadParameters) {
  EXPECT_THROW(makeSource("{min_range_m: 5, max_range_m: 5}"), std::exception);
  EXPECT_THROW(makeSource("{point_order: diagonal}"), std::exception);
  EXPECT_THROW(makeSource("{azimuth_step_deg: 0}"), std::exception);
  auto p = makeSource("{frames: 2, enable_camera: false, azimuth_step_deg: 2}");
  EXPECT_THROW(src(p).read(2), std::out_of_range);
}

// A ditch of 0.5 m or less (two 0.25 m walls) and an azimuth step past 5° are refused by the
// parameters' declared ranges, naming the parameter and the range; the deeper checks in
// sim::Simulation and sim::LidarModel are never reached from a configuration.
TEST(SimulatorSource, OutOfRangeDitchAndAzimuthStepNameTheParameterAndRange) {
  struct Case {
    std::string params, expect;
  };
  for (const Case& c :
       {Case{"{ditch_width_m: 0.5}",
             "parameter 'ditch_width_m': value 0.5 out of range: expected in [0.6, 5] m"},
        Case{"{azimuth_step_deg: 6}",
             "parameter 'azimuth_step_deg': value 6 out of range: expected in [0.05, 5] deg"}}) {
    try {
      makeSource(c.params);
      ADD_FAILURE() << "accepted " << c.params;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(c.expect), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace terramrf

namespace terramrf {
namespace {

std::unique_ptr<Plugin> makeSourceWithLabels(const std::string& params, const LabelSet& set) {
  PluginRegistry reg({test::pluginDir()});
  auto p = reg.create("simulator");
  PluginContext ctx;
  ctx.labels = &set;
  setParams(*p, params, ctx);
  return p;
}

LabelInfo named(const std::string& name) { return LabelInfo{name, {0, 0, 0}}; }

}  // namespace

// A config's own label set numbers its classes as it lists them; the simulation's truth is in
// road, rough and obstacle, so it is matched by name, points and pixels alike. (It was taken by
// id: with {unknown, road, kerb, rough, obstacle} the rough ground was learnt as kerb and the
// obstacles as rough, without a word.)
TEST(SimulatorSource, TruthFollowsTheConfigsLabelSetByName) {
  const LabelSet set(
      {named("unknown"), named("obstacle"), named("kerb"), named("road"), named("rough")});
  auto p = makeSourceWithLabels("{frames: 5}", set);
  const Frame f = src(p).read(0);
  const Frame& d = defaultFrame0();  // the default set: road 1, rough 2, obstacle 3
  ASSERT_EQ(f.truth.label.size(), d.truth.label.size());
  const LabelId to[4] = {0, 3, 4, 1};  // default id -> id in `set`
  for (std::size_t i = 0; i < d.truth.label.size(); ++i)
    ASSERT_EQ(f.truth.label[i], to[d.truth.label[i]]) << i;
  ASSERT_TRUE(f.cameras.at(0).truth && d.cameras.at(0).truth);
  const auto& px = f.cameras[0].truth->data;
  const auto& dpx = d.cameras[0].truth->data;
  ASSERT_EQ(px.size(), dpx.size());
  for (std::size_t i = 0; i < px.size(); ++i) ASSERT_EQ(px[i], to[dpx[i]]) << i;
  // The default set in another object: nothing to rename.
  const LabelSet defaults = LabelSet::defaults();
  auto q = makeSourceWithLabels("{frames: 5}", defaults);
  EXPECT_EQ(src(q).read(0).truth.label, d.truth.label);
}

TEST(SimulatorSource, ALabelSetWithoutTheSimulationsClassesIsRefused) {
  const LabelSet set({named("unknown"), named("road"), named("grass"), named("obstacle")});
  try {
    makeSourceWithLabels("{frames: 5}", set);
    FAIL() << "expected an error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("its ground truth is in the classes road, rough and "
                                         "obstacle, and the config's label set has no 'rough'"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace terramrf
