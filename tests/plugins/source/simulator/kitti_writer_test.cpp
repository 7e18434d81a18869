// KittiSequenceWriter round trip: simulator frames written in KITTI/SemanticKITTI layout and read
// back with the project's KITTI readers.
#include "terramrf/io/kitti_writer.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "terramrf/adapters/opencv_image.hpp"
#include "terramrf/atomic_file.hpp"
#include "terramrf/io/kitti.hpp"
#include "terramrf/io/label_map.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

std::vector<Frame> simulate(int n) {
  PluginRegistry reg({test::pluginDir()});
  auto p = reg.create("simulator");
  PluginContext ctx;
  setParams(*p,
            "{frames: " + std::to_string(n) +
                ", seed: 2, azimuth_step_deg: 0.36, camera_width: 320, camera_height: 128, "
                "camera_fx: 185}",
            ctx);
  auto& src = dynamic_cast<Source&>(*p);
  std::vector<Frame> frames;
  for (int i = 0; i < n; ++i) frames.push_back(src.read(i));
  return frames;
}

std::vector<std::string> dataLines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> out;
  for (std::string l; std::getline(in, l);)
    if (!l.empty() && l[0] != '#') out.push_back(l);
  return out;
}

TEST(KittiSequenceWriter, RoundTrip) {
  const std::vector<Frame> frames = simulate(3);
  test::TempDir dir;
  {
    KittiSequenceWriter w(dir.str());
    for (const Frame& f : frames) w.write(f);
    w.finish();
    EXPECT_EQ(w.frames(), 3u);
  }
  namespace fs = std::filesystem;
  const std::string d = dir.str();
  const KittiCalib calib = readKittiCalib(d + "/calib.txt");
  const CameraModel& cam = frames[0].cameras.at(0).model;
  const CameraModel back = kittiCamera(calib, 2, cam.width, cam.height);
  EXPECT_TRUE(back.P.isApprox(cam.P, 1e-9));
  EXPECT_TRUE(back.T_camera_lidar.matrix().isApprox(cam.T_camera_lidar.matrix(), 1e-9));
  // A reader projecting with P2 · Tr · X gets the camera's own pixels.
  const Eigen::Vector3d X(12.0, 1.5, -0.7);
  const Eigen::Vector3d a = calib.P[2] * (calib.T_cam_velo * X).homogeneous();
  const auto uv = cam.project(X);
  ASSERT_TRUE(uv.has_value());
  EXPECT_NEAR(a.x() / a.z(), uv->x(), 1e-6);
  EXPECT_NEAR(a.y() / a.z(), uv->y(), 1e-6);

  const std::vector<Eigen::Isometry3d> poses = readKittiPoses(d + "/poses.txt");
  ASSERT_EQ(poses.size(), 3u);
  const std::vector<double> times = readKittiTimes(d + "/times.txt");
  ASSERT_EQ(times.size(), 3u);
  std::size_t imu = 0, gps = 0, odo = 0;
  const LabelMap map = LabelMap::load(test::sourceDir() + "/configs/label_maps/simulator.yaml",
                                      LabelSet::defaults());
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const Frame& f = frames[i];
    const std::string s = KittiSequenceWriter::stem(i);
    EXPECT_EQ(s, f.id);
    const std::string bin = d + "/velodyne/" + s + ".bin";
    EXPECT_EQ(fs::file_size(bin), 16 * f.points.size());
    PointCloud pc;
    const ScanReadInfo info = readKittiScan(bin, pc);
    ASSERT_EQ(pc.size(), f.points.size());
    EXPECT_EQ(pc.x, f.points.x);
    EXPECT_EQ(pc.intensity, f.points.intensity);
    PointLabels truth;
    readKittiLabels(d + "/labels/" + s + ".label", bin, info, &map, truth);
    EXPECT_EQ(truth.raw, f.truth.raw);
    EXPECT_EQ(truth.label, f.truth.label) << "label map reproduces the project classes";
    const std::string rings = readFile(d + "/rings/" + s + ".bin");
    ASSERT_EQ(rings.size(), 2 * f.points.size());
    std::vector<uint16_t> r(f.points.size());
    std::memcpy(r.data(), rings.data(), rings.size());
    EXPECT_EQ(r, f.points.ring);
    const Image img = readImage(d + "/image_2/" + s + ".png");
    EXPECT_EQ(img.data, f.cameras[0].image->data);
    const Image tr = readImage(d + "/image_2_truth/" + s + ".png");
    EXPECT_EQ(tr.channels, 1);
    EXPECT_EQ(tr.data, f.cameras[0].truth->data);
    EXPECT_TRUE(kittiLidarPose(poses[i], calib.T_cam_velo).isApprox(*f.pose, 1e-9));
    EXPECT_NEAR(times[i], f.timestamp_s, 1e-9);
    imu += f.imu.size();
    gps += f.gps.size();
    odo += f.odometry.size();
  }
  EXPECT_EQ(dataLines(d + "/imu.txt").size(), imu);
  EXPECT_EQ(dataLines(d + "/gps.txt").size(), gps);
  EXPECT_EQ(dataLines(d + "/odometry.txt").size(), odo);
  // First sample line of imu.txt: 7 numbers matching the first sample.
  std::istringstream first(dataLines(d + "/imu.txt").at(0));
  double v[7];
  for (double& x : v) first >> x;
  EXPECT_NEAR(v[0], frames[0].imu[0].t_s, 1e-6);
  EXPECT_NEAR(v[6], frames[0].imu[0].accel_m_s2.z(), 1e-6);
  // No stray temporary files.
  for (const auto& e : fs::recursive_directory_iterator(d))
    EXPECT_EQ(e.path().filename().string().find(".tmp."), std::string::npos) << e.path();
}

TEST(KittiSequenceWriter, WithoutCameraOrPose) {
  Frame f;
  f.id = "a";
  f.points.push_back(1, 2, 3, 0.5);
  test::TempDir dir;
  KittiSequenceWriter w(dir.str());
  w.write(f);
  w.finish();
  const KittiCalib calib = readKittiCalib(dir.str() + "/calib.txt");
  EXPECT_TRUE(calib.T_cam_velo.matrix().isIdentity(1e-12));
  EXPECT_FALSE(std::filesystem::exists(dir.str() + "/poses.txt"));
  EXPECT_FALSE(std::filesystem::exists(dir.str() + "/labels"));
  EXPECT_EQ(std::filesystem::file_size(dir.str() + "/velodyne/000000.bin"), 16u);
  // Mixing frames with and without poses is refused.
  Frame g = f;
  g.pose = Eigen::Isometry3d::Identity();
  KittiSequenceWriter w2(dir.str() + "/b");
  w2.write(f);
  EXPECT_THROW(w2.write(g), std::runtime_error);
  // Label count must match the points.
  Frame h = f;
  h.truth.raw = {1, 2};
  EXPECT_THROW(w2.write(h), std::runtime_error);
}

// poses.txt is a dataset's reference, which the semantickitti reader takes for truth_pose: a
// frame's truth goes there, not the estimate an egomotion stage left in its pose. A frame
// without truth has its pose written.
TEST(KittiSequenceWriter, PosesTxtHoldsTheTruthPoseWhereThereIsOne) {
  test::TempDir dir;
  KittiSequenceWriter w(dir.str());
  for (int i = 0; i < 2; ++i) {
    Frame f;
    f.id = std::to_string(i);
    f.points.push_back(1, 2, 3, 0.5);
    f.truth_pose = Eigen::Isometry3d(Eigen::Translation3d(2.0 * i, 0, 0));
    f.pose = Eigen::Translation3d(2.0 * i + 0.7, 0.2, 0) *
             Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ());  // an estimate, off the truth
    w.write(f);
  }
  w.finish();
  const auto poses = readKittiPoses(dir.str() + "/poses.txt");
  ASSERT_EQ(poses.size(), 2u);
  // No camera: Tr = identity, so poses.txt holds the LiDAR poses.
  EXPECT_TRUE(poses[0].isApprox(Eigen::Isometry3d::Identity(), 1e-12)) << poses[0].matrix();
  EXPECT_TRUE(poses[1].isApprox(Eigen::Isometry3d(Eigen::Translation3d(2, 0, 0)), 1e-12))
      << poses[1].matrix();

  KittiSequenceWriter only_pose(dir.str() + "/b");
  Frame g;
  g.id = "g";
  g.points.push_back(1, 2, 3, 0.5);
  g.pose = Eigen::Isometry3d(Eigen::Translation3d(0, 4, 0));
  only_pose.write(g);
  only_pose.finish();
  const auto b = readKittiPoses(dir.str() + "/b/poses.txt");
  ASSERT_EQ(b.size(), 1u);
  EXPECT_TRUE(b[0].isApprox(*g.pose, 1e-12)) << b[0].matrix();
}

// calib.txt holds P0..P3 and no distortion: three cameras, a distorted camera, or a frame whose
// cameras differ from the first frame's are refused, naming the frame, before anything is written.
TEST(KittiSequenceWriter, RefusesCamerasCalibTxtCannotHold) {
  Frame f;
  f.id = "f7";
  f.points.push_back(1, 2, 3, 0.5);
  CameraImage cam;
  cam.model.name = "image_2";
  cam.model.width = 8;
  cam.model.height = 4;
  cam.model.P.leftCols<3>() << 4, 0, 4, 0, 4, 2, 0, 0, 1;
  cam.image = std::make_shared<Image>(8, 4, 3);
  auto expectError = [&](const Frame& frame, const std::string& says) {
    test::TempDir dir;
    KittiSequenceWriter w(dir.str());
    try {
      w.write(frame);
      FAIL() << "expected an error: " << says;
    } catch (const std::runtime_error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("frame 'f7'"), std::string::npos) << what;
      EXPECT_NE(what.find(says), std::string::npos) << what;
    }
    EXPECT_FALSE(std::filesystem::exists(dir.str() + "/velodyne/000000.bin"));
  };
  Frame three = f;
  three.cameras = {cam, cam, cam};
  expectError(three, "has 3 cameras; calib.txt holds two colour cameras");
  Frame distorted = f;
  distorted.cameras = {cam};
  distorted.cameras[0].model.distortion[0] = -0.1;
  expectError(distorted, "camera 'image_2' has lens distortion");

  test::TempDir dir;
  KittiSequenceWriter w(dir.str());
  Frame two = f;
  two.cameras = {cam, cam};
  two.cameras[1].model.name = "image_3";
  w.write(two);
  Frame one = f;
  one.cameras = {cam};
  try {
    w.write(one);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cameras or their calibration differ"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(w.frames(), 1u);
}

}  // namespace
}  // namespace terramrf
