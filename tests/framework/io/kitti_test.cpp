#include "terramrf/io/kitti.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>

#include "io_test_util.hpp"
#include "terramrf/atomic_file.hpp"
#include "terramrf/errors.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

const char* kSeq = "semantickitti_seq00_000000-000005/sequences/00";
std::string seqFile(const std::string& rel) {
  return test::dataPath(std::string(kSeq) + "/" + rel);
}

LabelMap skMap() {
  return LabelMap::load(test::sourceDir() + "/configs/label_maps/semantickitti.yaml",
                        LabelSet::defaults());
}

TEST(KittiScan, Seq00CountsAndLabelHistogram) {
  const std::size_t counts[] = {124668, 124605, 124478, 124167, 123969, 123924};
  const LabelMap map = skMap();
  std::map<uint32_t, std::size_t> hist;
  for (int i = 0; i < 6; ++i) {
    PointCloud c;
    const std::string bin = seqFile("velodyne/00000" + std::to_string(i) + ".bin");
    const ScanReadInfo info = readKittiScan(bin, c);
    EXPECT_EQ(info.raw_points, counts[i]);
    EXPECT_EQ(c.size(), counts[i]);
    EXPECT_EQ(info.droppedTotal(), 0u);
    EXPECT_FALSE(c.hasRing());
    if (i < 3) {
      PointLabels t;
      readKittiLabels(seqFile("labels/00000" + std::to_string(i) + ".label"), bin, info, &map, t);
      ASSERT_EQ(t.raw.size(), counts[i]);
      ASSERT_EQ(t.label.size(), counts[i]);
      for (const auto& [k, v] : test::histogram(t.raw)) hist[k] += v;
    }
  }
  // PROVENANCE.md of the folder (python/numpy histogram of frames 0-2).
  const std::map<uint32_t, std::size_t> expected{
      {0, 6448},   {1, 27},    {10, 13346}, {40, 99691}, {44, 11716}, {48, 77924},
      {50, 57571}, {51, 1158}, {52, 4240},  {60, 2583},  {70, 81226}, {71, 3685},
      {72, 8314},  {80, 1782}, {81, 295},   {99, 3512},  {255, 233}};
  EXPECT_EQ(hist, expected);
  // Mapped shares: road 51.3 %, rough 2.2 %, obstacle 44.7 %, unknown 1.7 %.
  std::size_t total = 0, road = 0;
  for (const auto& [k, v] : hist) {
    total += v;
    if (map.map(k) == labels::kRoad) road += v;
  }
  EXPECT_NEAR(100.0 * road / total, 51.3, 0.05);
}

TEST(KittiScan, FirstPointOfSeq00) {
  PointCloud c;
  readKittiScan(seqFile("velodyne/000000.bin"), c);
  // Known answer from numpy: first point, azimuth ~0.02° (the sweep starts facing forward).
  EXPECT_NEAR(std::atan2(c.y[0], c.x[0]) * 180 / M_PI, 0.0249, 1e-3);
  EXPECT_GE(c.intensity[0], 0.f);
  EXPECT_LE(c.intensity[0], 1.f);
}

TEST(KittiScan, Open3dMlConvertedAndMmdetFixture) {
  const LabelMap map = skMap();
  std::map<uint32_t, std::size_t> hist;
  for (const auto& [id, n] :
       {std::pair<std::string, std::size_t>{"000700", 85962}, {"000750", 86139}}) {
    const std::string base = test::dataPath("semantickitti_o3dml_demo/converted_semantickitti");
    PointCloud c;
    const auto info = readKittiScan(base + "/velodyne/" + id + ".bin", c);
    EXPECT_EQ(c.size(), n);
    PointLabels t;
    readKittiLabels(base + "/labels/" + id + ".label", base + "/velodyne/" + id + ".bin", info,
                    &map, t);
    for (const auto& [k, v] : test::histogram(t.raw)) hist[k] += v;
    for (float in : c.intensity) ASSERT_EQ(in, 0.f);  // the .npy source has no intensity
  }
  const std::map<uint32_t, std::size_t> expected{
      {0, 3693},   {10, 1970}, {11, 55},    {20, 46},  {30, 53},    {40, 28125}, {48, 17185},
      {50, 25374}, {51, 2516}, {70, 61674}, {71, 177}, {72, 30585}, {80, 575},   {81, 73}};
  EXPECT_EQ(hist, expected);

  const std::string fx = test::dataPath("semantickitti_mmdet3d_fixture/sequences/00");
  PointCloud c;
  const auto info = readKittiScan(fx + "/velodyne/000000.bin", c);
  EXPECT_EQ(c.size(), 50u);
  PointLabels t;
  readKittiLabels(fx + "/labels/000000.label", fx + "/velodyne/000000.bin", info, &map, t);
  EXPECT_EQ(test::histogram(t.raw), (std::map<uint32_t, std::size_t>{
                                        {0, 2}, {50, 25}, {52, 1}, {70, 17}, {71, 3}, {80, 2}}));
}

TEST(KittiScan, SizeNotMultipleOf16NamesFileAndSize) {
  test::TempDir dir;
  const std::string p = dir.str() + "/bad.bin";
  const std::vector<float> v(9, 1.f);  // 36 bytes
  test::writeScan(p, v);
  PointCloud c;
  try {
    readKittiScan(p, c);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), p);
    EXPECT_NE(std::string(e.what()).find("36 bytes"), std::string::npos) << e.what();
  }
  EXPECT_THROW(readKittiScan(dir.str() + "/missing.bin", c), InputError);
}

TEST(KittiScan, EmptyFileIsAnEmptyScan) {
  test::TempDir dir;
  const std::string p = dir.str() + "/empty.bin";
  test::writeScan(p, {});
  PointCloud c;
  c.push_back(1, 2, 3, 4);
  const ScanReadInfo info = readKittiScan(p, c);
  EXPECT_EQ(info.raw_points, 0u);
  EXPECT_TRUE(c.empty());
  const std::string l = dir.str() + "/empty.label";
  test::writeLabels(l, {});
  PointLabels t;
  const LabelMap map = skMap();
  readKittiLabels(l, p, info, &map, t);
  EXPECT_TRUE(t.empty());
}

TEST(KittiScan, NonFiniteAndNoReturnPointsAreDroppedWithTheirLabels) {
  test::TempDir dir;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<float> pts{1,   2,   3, 0.5f,   // kept
                               nan, 0,   0, 0,      // non-finite
                               0,   0,   0, 0.1f,   // no return
                               4,   inf, 1, 0,      // non-finite
                               5,   6,   7, 0.25f,  // kept
                               0,   0,   0, 0};     // no return
  const std::string bin = dir.str() + "/s.bin", lab = dir.str() + "/s.label";
  test::writeScan(bin, pts);
  test::writeLabels(lab, {40, 1, 0, 1, (7u << 16) | 70u, 0});
  PointCloud c;
  const ScanReadInfo info = readKittiScan(bin, c);
  EXPECT_EQ(info.raw_points, 6u);
  EXPECT_EQ(info.dropped_nonfinite, 2u);
  EXPECT_EQ(info.dropped_no_return, 2u);
  EXPECT_EQ(info.dropped, (std::vector<uint32_t>{1, 2, 3, 5}));
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.x[1], 5.f);
  EXPECT_EQ(c.intensity[1], 0.25f);
  const LabelMap map = skMap();
  PointLabels t;
  readKittiLabels(lab, bin, info, &map, t);
  EXPECT_EQ(t.raw, (std::vector<uint32_t>{40, 70}));  // instance bits stripped
  EXPECT_EQ(t.label, (std::vector<LabelId>{labels::kRoad, labels::kObstacle}));

  // Keeping no-return points is a choice.
  const ScanReadInfo keep = readKittiScan(bin, c, /*drop_no_return=*/false);
  EXPECT_EQ(c.size(), 4u);
  EXPECT_EQ(keep.dropped_no_return, 0u);
}

// The reader takes four points at a time where all four are valid: bad points anywhere (inside
// a block of four, at its edges, across the 32768-point read chunks, in any coordinate) must
// still be dropped exactly as one point at a time would, and the kept ones keep their order.
TEST(KittiScan, BadPointsAnywhereAreDroppedAsOnePointAtATimeWould) {
  test::TempDir dir;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  constexpr std::size_t kPoints = 70003;  // two full read chunks and a ragged third
  std::vector<float> pts(4 * kPoints);
  uint32_t state = 12345;
  auto next = [&] { return state = state * 1664525u + 1013904223u; };
  for (std::size_t i = 0; i < pts.size(); ++i) pts[i] = float(int(next() >> 16) - 32768) / 100.f;
  const std::vector<std::size_t> bad_at{0,     1,     5,     6,     7,     32767, 32768, 32771,
                                        40000, 40001, 40002, 40003, 65535, 65536, 70000, 70002};
  for (std::size_t k = 0; k < bad_at.size(); ++k) {
    float* p = &pts[4 * bad_at[k]];
    const std::size_t kind = k % 5;
    if (kind == 0) p[0] = p[1] = p[2] = 0.f;              // no return
    if (kind == 1) p[3] = nan;                            // intensity only
    if (kind == 2) p[1] = -inf;                           // non-finite y
    if (kind == 3) p[2] = nan;                            // non-finite z
    if (kind == 4) p[0] = -0.f, p[1] = 0.f, p[2] = -0.f;  // no return, signed zeros
  }
  const std::string bin = dir.str() + "/s.bin";
  test::writeScan(bin, pts);
  for (const bool drop_no_return : {true, false}) {
    std::vector<float> x, y, z, in;
    std::vector<uint32_t> dropped;
    for (std::size_t i = 0; i < kPoints; ++i) {
      const float* p = &pts[4 * i];
      const bool finite =
          std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]) && std::isfinite(p[3]);
      const bool origin = p[0] == 0.f && p[1] == 0.f && p[2] == 0.f;
      if (!finite || (drop_no_return && origin))
        dropped.push_back(uint32_t(i));
      else
        x.push_back(p[0]), y.push_back(p[1]), z.push_back(p[2]), in.push_back(p[3]);
    }
    PointCloud c;
    const ScanReadInfo info = readKittiScan(bin, c, drop_no_return);
    EXPECT_EQ(info.dropped, dropped) << "drop_no_return " << drop_no_return;
    EXPECT_EQ(info.dropped_nonfinite, 9u);
    EXPECT_EQ(info.dropped_no_return, drop_no_return ? 7u : 0u);
    EXPECT_EQ(c.x, x);
    EXPECT_EQ(c.y, y);
    EXPECT_EQ(c.z, z);
    EXPECT_EQ(c.intensity, in);
  }
}

TEST(KittiScan, LabelCountMismatchNamesBothFilesAndCounts) {
  test::TempDir dir;
  const std::string bin = dir.str() + "/s.bin", lab = dir.str() + "/s.label";
  test::writeScan(bin, std::vector<float>(4 * 5, 1.f));
  test::writeLabels(lab, {40, 40, 40});
  PointCloud c;
  const ScanReadInfo info = readKittiScan(bin, c);
  PointLabels t;
  try {
    readKittiLabels(lab, bin, info, nullptr, t);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find(lab), std::string::npos) << w;
    EXPECT_NE(w.find(bin), std::string::npos) << w;
    EXPECT_NE(w.find("3 labels"), std::string::npos) << w;
    EXPECT_NE(w.find("5 points"), std::string::npos) << w;
  }
  // An odd byte count is reported as such.
  test::writeBytes(lab, "abcdefg", 7);
  EXPECT_THROW(readKittiLabels(lab, bin, info, nullptr, t), InputError);
}

TEST(KittiScan, UnmappedLabelNamesMapIdAndLabelFile) {
  test::TempDir dir;
  const std::string bin = dir.str() + "/s.bin", lab = dir.str() + "/s.label";
  test::writeScan(bin, std::vector<float>(4 * 2, 1.f));
  test::writeLabels(lab, {40, 123});
  PointCloud c;
  const ScanReadInfo info = readKittiScan(bin, c);
  const LabelMap map = skMap();
  PointLabels t;
  try {
    readKittiLabels(lab, bin, info, &map, t);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("semantickitti.yaml"), std::string::npos) << w;
    EXPECT_NE(w.find("123"), std::string::npos) << w;
    EXPECT_NE(w.find(lab), std::string::npos) << w;
  }
}

TEST(KittiCalib, OdometryVariant) {
  const KittiCalib c = readKittiCalib(seqFile("calib.txt"));
  EXPECT_FALSE(c.object_format);
  EXPECT_NEAR(c.P[2](0, 0), 718.856, 1e-9);
  EXPECT_NEAR(c.P[2](0, 3), 45.38225, 1e-9);
  EXPECT_NEAR(c.T_cam_velo.translation().z(), -0.2921968648686, 1e-12);
  EXPECT_NEAR(c.T_cam_velo.linear()(0, 1), -0.9999672484946, 1e-12);
  // A forward LiDAR point is in front of camera 0.
  EXPECT_GT((c.T_cam_velo * Eigen::Vector3d(10, 0, 0)).z(), 9.0);
}

TEST(KittiCalib, ObjectVariantProjectsIntoTheImage) {
  const std::string base = test::dataPath("kitti_object_fusion/training");
  const std::pair<int, int> sizes[] = {{1224, 370}, {1242, 375}};
  // P2·R0_rect·Tr_velo_to_cam with pixel centres at integers (−0.5 ≤ u < W − 0.5); numpy's count
  // with 0 ≤ u < W is 20285 / 18630.
  const std::size_t expected_in_image[] = {20259, 18608};
  const std::size_t expected_points[] = {115384, 120268};
  for (int i = 0; i < 2; ++i) {
    const KittiCalib c = readKittiCalib(base + "/calib/00000" + std::to_string(i) + ".txt");
    EXPECT_TRUE(c.object_format);
    const CameraModel cam = kittiCamera(c, 2, sizes[i].first, sizes[i].second);
    EXPECT_EQ(cam.name, "image_2");
    PointCloud pc;
    readKittiScan(base + "/velodyne/00000" + std::to_string(i) + ".bin", pc);
    EXPECT_EQ(pc.size(), expected_points[i]);
    std::size_t in = 0;
    for (std::size_t k = 0; k < pc.size(); ++k)
      in += cam.project(Eigen::Vector3d(pc.x[k], pc.y[k], pc.z[k])).has_value();
    EXPECT_NEAR(double(in), double(expected_in_image[i]), 3.0);
  }
}

// KITTI's own P2 / P3 only translate (baseline in the last column) and are kept as they are; a
// P that also turns the camera (a rear camera written by `terramrf simulate`) is split into
// K [I | 0] and a pose, so that front / behind is judged along that camera's own axis.
TEST(KittiCalib, TurnedCameraIsSplitIntoIntrinsicsAndPose) {
  const std::string base = test::dataPath("kitti_object_fusion/training");
  const KittiCalib real = readKittiCalib(base + "/calib/000000.txt");
  const CameraModel right = kittiCamera(real, 3, 1224, 370);
  EXPECT_EQ(right.name, "image_3");
  EXPECT_TRUE(right.P == real.P[3]);  // untouched, bit for bit
  EXPECT_TRUE(right.T_camera_lidar.matrix() == real.T_cam_velo.matrix());

  // A rear camera: camera 0 turned 180° about its y (down) axis, 1.5 m behind camera 0.
  KittiCalib c = real;
  c.path = "rig/calib.txt";
  Eigen::Matrix3d K;
  K << 500, 0, 320, 0, 480, 120, 0, 0, 1;
  Eigen::Isometry3d T_rear_cam0 = Eigen::Isometry3d::Identity();
  T_rear_cam0.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY()).toRotationMatrix() *
                         Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitX()).toRotationMatrix();
  T_rear_cam0.translation() = Eigen::Vector3d(0.1, -0.2, -1.5);
  Eigen::Matrix<double, 3, 4> Rt = T_rear_cam0.matrix().topRows<3>();
  c.P[3] = -2.0 * K * Rt;  // any non-zero scale, even negative, is the same projection
  const CameraModel rear = kittiCamera(c, 3, 640, 240);
  EXPECT_TRUE(rear.P.leftCols<3>().isApprox(K, 1e-9)) << rear.P;
  EXPECT_TRUE(rear.P.col(3).isZero(1e-12));
  EXPECT_TRUE(rear.T_camera_lidar.isApprox(T_rear_cam0 * real.T_cam_velo, 1e-9));
  EXPECT_EQ(rear.calibration, "rig/calib.txt (P3, R0_rect, Tr_velo_to_cam)");
  int behind_seen = 0;
  for (const Eigen::Vector3d& x : {Eigen::Vector3d(-8, 0.5, -1.2), Eigen::Vector3d(-15, -3, 0),
                                   Eigen::Vector3d(-4, 1, -1.5)}) {
    // Reference: the file's P3 applied to the camera-0 point, as a KITTI user would.
    const Eigen::Vector3d q = c.P[3] * (real.T_cam_velo * x).homogeneous();
    const auto uv = rear.projectUnbounded(x);
    ASSERT_TRUE(uv.has_value());
    EXPECT_NEAR(uv->x(), q.x() / q.z(), 1e-6);
    EXPECT_NEAR(uv->y(), q.y() / q.z(), 1e-6);
    behind_seen += rear.project(x).has_value();
  }
  EXPECT_GT(behind_seen, 0);  // points behind the vehicle are in the rear camera's image
  EXPECT_FALSE(rear.projectUnbounded(Eigen::Vector3d(10, 0, -1)).has_value());  // ahead

  c.P[3].setZero();
  c.P[3](0, 0) = 1;
  c.P[3](1, 0) = 1;  // rank-deficient left 3×3, not upper triangular
  try {
    kittiCamera(c, 3, 640, 240);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "rig/calib.txt");
    EXPECT_NE(std::string(e.what()).find("P3 is not a camera projection"), std::string::npos)
        << e.what();
  }
}

TEST(KittiCalib, RejectsBrokenFiles) {
  test::TempDir dir;
  const std::string p = dir.str() + "/calib.txt";
  std::ofstream(p) << "P0: 1 2 3\n";
  EXPECT_THROW(readKittiCalib(p), InputError);
  std::ofstream(p) << "P0: 1 0 0 0 0 1 0 0 0 0 1 0\nP1: 1 0 0 0 0 1 0 0 0 0 1 0\n"
                      "P2: 1 0 0 0 0 1 0 0 0 0 1 0\nP3: 1 0 0 0 0 1 0 0 0 0 1 0\n";
  try {
    readKittiCalib(p);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("Tr"), std::string::npos);
  }
  EXPECT_THROW(readKittiCalib(dir.str() + "/nope.txt"), InputError);

  // Found by fuzzing: a word in a matrix dropped the whole entry ("no 'P2:' entry", with the line
  // right there), "nan" was read as a number, and a transform that is no rotation was taken.
  const std::string good = readFile(seqFile("calib.txt"));
  struct Case {
    std::string from, to, expect;
  };
  for (const Case& c :
       {Case{"P2: 7.188560000000e+02 0.000000000000e+00", "P2: 7.188560000000e+02 zero",
             "calib.txt: line 3: 'P2:' value 'zero' is not a finite number"},
        Case{"P2: 7.188560000000e+02 0.000000000000e+00", "P2: 7.188560000000e+02 nan",
             "line 3: 'P2:' value 'nan' is not a finite number"},
        Case{"P2: 7.188560000000e+02 0.000000000000e+00", "P2: 7.188560000000e+02 1e999",
             "line 3: 'P2:' value '1e999' is not a finite number"},
        Case{"Tr: 4.276802385584e-04 -9.999672484946e-01",
             "Tr: 4.276802385584e-04 -0.9999672484946e-01",
             "'Tr:' rotation part is not a rotation"}}) {
    std::string text = good;
    ASSERT_NE(text.find(c.from), std::string::npos) << c.from;
    text.replace(text.find(c.from), c.from.size(), c.to);
    std::ofstream(p) << text;
    try {
      readKittiCalib(p);
      ADD_FAILURE() << "accepted " << c.to;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(c.expect), std::string::npos) << e.what();
    }
  }
  // Non-numeric entries (raw KITTI's "calib_time: 09-Jan-2012 13:57:47") are not matrices.
  std::ofstream(p) << "calib_time: 09-Jan-2012 13:57:47\n" << good;
  EXPECT_NO_THROW(readKittiCalib(p));
}

// Only what is read is required: the LiDAR→camera transform and the P of each camera asked for.
// A calib.txt of just P2 and Tr (docs/own_data.md: what your own data needs for image_2) used to
// be refused for the P0, P1 and P3 nobody reads ("no 'P0:' entry").
TEST(KittiCalib, OnlyTheProjectionsOfTheCamerasReadAreRequired) {
  test::TempDir dir;
  const std::string p = dir.str() + "/calib.txt";
  std::ofstream(p) << "P2: 718.856 0 607.1928 45.38225 0 718.856 185.2157 -0.1130887 0 0 1 "
                      "0.003779761\n"
                      "Tr: 0 -1 0 0 0 0 -1 0 1 0 0 -0.27\n";
  KittiCalib c;
  ASSERT_NO_THROW(c = readKittiCalib(p));
  EXPECT_NEAR(c.T_cam_velo.translation().z(), -0.27, 1e-12);
  const CameraModel left = kittiCamera(c, 2, 1241, 376);
  EXPECT_NEAR(left.P(0, 2), 607.1928, 1e-9);
  EXPECT_EQ(left.calibration, p + " (P2, Tr)");
  try {
    kittiCamera(c, 3, 1241, 376);
    FAIL() << "expected InputError for camera 3 without P3";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), p);
    EXPECT_NE(std::string(e.what()).find("no 'P3:' entry; camera image_3 needs it (its 3x4 "
                                         "projection)"),
              std::string::npos)
        << e.what();
  }
  // An entry that is there must still be whole, and the transform is still required.
  std::ofstream(p) << "P2: 718.856 0 607.1928\nTr: 0 -1 0 0 0 0 -1 0 1 0 0 -0.27\n";
  EXPECT_THROW(readKittiCalib(p), InputError);
  std::ofstream(p) << "P2: 718.856 0 607.1928 45.38225 0 718.856 185.2157 0 0 0 1 0\n";
  EXPECT_THROW(readKittiCalib(p), InputError);
}

TEST(KittiPoses, LidarPoseMovesForward) {
  const auto poses = readKittiPoses(seqFile("poses.txt"));
  ASSERT_EQ(poses.size(), 4541u);
  const KittiCalib c = readKittiCalib(seqFile("calib.txt"));
  const Eigen::Isometry3d p1 = kittiLidarPose(poses[1], c.T_cam_velo);
  const Eigen::Isometry3d p5 = kittiLidarPose(poses[5], c.T_cam_velo);
  // numpy: inv(Tr)·P·Tr translations (LiDAR x forward).
  EXPECT_NEAR(p1.translation().x(), 0.8588, 1e-3);
  EXPECT_NEAR(p1.translation().y(), 0.0465, 1e-3);
  EXPECT_NEAR(p5.translation().x(), 4.2917, 1e-3);
  EXPECT_NEAR(p5.translation().z(), 0.1111, 1e-3);
  EXPECT_TRUE(kittiLidarPose(poses[0], c.T_cam_velo).isApprox(Eigen::Isometry3d::Identity(), 1e-6));

  test::TempDir dir;
  const std::string bad = dir.str() + "/poses.txt";
  std::ofstream(bad) << "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1\n";
  try {
    readKittiPoses(bad);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("line 2"), std::string::npos) << e.what();
  }
  // Found by fuzzing: a NaN was reported as "got 0" numbers, and a pose that is no rotation
  // (one digit off) was taken as a rigid motion.
  for (const auto& [line, expect] : std::vector<std::pair<std::string, std::string>>{
           {"1 0 0 0 0 1 0 0 0 0 nan 0", "line 2: 'nan' is not a finite number"},
           {"1 0 0 0 0 1 0 0 0 0 1 0 7",
            "line 2: expected 12 numbers (row-major 3x4 pose), got 13"},
           {"1 0 0 0 0 1 0 0 0 0 10 0", "line 2: the pose's 3x3 is not a rotation"},
           {"-1 0 0 0 0 1 0 0 0 0 1 0", "line 2: the pose's 3x3 is not a rotation"}}) {
    std::ofstream(bad) << "1 0 0 0 0 1 0 0 0 0 1 0\n" << line << "\n";
    try {
      readKittiPoses(bad);
      ADD_FAILURE() << "accepted " << line;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(bad + ": " + expect), std::string::npos) << e.what();
    }
  }
}

TEST(KittiTimes, OneFiniteTimePerLine) {
  test::TempDir dir;
  const std::string p = dir.str() + "/times.txt";
  std::ofstream(p) << "0.000000e+00\n1.036300e-01\n\n";
  EXPECT_EQ(readKittiTimes(p), (std::vector<double>{0.0, 0.10363}));
  // std::stod read "0.2s" as 0.2 and "nan" as a time.
  for (const char* bad : {"0.2s", "nan", "0.1 0.2", "inf"}) {
    std::ofstream(p) << "0\n" << bad << "\n";
    try {
      readKittiTimes(p);
      ADD_FAILURE() << "accepted " << bad;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(p + ": line 2: expected one time [s], got '" + bad),
                std::string::npos)
          << e.what();
    }
  }
}

TEST(KittiLayout, ResolvesEveryKittiFolderOfTheData) {
  const std::string seq = test::dataPath(kSeq);
  const KittiLayout a = resolveKittiLayout(seq, "");
  EXPECT_EQ(a.kind, KittiLayout::Kind::kSequence);
  EXPECT_EQ(a.stems.size(), 6u);
  EXPECT_FALSE(a.poses_file.empty());
  const KittiLayout b =
      resolveKittiLayout(test::dataPath("semantickitti_seq00_000000-000005"), "00");
  EXPECT_EQ(b.root, a.root);
  EXPECT_EQ(
      resolveKittiLayout(test::dataPath("semantickitti_seq00_000000-000005"), "").stems.size(), 6u);
  EXPECT_EQ(
      resolveKittiLayout(test::dataPath("semantickitti_seq00_000000-000005"), "0").stems.size(),
      6u);
  EXPECT_THROW(resolveKittiLayout(test::dataPath("semantickitti_seq00_000000-000005"), "07"),
               ParamError);
  const KittiLayout o = resolveKittiLayout(test::dataPath("kitti_object_fusion/training"), "");
  EXPECT_EQ(o.kind, KittiLayout::Kind::kObject);
  EXPECT_EQ(o.stems, (std::vector<std::string>{"000000", "000001"}));
  EXPECT_EQ(std::filesystem::path(o.calibPath(1)).filename(), "000001.txt");
  EXPECT_EQ(resolveKittiLayout(test::dataPath("kitti_object_fusion"), "").root, o.root);
  const KittiLayout d =
      resolveKittiLayout(test::dataPath("semantickitti_o3dml_demo/converted_semantickitti"), "");
  EXPECT_EQ(d.stems, (std::vector<std::string>{"000700", "000750"}));
  EXPECT_TRUE(d.poses_file.empty());
  EXPECT_THROW(resolveKittiLayout(test::dataPath("rellis3d_example_000104"), ""), ParamError);
}

// rings/<id>.bin (written by the simulator) must hold one uint16 per point of the scan as stored,
// dropped points included; otherwise every ring after the gap would belong to another point.
TEST(KittiRings, RingFileOfTheWrongSizeNamesBothFilesAndCounts) {
  test::TempDir dir;
  const std::string bin = dir.str() + "/s.bin", rings = dir.str() + "/s.rings";
  test::writeScan(bin, std::vector<float>(4 * 3, 1.f));
  PointCloud c;
  const ScanReadInfo info = readKittiScan(bin, c);
  const uint16_t two[] = {0, 1};
  for (const std::size_t bytes : {sizeof two, std::size_t(5)}) {  // 2 rings; an odd byte count
    test::writeBytes(rings, two, bytes);
    try {
      readKittiRings(rings, bin, info, c);
      ADD_FAILURE() << "accepted a ring file of " << bytes << " bytes for 3 points";
    } catch (const InputError& e) {
      const std::string w = e.what();
      EXPECT_EQ(e.file(), rings);
      EXPECT_NE(w.find("has " + std::to_string(bytes) + " bytes"), std::string::npos) << w;
      EXPECT_NE(w.find("the scan " + bin + " has 3 points"), std::string::npos) << w;
      EXPECT_NE(w.find("expected one uint16 per point"), std::string::npos) << w;
    }
  }
  // The right size reads.
  const uint16_t three[] = {5, 6, 7};
  test::writeBytes(rings, three, sizeof three);
  readKittiRings(rings, bin, info, c);
  EXPECT_EQ(c.ring, (std::vector<uint16_t>{5, 6, 7}));
}

// A dataset root with sequences/NN/ folders: which one to read must be said when there are
// several; a chosen sequence without velodyne/, or an empty sequences/, is named as such.
TEST(KittiLayout, DatasetRootErrorsNameTheFolderAndWhatIsExpected) {
  test::TempDir dir;
  const std::string root = dir.str();
  std::filesystem::create_directories(root + "/sequences");
  try {
    resolveKittiLayout(root, "");
    ADD_FAILURE() << "accepted an empty sequences/ folder";
  } catch (const ParamError& e) {
    EXPECT_EQ(e.param(), "path");
    EXPECT_NE(std::string(e.what()).find("'" + root +
                                         "' has an empty sequences/ folder; expected "
                                         "sequences/NN/velodyne/"),
              std::string::npos)
        << e.what();
  }
  std::filesystem::create_directories(root + "/sequences/00/velodyne");
  std::filesystem::create_directories(root + "/sequences/01");  // no velodyne/
  try {
    resolveKittiLayout(root, "");
    ADD_FAILURE() << "picked one of two sequences";
  } catch (const ParamError& e) {
    EXPECT_EQ(e.param(), "sequence");
    EXPECT_NE(std::string(e.what()).find("'" + root +
                                         "' holds several sequences (00, 01); set "
                                         "'sequence' to one of them"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(resolveKittiLayout(root, "00").root, root + "/sequences/00");
  try {
    resolveKittiLayout(root, "1");  // "1" means "01"
    ADD_FAILURE() << "accepted a sequence without velodyne/";
  } catch (const ParamError& e) {
    EXPECT_EQ(e.param(), "path");
    EXPECT_NE(std::string(e.what()).find("'" + root + "/sequences/01' has no velodyne/ folder"),
              std::string::npos)
        << e.what();
  }
}

// Frames come in the order they were recorded, also when their names are not zero-padded: text
// order put 10.bin before 9.bin (and 100.bin before 11.bin).
TEST(KittiLayout, UnpaddedFrameNamesComeInNumericOrder) {
  test::TempDir dir;
  std::filesystem::create_directories(dir.str() + "/velodyne");
  for (const char* n : {"10", "9", "100", "1", "11", "0"})
    test::writeScan(dir.str() + "/velodyne/" + n + ".bin", {});
  EXPECT_EQ(resolveKittiLayout(dir.str(), "").stems,
            (std::vector<std::string>{"0", "1", "9", "10", "11", "100"}));
}

// `sequence` picks a folder under sequences/. A path that is already a sequence folder (or a KITTI
// object folder) has nothing to pick: `path: …/sequences/00, sequence: "08"` used to read 00
// without a word. A sequence naming the folder itself ("00", or "0" for "00") is fine.
TEST(KittiLayout, SequenceThatDisagreesWithASequenceFolderPathIsAnError) {
  const std::string seq = test::dataPath(kSeq);
  for (const char* same : {"", "00", "0"})
    EXPECT_EQ(resolveKittiLayout(seq, same).stems.size(), 6u) << same;
  EXPECT_EQ(resolveKittiLayout(seq + "/", "00").stems.size(), 6u);  // a trailing slash
  try {
    resolveKittiLayout(seq, "08");
    ADD_FAILURE() << "read sequence 00 for sequence: 08";
  } catch (const ParamError& e) {
    EXPECT_EQ(e.param(), "sequence");
    EXPECT_NE(std::string(e.what()).find("is '08', but path '" + seq +
                                         "' is itself the sequence folder '00'"),
              std::string::npos)
        << e.what();
  }
  // The object benchmark has no sequences; its folder and its parent both refuse one.
  for (const std::string& object :
       {test::dataPath("kitti_object_fusion/training"), test::dataPath("kitti_object_fusion")}) {
    try {
      resolveKittiLayout(object, "00");
      ADD_FAILURE() << "accepted sequence: 00 for " << object;
    } catch (const ParamError& e) {
      EXPECT_EQ(e.param(), "sequence");
      EXPECT_NE(
          std::string(e.what()).find("is '00', but path '" + object + "' is a KITTI object folder"),
          std::string::npos)
          << e.what();
    }
  }
}

}  // namespace
}  // namespace terramrf
