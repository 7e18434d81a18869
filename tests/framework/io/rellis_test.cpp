#include "terramrf/io/rellis.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <fstream>
#include <map>

#include "io_test_util.hpp"
#include "terramrf/adapters/opencv_image.hpp"
#include "terramrf/errors.hpp"
#include "terramrf/io/ring_recovery.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

const char* kDir = "rellis3d_example_000104";

TEST(Rellis, LayoutOfTheExampleFolder) {
  const RellisLayout L = resolveRellisLayout(test::dataPath(kDir));
  ASSERT_EQ(L.frames.size(), 1u);  // vel000104.bin is the Velodyne scan, not a frame
  const RellisFrameFiles& f = L.frames[0];
  EXPECT_EQ(f.id, "000104");
  EXPECT_NE(f.label.find("000104.label"), std::string::npos);
  EXPECT_NE(f.image.find("frame000104-1581624663_149.jpg"), std::string::npos);
  EXPECT_NE(f.image_label.find("frame000104-1581624663_149.png"), std::string::npos);
  EXPECT_FALSE(L.camera_info.empty());
  EXPECT_FALSE(L.transforms.empty());
  test::TempDir empty;
  EXPECT_THROW(resolveRellisLayout(empty.str()), ParamError);
}

// Scans and images pad their frame numbers differently; they are matched by value, and a number
// too long for an integer (std::stoull threw out_of_range, naming no file) is matched as digits.
TEST(Rellis, ImagesAreMatchedByFrameNumberWhateverTheirPadding) {
  test::TempDir dir;
  const std::string long_id = "1234567890123456789012345";
  for (const std::string& n :
       std::vector<std::string>{"000104.bin", "7.bin", long_id + ".bin", "000000.bin"})
    std::ofstream(dir.str() + "/" + n) << "";
  for (const std::string& n :
       std::vector<std::string>{"frame104-1.jpg", "frame0007-2.png", "frame" + long_id + "-3.jpg",
                                "frame0-4.jpg", "frame105-5.jpg"})
    std::ofstream(dir.str() + "/" + n) << "";
  RellisLayout L;
  ASSERT_NO_THROW(L = resolveRellisLayout(dir.str()));
  ASSERT_EQ(L.frames.size(), 4u);
  std::map<std::string, const RellisFrameFiles*> by_id;
  for (const auto& f : L.frames) by_id[f.id] = &f;
  EXPECT_NE(by_id.at("000104")->image.find("frame104-1.jpg"), std::string::npos);
  EXPECT_EQ(by_id.at("000104")->image_label, "");
  EXPECT_EQ(by_id.at("7")->image, "");
  EXPECT_NE(by_id.at("7")->image_label.find("frame0007-2.png"), std::string::npos);
  EXPECT_NE(by_id.at(long_id)->image.find("frame" + long_id + "-3.jpg"), std::string::npos);
  EXPECT_NE(by_id.at("000000")->image.find("frame0-4.jpg"), std::string::npos);
}

// Two images of one frame number (other padding, or another stamp): the frame got whichever the
// folder listed last, silently. Now an error naming both files.
TEST(Rellis, TwoImagesOfOneFrameAreAnErrorNamingBoth) {
  for (const auto& [a, b, what] : std::vector<std::array<std::string, 3>>{
           {"frame000104-1581624663_149.jpg", "frame104-1581624663_149.jpg", "images"},
           {"frame000104-1.png", "frame000104-2.png", "image labels"}}) {
    SCOPED_TRACE(a + " / " + b);
    test::TempDir dir;
    std::ofstream(dir.str() + "/000104.bin") << "";
    std::ofstream(dir.str() + "/" + a) << "";
    std::ofstream(dir.str() + "/" + b) << "";
    try {
      resolveRellisLayout(dir.str());
      ADD_FAILURE() << "expected a ParamError";
    } catch (const ParamError& e) {
      EXPECT_EQ(e.param(), "path");
      const std::string m = e.what();
      EXPECT_NE(m.find("'" + dir.str() + "/" + a + "' and '" + dir.str() + "/" + b + "' are both " +
                       what + " of frame 104; expected one per frame number"),
                std::string::npos)
          << m;
    }
  }
}

// Frames come in the order they were recorded, also when scan names are not zero-padded: text
// order put 10.bin before 9.bin.
TEST(Rellis, UnpaddedScanNamesComeInNumericOrder) {
  test::TempDir dir;
  for (const char* n : {"10", "9", "100", "1", "11"})
    std::ofstream(dir.str() + "/" + n + ".bin") << "";
  std::vector<std::string> ids;
  for (const auto& f : resolveRellisLayout(dir.str()).frames) ids.push_back(f.id);
  EXPECT_EQ(ids, (std::vector<std::string>{"1", "9", "10", "11", "100"}));
}

TEST(Rellis, ScanLabelsAndOrganisedRings) {
  const RellisLayout L = resolveRellisLayout(test::dataPath(kDir));
  const auto& files = L.frames[0];
  PointCloud c;
  const ScanReadInfo info = readKittiScan(files.scan, c);
  EXPECT_EQ(info.raw_points, 131072u);
  EXPECT_EQ(info.dropped_no_return, 53364u);
  EXPECT_EQ(info.dropped_nonfinite, 0u);
  EXPECT_EQ(c.size(), 131072u - 53364u);
  organisedRings(c, info, 64, files.scan);
  ASSERT_TRUE(c.hasRing());
  // ring = index % 64: elevation is constant within a ring (organised Ouster layout) and falls
  // from ring 0 (top, ~+17°) to ring 63.
  std::vector<double> lo(64, 1e9), hi(64, -1e9);
  for (std::size_t i = 0; i < c.size(); ++i) {
    const double el = std::atan2(c.z[i], std::hypot(c.x[i], c.y[i])) * 180 / M_PI;
    lo[c.ring[i]] = std::min(lo[c.ring[i]], el);
    hi[c.ring[i]] = std::max(hi[c.ring[i]], el);
  }
  for (int k = 0; k < 64; ++k) {
    EXPECT_LT(hi[k] - lo[k], 0.01) << "ring " << k;
    if (k) EXPECT_LT(hi[k], lo[k - 1]) << "ring " << k;
  }
  EXPECT_NEAR(lo[0], 17.0, 0.1);

  const LabelMap map =
      LabelMap::load(test::sourceDir() + "/configs/label_maps/rellis3d.yaml", LabelSet::defaults());
  PointLabels t;
  readKittiLabels(files.label, files.scan, info, &map, t);
  // PROVENANCE.md histogram; all 53364 no-return points are void (0).
  EXPECT_EQ(test::histogram(t.raw), (std::map<uint32_t, std::size_t>{{0, 68284 - 53364},
                                                                     {3, 18040},
                                                                     {4, 17872},
                                                                     {17, 1310},
                                                                     {18, 595},
                                                                     {19, 3360},
                                                                     {23, 20242},
                                                                     {31, 1269},
                                                                     {33, 100}}));
  const auto mapped = test::histogram(t.label);
  EXPECT_EQ(mapped.at(labels::kRoad), 20242u);
  EXPECT_EQ(mapped.at(labels::kRough), 18040u + 1269u + 100u);
  EXPECT_EQ(mapped.at(labels::kObstacle), 17872u + 1310u + 595u + 3360u);
}

/// A synthetic organised scan of `rings` × `cols` at 10 m, ring r at 15° − 0.5° r, written column
/// by column (or ring by ring) to `path`; every 5th point is a no-return at the origin.
void writeSyntheticOuster(const std::string& path, int rings, int cols, bool column_by_column) {
  std::vector<float> v;
  for (int a = 0; a < (column_by_column ? cols : rings); ++a)
    for (int b = 0; b < (column_by_column ? rings : cols); ++b) {
      const int r = column_by_column ? b : a, c = column_by_column ? a : b;
      const double el = (15.0 - 0.5 * r) * M_PI / 180, az = 2 * M_PI * c / cols;
      if ((r + c) % 5 == 0)
        v.insert(v.end(), {0.f, 0.f, 0.f, 0.f});
      else
        v.insert(v.end(), {float(10 * std::cos(el) * std::cos(az)),
                           float(10 * std::cos(el) * std::sin(az)), float(10 * std::sin(el)), 1.f});
    }
  test::writeScan(path, v);
}

TEST(Rellis, OrganisedRingsChecksTheScanIsOrganised) {
  test::TempDir dir;
  const std::string good = dir.str() + "/good.bin", rows = dir.str() + "/rows.bin";
  writeSyntheticOuster(good, 64, 32, true);
  writeSyntheticOuster(rows, 64, 32, false);
  for (const bool drop : {true, false}) {  // no-returns kept at the origin have no elevation
    PointCloud c;
    const ScanReadInfo info = readKittiScan(good, c, drop);
    ASSERT_NO_THROW(organisedRings(c, info, 64, good)) << drop;
    for (std::size_t k = 0; k < c.size(); ++k) {
      if (c.x[k] == 0 && c.y[k] == 0 && c.z[k] == 0) continue;
      const double el = std::atan2(c.z[k], std::hypot(c.x[k], c.y[k])) * 180 / M_PI;
      ASSERT_NEAR(el, 15.0 - 0.5 * c.ring[k], 1e-4) << k;
    }
  }
  PointCloud c;
  ScanReadInfo info = readKittiScan(rows, c);
  try {
    organisedRings(c, info, 64, rows);
    ADD_FAILURE() << "accepted a scan stored ring by ring";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), rows);
    // Every "ring" holds every beam: 31° of the 31.5° field of view (some ends are no-returns).
    EXPECT_NE(std::string(e.what()).find("spans 31.00° of elevation among its returns; expected "
                                         "at most 2°"),
              std::string::npos)
        << e.what();
  }
  // Read as 32 rings the good scan is not organised either (two beams per "ring"), and a point
  // count that is not whole columns is named with the layout expected.
  info = readKittiScan(good, c);
  EXPECT_THROW(organisedRings(c, info, 32, good), InputError);
  try {
    organisedRings(c, info, 48, good);
    ADD_FAILURE() << "accepted 2048 points as columns of 48";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), good);
    EXPECT_NE(std::string(e.what()).find("2048 points is not a whole number of columns; expected "
                                         "an organised scan of 48 rings stored column by column"),
              std::string::npos)
        << e.what();
  }
}

TEST(Rellis, ExtrinsicDirectionPutsLabelledPointsOnMatchingPixels) {
  const RellisLayout L = resolveRellisLayout(test::dataPath(kDir));
  const auto& files = L.frames[0];
  const Image img = readImage(files.image);
  EXPECT_EQ(img.width, 1920);
  EXPECT_EQ(img.height, 1200);
  const CameraModel cam = rellisCamera(L.camera_info, L.transforms, img.width, img.height);
  EXPECT_NEAR(cam.P(0, 0), 2813.643275, 1e-6);
  EXPECT_NEAR(cam.P(1, 2), 624.049972, 1e-6);
  const Image pix = readImage(files.image_label);
  ASSERT_EQ(pix.channels, 1);
  PointCloud c;
  const ScanReadInfo info = readKittiScan(files.scan, c);
  PointLabels t;
  readKittiLabels(files.label, files.scan, info, nullptr, t);
  std::size_t in = 0, both = 0, same = 0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const auto uv = cam.project(Eigen::Vector3d(c.x[i], c.y[i], c.z[i]));
    if (!uv) continue;
    ++in;
    const uint8_t p = *pix.at(int(uv->x()), int(uv->y()));
    if (t.raw[i] == 0 || p == 0) continue;
    ++both;
    same += p == t.raw[i];
  }
  std::printf("RELLIS 000104: %zu points in the image, %zu labelled, %.3f same RELLIS id\n", in,
              both, double(same) / both);
  EXPECT_NEAR(double(in), 7428, 10);  // numpy with the inverted transform
  EXPECT_GT(double(same) / both, 0.7);
}

TEST(Rellis, VelodyneScanBinsIntoTheVlp32cLaserAngles) {
  // vel000104.bin, the simultaneous Velodyne VLP-32C scan: firing (column) order, so rings come
  // from elevation binning, whose centres must be the sensor's nominal laser angles.
  PointCloud c;
  const ScanReadInfo info =
      readKittiScan(test::dataPath("rellis3d_example_000104/vel000104.bin"), c);
  EXPECT_EQ(info.raw_points, 37334u);
  EXPECT_EQ(info.droppedTotal(), 0u);
  RingRecoveryOptions o;
  o.rings = 32;
  const RingRecoveryStats st = recoverRings(c, o);
  EXPECT_EQ(st.method, RingMethod::kElevation);
  ASSERT_EQ(st.rings_found, 32);
  const double vlp32c[] = {15,    10.33, 7,     4.67,  3.33,  2.33,   1.67,   1.33,
                           1,     0.67,  0.33,  0,     -0.33, -0.67,  -1,     -1.33,
                           -1.67, -2,    -2.33, -2.67, -3,    -3.33,  -3.67,  -4,
                           -4.67, -5.33, -6.15, -7.25, -8.84, -11.31, -15.64, -25};
  for (int k = 0; k < 32; ++k)
    EXPECT_NEAR(st.ring_median_elevation_deg[k], vlp32c[k], 0.1) << "ring " << k;
}

// camera_info.txt holds "fx fy cx cy" (the release's file: four numbers on one line). A file with
// more — distortion coefficients, a full K — used to be read for its first four numbers and the
// rest dropped, giving a camera model other than the one calibrated.
TEST(Rellis, IntrinsicsWithMoreThanFourNumbersAreRefusedNamingTheCount) {
  const Matrix34d real =
      readRellisIntrinsics(test::dataPath("rellis3d_example_000104/camera_info.txt"));
  EXPECT_NEAR(real(0, 2), 969.285772, 1e-9);
  test::TempDir dir;
  const std::string ci = dir.str() + "/camera_info.txt";
  struct Case {
    std::string text, expect;
  };
  for (const Case& c :
       {Case{"2813.64 2808.33 969.29 624.05 -0.134313 -0.025905 0.002181 0.00084 0\n",
             "has 9 numbers; expected exactly 4, 'fx fy cx cy' [px] (no distortion or other "
             "entries: they would be dropped"},
        Case{"2813.64 2808.33\n969.29 624.05\n0\n", "has 5 numbers; expected exactly 4"},
        Case{"2813.64 2808.33 969.29\n", "has 3 numbers; expected exactly 4"},
        Case{"2813.64 2808.33 969.29 624.05 k1\n",
             "line 1: 'k1' is not a finite number; expected 'fx fy cx cy' [px]"},
        Case{"2813.64 2808.33 nan 624.05\n", "line 1: 'nan' is not a finite number"},
        Case{"-2813.64 2808.33 969.29 624.05\n", "positive focal lengths"}}) {
    std::ofstream(ci) << c.text;
    try {
      readRellisIntrinsics(ci);
      ADD_FAILURE() << "accepted " << c.text;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), ci);
      EXPECT_NE(std::string(e.what()).find(c.expect), std::string::npos) << e.what();
    }
  }
  // Four numbers over several lines, with surrounding blanks, are still the four.
  std::ofstream(ci) << "  2813.64\t2808.33\n969.29 624.05  \n\n";
  EXPECT_NEAR(readRellisIntrinsics(ci)(1, 2), 624.05, 1e-9);
}

TEST(Rellis, CalibrationErrorsNameTheFile) {
  test::TempDir dir;
  const std::string ci = dir.str() + "/camera_info.txt", tf = dir.str() + "/transforms.yaml";
  std::ofstream(ci) << "1 2\n";
  EXPECT_THROW(readRellisIntrinsics(ci), InputError);
  EXPECT_THROW(readRellisIntrinsics(dir.str() + "/none.txt"), InputError);
  std::ofstream(tf) << "other: {}\n";
  try {
    readRellisCameraFromLidar(tf);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), tf);
  }
  std::ofstream(tf) << "os1_cloud_node-pylon_camera_node: {q: {w: 2, x: 0, y: 0, z: 0}, "
                       "t: {x: 0, y: 0, z: 0}}\n";
  EXPECT_THROW(readRellisCameraFromLidar(tf), InputError);
  // A repeated transform: which one is meant cannot be known.
  const std::string t = "{q: {w: 1, x: 0, y: 0, z: 0}, t: {x: 0, y: 0, z: 0}}\n";
  std::ofstream(tf) << "os1_cloud_node-pylon_camera_node: " << t
                    << "os1_cloud_node-pylon_camera_node: " << t;
  try {
    readRellisCameraFromLidar(tf);
    FAIL() << "accepted a repeated transform";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), tf);
    EXPECT_NE(std::string(e.what()).find("duplicate key 'os1_cloud_node-pylon_camera_node'"),
              std::string::npos)
        << e.what();
  }
  // Found by fuzzing: `.nan` is a YAML float, and a NaN quaternion's norm passed the norm check
  // (NaN comparisons are false); so did a transform that is a list, with yaml-cpp's own message.
  for (const char* bad : {"{q: {w: .nan, x: 0, y: 0, z: 0}, t: {x: 0, y: 0, z: 0}}",
                          "{q: {w: 1, x: 0, y: 0, z: 0}, t: {x: 0, y: .inf, z: 0}}"}) {
    std::ofstream(tf) << "os1_cloud_node-pylon_camera_node: " << bad << "\n";
    try {
      readRellisCameraFromLidar(tf);
      ADD_FAILURE() << "accepted " << bad;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(tf + ": q and t must be finite numbers"),
                std::string::npos)
          << e.what();
    }
  }
  // A component missing or not a number: yaml-cpp's own error, wrapped with the file, the line
  // and what each of q and t needs.
  for (const char* bad : {"{q: {w: 1, x: 0, y: 0}, t: {x: 0, y: 0, z: 0}}",
                          "{q: {w: 1, x: 0, y: 0, z: 0}, t: {x: 0, y: one, z: 0}}",
                          "{q: {w: 1, x: 0, y: 0, z: 0}, t: [0, 0, 0]}"}) {
    std::ofstream(tf) << "os1_cloud_node-pylon_camera_node: " << bad << "\n";
    try {
      readRellisCameraFromLidar(tf);
      ADD_FAILURE() << "accepted " << bad;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), tf);
      EXPECT_NE(std::string(e.what()).find("q needs w, x, y, z and t needs x, y, z numbers"),
                std::string::npos)
          << e.what();
    }
  }
  std::ofstream(tf) << "os1_cloud_node-pylon_camera_node: [1, 2]\n";
  try {
    readRellisCameraFromLidar(tf);
    FAIL() << "accepted a list";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(tf + ": expected 'os1_cloud_node-pylon_camera_node:"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace terramrf
