// The "semantickitti" source on every KITTI-style folder of the shared data, plus bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "terramrf/adapters/opencv_image.hpp"
#include "terramrf/errors.hpp"
#include "terramrf/io/kitti.hpp"
#include "terramrf/io/label_map.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

class SemanticKittiSourceTest : public ::testing::Test {
 protected:
  SemanticKittiSourceTest() : reg_({test::pluginDir()}) { ctx_.labels = &labels_; }

  std::unique_ptr<Source> make(const std::string& params) {
    auto p = reg_.create("semantickitti");
    setParams(*p, params, ctx_);
    plugin_ = std::move(p);
    return std::unique_ptr<Source>(dynamic_cast<Source*>(plugin_.release()));
  }

  PluginRegistry reg_;
  LabelSet labels_ = LabelSet::defaults();
  PluginContext ctx_;
  std::unique_ptr<Plugin> plugin_;
};

void writeFloats(const std::string& path, const std::vector<float>& v) {
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(v.data()), std::streamsize(v.size() * 4));
}
void writeU32(const std::string& path, const std::vector<uint32_t>& v) {
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(v.data()), std::streamsize(v.size() * 4));
}

const char* kOdoCalib =
    "P0: 718.856 0 607.1928 0 0 718.856 185.2157 0 0 0 1 0\n"
    "P1: 718.856 0 607.1928 -386.1448 0 718.856 185.2157 0 0 0 1 0\n"
    "P2: 718.856 0 607.1928 45.38225 0 718.856 185.2157 -0.1130887 0 0 1 0.003779761\n"
    "P3: 718.856 0 607.1928 -337.2877 0 718.856 185.2157 2.369057 0 0 1 0.004915215\n"
    "Tr: 0 -1 0 0 0 0 -1 0 1 0 0 -0.27\n";

/// A sequence folder with one 3-point scan (and labels) in a temp dir.
std::string tinySequence(const test::TempDir& dir, bool calib = true) {
  const std::string seq = dir.str() + "/seq";
  std::filesystem::create_directories(seq + "/velodyne");
  std::filesystem::create_directories(seq + "/labels");
  writeFloats(seq + "/velodyne/000000.bin", {5, 0, -1.7f, 0.3f, 6, 1, -1.7f, 0.2f, 7, -1, 0, 0.1f});
  writeU32(seq + "/labels/000000.label", {40, 72, 70});
  if (calib) std::ofstream(seq + "/calib.txt") << kOdoCalib;
  return seq;
}

TEST_F(SemanticKittiSourceTest, Seq00FramesLabelsPosesRings) {
  const std::string seq = test::dataPath("semantickitti_seq00_000000-000005/sequences/00");
  auto src = make("{path: " + seq + "}");
  ASSERT_EQ(src->size(), 6u);
  EXPECT_EQ(src->frameId(5), "000005");
  const std::size_t counts[] = {124668, 124605, 124478, 124167, 123969, 123924};
  std::map<LabelId, std::size_t> mapped;
  for (std::size_t i = 0; i < 6; ++i) {
    const Frame f = src->read(i);
    EXPECT_EQ(f.points.size(), counts[i]);
    EXPECT_EQ(f.dropped_nonfinite_points + f.dropped_no_return_points, 0u);
    EXPECT_NEAR(f.timestamp_s, 0.1 * i, 1e-9);
    ASSERT_TRUE(f.points.hasRing());
    EXPECT_EQ(*std::max_element(f.points.ring.begin(), f.points.ring.end()), 63);
    ASSERT_TRUE(f.pose.has_value());
    if (i < 3) {
      ASSERT_EQ(f.truth.label.size(), counts[i]);
      ASSERT_EQ(f.truth.raw.size(), counts[i]);
      for (LabelId l : f.truth.label) ++mapped[l];
    } else {
      EXPECT_TRUE(f.truth.empty()) << "frames 3-5 have no labels";
    }
    if (i == 1) EXPECT_NEAR(f.pose->translation().x(), 0.8588, 1e-3);
    if (i == 0) EXPECT_TRUE(f.pose->isApprox(Eigen::Isometry3d::Identity(), 1e-6));
    // poses.txt holds the dataset's reference poses: the truth, and the pose until an egomotion
    // stage replaces it.
    ASSERT_TRUE(f.truth_pose.has_value());
    EXPECT_TRUE(f.truth_pose->isApprox(*f.pose, 0.0));
    EXPECT_FALSE(f.pose_covariance.has_value());
    EXPECT_TRUE(f.cameras.empty());
  }
  // README: road 51.3 %, rough 2.2 %, obstacle 44.7 %, unknown 1.7 % (frames 0-2).
  const double total = counts[0] + counts[1] + counts[2];
  EXPECT_NEAR(100 * mapped[labels::kRoad] / total, 51.3, 0.05);
  EXPECT_NEAR(100 * mapped[labels::kRough] / total, 2.2, 0.05);
  EXPECT_NEAR(100 * mapped[labels::kObstacle] / total, 44.7, 0.05);
  EXPECT_NEAR(100 * mapped[labels::kUnknown] / total, 1.7, 0.05);
  EXPECT_THROW(src->read(6), std::out_of_range);
}

TEST_F(SemanticKittiSourceTest, TheDefaultLabelMapIsNamedByTheFileItRead) {
  // Resolved configs and model provenance read the parameter back: it must name the shipped
  // file that was loaded, not stay "".
  auto src = make("{path: " + test::dataPath("semantickitti_seq00_000000-000005") + "}");
  ParamDecl d;
  src->declare(d);
  const ParamSpec* spec = d.find("label_map");
  ASSERT_NE(spec, nullptr);
  const std::string value = std::get<std::string>(spec->get());
  EXPECT_EQ(value, shippedLabelMap("semantickitti.yaml"));
  EXPECT_TRUE(std::filesystem::is_regular_file(value)) << value;
}

TEST_F(SemanticKittiSourceTest, DatasetRootWithSequence) {
  const std::string root = test::dataPath("semantickitti_seq00_000000-000005");
  EXPECT_EQ(make("{path: " + root + ", sequence: '00'}")->size(), 6u);
  EXPECT_EQ(make("{path: " + root + "}")->size(), 6u);  // the only sequence
  try {
    make("{path: " + root + ", sequence: '08'}");
    FAIL() << "expected an error for a missing sequence";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("sequence"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("00"), std::string::npos) << e.what();
  }
  const auto fixture = make("{path: " + test::dataPath("semantickitti_mmdet3d_fixture") + "}");
  ASSERT_EQ(fixture->size(), 1u);
  const Frame f = fixture->read(0);
  EXPECT_EQ(f.points.size(), 50u);
  std::map<uint32_t, std::size_t> h;
  for (uint32_t r : f.truth.raw) ++h[r];
  EXPECT_EQ(
      h, (std::map<uint32_t, std::size_t>{{0, 2}, {50, 25}, {52, 1}, {70, 17}, {71, 3}, {80, 2}}));
  EXPECT_FALSE(f.points.hasRing());  // 50 points carry no ring structure
}

// A sequence folder as path with another sequence asked for: a parameter error naming both,
// before any frame is read (it used to read the folder's own sequence).
TEST_F(SemanticKittiSourceTest, SequenceParameterThatDisagreesWithTheFolderIsAnError) {
  const std::string seq = test::dataPath("semantickitti_seq00_000000-000005/sequences/00");
  EXPECT_EQ(make("{path: " + seq + ", sequence: '00'}")->size(), 6u);
  try {
    make("{path: " + seq + ", sequence: '08'}");
    FAIL() << "expected an error for sequence 08 with the folder of sequence 00";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    // (The path as the parameter resolved it: the data folder's "/../" is gone.)
    EXPECT_NE(what.find("parameter 'sequence': is '08', but path '"), std::string::npos) << what;
    EXPECT_NE(what.find("sequences/00' is itself the sequence folder '00'"), std::string::npos)
        << what;
  }
}

TEST_F(SemanticKittiSourceTest, MissingDataPathIsAParameterError) {
  try {
    make("{path: /nonexistent/kitti}");
    FAIL();
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
  }
  test::TempDir dir;
  EXPECT_THROW(make("{path: " + dir.str() + "}"), std::exception);  // no velodyne/
}

TEST_F(SemanticKittiSourceTest, KittiObjectWithImages) {
  auto src =
      make("{path: " + test::dataPath("kitti_object_fusion/training") + ", use_images: true}");
  ASSERT_EQ(src->size(), 2u);
  const std::size_t points[] = {115384, 120268};
  const int w[] = {1224, 1242}, h[] = {370, 375};
  // P2·R0_rect·Tr_velo_to_cam, in front of the camera, −0.5 ≤ u < W − 0.5 and −0.5 ≤ v < H − 0.5
  // (pixel centres at integers; with 0 ≤ u < W instead numpy counts 20285 and 18630).
  const std::size_t in_image[] = {20259, 18608};
  for (std::size_t i = 0; i < 2; ++i) {
    const Frame f = src->read(i);
    EXPECT_EQ(f.points.size(), points[i]);
    EXPECT_TRUE(f.truth.empty());  // label_2 boxes are not per-point labels
    EXPECT_FALSE(f.pose.has_value());
    ASSERT_EQ(f.cameras.size(), 1u);
    const CameraImage& cam = f.cameras[0];
    EXPECT_EQ(cam.model.width, w[i]);
    EXPECT_EQ(cam.model.height, h[i]);
    ASSERT_TRUE(cam.image);
    EXPECT_EQ(cam.image->width, w[i]);
    EXPECT_EQ(cam.image->channels, 3);
    std::size_t in = 0;
    for (std::size_t k = 0; k < f.points.size(); ++k)
      in += cam.model.project({f.points.x[k], f.points.y[k], f.points.z[k]}).has_value();
    EXPECT_NEAR(double(in), double(in_image[i]), 3.0);
  }
  // The parent folder works too.
  EXPECT_EQ(make("{path: " + test::dataPath("kitti_object_fusion") + "}")->size(), 2u);
}

TEST_F(SemanticKittiSourceTest, RecentresTheShiftedOpen3dMlScan) {
  const std::string path = test::dataPath("semantickitti_o3dml_demo/converted_semantickitti");
  auto raw = make("{path: " + path + ", ring_method: none}");
  auto rec = make("{path: " + path + ", recentre: auto}");
  ASSERT_EQ(rec->size(), 2u);
  const Frame a0 = raw->read(0), a1 = rec->read(0);
  ASSERT_EQ(a0.points.size(), 85962u);
  ASSERT_EQ(a1.points.size(), 85962u);
  const double dx = a1.points.x[0] - a0.points.x[0], dy = a1.points.y[0] - a0.points.y[0];
  // PROVENANCE.md: the sensor sits near (0.0, -100.1) in 000700.
  EXPECT_NEAR(dx, 0.0, 0.5);
  EXPECT_NEAR(dy, 100.1, 0.5);
  EXPECT_NEAR(a1.points.y[1000] - a0.points.y[1000], dy, 1e-3);
  EXPECT_TRUE(a1.points.hasRing());  // elevation binning: the .npy order is not scan order
  EXPECT_EQ(a1.truth.label.size(), 85962u);
  const Frame b0 = raw->read(1), b1 = rec->read(1);
  ASSERT_EQ(b1.points.size(), 86139u);
  EXPECT_EQ(b0.points.x, b1.points.x);  // 000750 is centred: left untouched
  EXPECT_EQ(b0.points.y, b1.points.y);
}

// recentre: auto moves the points; the pose and the truth pose move with them, so that both
// still take the points to the same place in the world.
TEST_F(SemanticKittiSourceTest, RecentreKeepsPoseAndTruthPoseOnThePoints) {
  test::TempDir dir;
  const std::string demo = test::dataPath("semantickitti_o3dml_demo/converted_semantickitti");
  const std::string seq = dir.str() + "/seq";
  std::filesystem::create_directories(seq);
  std::filesystem::copy(demo + "/velodyne", seq + "/velodyne");
  std::ofstream(seq + "/calib.txt") << kOdoCalib;
  {
    std::ofstream poses(seq + "/poses.txt");  // the scans are frames 700 and 750
    for (int k = 0; k <= 750; ++k) poses << "1 0 0 " << 0.5 * k << " 0 1 0 0 0 0 1 0\n";
  }
  const Frame raw = make("{path: " + seq + ", ring_method: none}")->read(0);
  const Frame rec = make("{path: " + seq + ", ring_method: none, recentre: auto}")->read(0);
  ASSERT_TRUE(raw.truth_pose && raw.pose && rec.truth_pose && rec.pose);
  EXPECT_TRUE(raw.truth_pose->isApprox(*raw.pose, 0.0));
  EXPECT_TRUE(rec.truth_pose->isApprox(*rec.pose, 0.0));
  ASSERT_EQ(rec.points.size(), raw.points.size());
  EXPECT_GT(std::abs(rec.points.y[0] - raw.points.y[0]), 100.0);  // moved (PROVENANCE.md)
  for (std::size_t k : {std::size_t(0), std::size_t(1000), raw.points.size() - 1}) {
    const Eigen::Vector3d p_raw(raw.points.x[k], raw.points.y[k], raw.points.z[k]);
    const Eigen::Vector3d p_rec(rec.points.x[k], rec.points.y[k], rec.points.z[k]);
    EXPECT_LT((*rec.truth_pose * p_rec - *raw.truth_pose * p_raw).norm(), 1e-4) << k;
  }
}

// recentre: auto on a cloud whose sensor origin cannot be estimated: the cloud stays as stored,
// and stderr says so naming the scan (it used to stay off-centre without a word). An estimate
// shorter than recentre_min_m is a deliberate, silent skip.
TEST_F(SemanticKittiSourceTest, RecentreThatCannotEstimateTheOriginSaysSoNamingTheScan) {
  test::TempDir dir;
  const std::string seq = tinySequence(dir);  // 3 points: no ring to fit
  auto src = make("{path: " + seq + ", recentre: auto, ring_method: none}");
  testing::internal::CaptureStderr();
  const Frame f = src->read(0);
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_EQ(f.points.x, (std::vector<float>{5, 6, 7}));  // left as stored
  EXPECT_NE(err.find("semantickitti: " + seq +
                     "/velodyne/000000.bin: recentre: auto could not estimate the sensor origin "
                     "(too few points (3)); the cloud is left as stored"),
            std::string::npos)
      << err;
  // Seq 00 frame 0: the estimate lies within recentre_min_m of (0, 0), nothing is said.
  auto real = make("{path: " + test::dataPath("semantickitti_seq00_000000-000005/sequences/00") +
                   ", recentre: auto}");
  testing::internal::CaptureStderr();
  const Frame g = real->read(0);
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
  EXPECT_EQ(g.points.size(), 124668u);
}

TEST_F(SemanticKittiSourceTest, MissingImageOrCalibrationWhenRequested) {
  test::TempDir dir;
  const std::string seq = tinySequence(dir);
  auto src = make("{path: " + seq + ", use_images: true}");
  try {
    src->read(0);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), seq + "/image_2/000000.png");
  }
  // Image present, calibration missing.
  test::TempDir dir2;
  const std::string seq2 = tinySequence(dir2, /*calib=*/false);
  writeImageAtomic(seq2 + "/image_2/000000.png", Image(1241, 376, 3));
  auto src2 = make("{path: " + seq2 + ", use_images: true}");
  try {
    src2->read(0);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), seq2 + "/calib.txt");
  }
  // Both present: a frame with a camera.
  std::ofstream(seq2 + "/calib.txt") << kOdoCalib;
  const Frame f = make("{path: " + seq2 + ", use_images: true}")->read(0);
  ASSERT_EQ(f.cameras.size(), 1u);
  EXPECT_EQ(f.cameras[0].model.width, 1241);
  EXPECT_EQ(f.cameras[0].model.calibration, seq2 + "/calib.txt (P2, Tr)");
  EXPECT_EQ(f.truth.label,
            (std::vector<LabelId>{labels::kRoad, labels::kRough, labels::kObstacle}));
}

// docs/own_data.md: image_2 with a calib.txt of P2 and Tr is all a sequence of your own needs.
TEST_F(SemanticKittiSourceTest, CalibrationWithOnlyP2AndTrReadsImage2) {
  test::TempDir dir;
  const std::string seq = tinySequence(dir, /*calib=*/false);
  std::ofstream(seq + "/calib.txt")
      << "P2: 718.856 0 607.1928 45.38225 0 718.856 185.2157 -0.1130887 0 0 1 0.003779761\n"
         "Tr: 0 -1 0 0 0 0 -1 0 1 0 0 -0.27\n";
  writeImageAtomic(seq + "/image_2/000000.png", Image(1241, 376, 3));
  const Frame f = make("{path: " + seq + ", use_images: true}")->read(0);
  ASSERT_EQ(f.cameras.size(), 1u);
  EXPECT_EQ(f.cameras[0].model.calibration, seq + "/calib.txt (P2, Tr)");
  // Asking for image_3 as well: the missing P3 is named.
  writeImageAtomic(seq + "/image_3/000000.png", Image(1241, 376, 3));
  try {
    make("{path: " + seq + ", use_images: true, cameras: [image_2, image_3]}")->read(0);
    FAIL() << "expected InputError for image_3 without P3";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), seq + "/calib.txt");
    EXPECT_NE(std::string(e.what()).find("no 'P3:' entry"), std::string::npos) << e.what();
  }
}

// KITTI's colour pair: image_2 and image_3, each projected with its own P (P3 holds the
// 0.54 m baseline), from the real object frame's calibration.
TEST_F(SemanticKittiSourceTest, StereoPairReadsEachCameraWithItsOwnProjection) {
  const std::string real = test::dataPath("kitti_object_fusion/training");
  test::TempDir dir;
  const std::string root = dir.str() + "/training";
  for (const char* sub : {"velodyne", "calib", "image_2", "image_3"})
    std::filesystem::create_directories(root + "/" + sub);
  for (const char* f : {"/velodyne/000000.bin", "/calib/000000.txt", "/image_2/000000.png"})
    std::filesystem::create_symlink(real + f, root + f);
  // The data holds no right image; the left one stands in (same size, only geometry is tested).
  std::filesystem::create_symlink(real + "/image_2/000000.png", root + "/image_3/000000.png");

  const Frame f =
      make("{path: " + root + ", use_images: true, cameras: [image_2, image_3]}")->read(0);
  ASSERT_EQ(f.cameras.size(), 2u);
  EXPECT_EQ(f.cameras[0].model.name, "image_2");
  EXPECT_EQ(f.cameras[1].model.name, "image_3");
  EXPECT_EQ(f.cameras[1].source_path, root + "/image_3/000000.png");
  EXPECT_EQ(f.cameras[1].model.calibration,
            root + "/calib/000000.txt (P3, R0_rect, Tr_velo_to_cam)");
  const KittiCalib c = readKittiCalib(root + "/calib/000000.txt");
  int both = 0;
  for (std::size_t k = 0; k < f.points.size(); k += 97) {
    const Eigen::Vector3d x(f.points.x[k], f.points.y[k], f.points.z[k]);
    const Eigen::Vector3d x0 = c.T_cam_velo * x;  // rectified camera-0 frame
    const auto l = f.cameras[0].model.project(x), r = f.cameras[1].model.project(x);
    if (!l || !r) continue;
    ++both;
    const Eigen::Vector3d q = c.P[3] * x0.homogeneous();
    EXPECT_NEAR(r->x(), q.x() / q.z(), 1e-6);
    EXPECT_NEAR(r->y(), q.y() / q.z(), 1e-6);
    // Rectified pair: the same row and a disparity of f·b / z with b = (P2(0,3) − P3(0,3)) / f ≈
    // 0.54 m, up to the cameras' small offsets along y and z (P(1,3), P(2,3): < 1 px beyond 4 m).
    EXPECT_NEAR(r->y(), l->y(), 1.0);
    EXPECT_NEAR(l->x() - r->x(), (c.P[2](0, 3) - c.P[3](0, 3)) / x0.z(), 1.0);
    EXPECT_GT(l->x() - r->x(), 0.0);
  }
  EXPECT_GT(both, 100);

  // Bad camera lists and a missing right image.
  for (const auto& [cams, says] :
       {std::pair<std::string, std::string>{"[image_5]",
                                            "unknown camera 'image_5'; expected "
                                            "image_0, image_1, image_2 or image_3"},
        {"[image_2, image_2]", "'image_2' is listed twice"},
        {"[]", "is empty; expected at least one"}}) {
    try {
      make("{path: " + root + ", use_images: true, cameras: " + cams + "}");
      FAIL() << "expected an error for cameras: " << cams;
    } catch (const std::exception& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("cameras"), std::string::npos) << what;
      EXPECT_NE(what.find(says), std::string::npos) << what;
    }
  }
  std::filesystem::remove(root + "/image_3/000000.png");
  try {
    make("{path: " + root + ", use_images: true, cameras: [image_2, image_3]}")->read(0);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), root + "/image_3/000000.png");
  }
}

/// A KITTI object folder in `dir` whose frame 000001 is the real one (scan and calibration linked,
/// not copied) with image_2 resized to w × h px by OpenCV; `calib_text` replaces the calibration.
std::string resizedKittiObject(const test::TempDir& dir, int w, int h,
                               const std::string& calib_text = "") {
  const std::string real = test::dataPath("kitti_object_fusion/training");
  const std::string root = dir.str() + "/training";
  for (const char* sub : {"velodyne", "calib", "image_2"})
    std::filesystem::create_directories(root + "/" + sub);
  std::filesystem::create_symlink(real + "/velodyne/000001.bin", root + "/velodyne/000001.bin");
  if (calib_text.empty())
    std::filesystem::create_symlink(real + "/calib/000001.txt", root + "/calib/000001.txt");
  else
    std::ofstream(root + "/calib/000001.txt") << calib_text;
  cv::Mat img = cv::imread(real + "/image_2/000001.png"), out;
  EXPECT_EQ(img.cols, 1242);
  cv::resize(img, out, cv::Size(w, h), 0, 0, cv::INTER_AREA);
  cv::imwrite(root + "/image_2/000001.png", out);
  return root;
}

// The source takes the camera's size from the image, so an image with 100 px cut off its left
// edge (1242 → 1142) was read with the full image's calibration and every pixel lookup shifted
// by 100 px: its principal point, 3.4 % of the width off the new centre, passed the 10 % bound.
TEST_F(SemanticKittiSourceTest, CroppedImageIsAnErrorNamingImageCalibrationAndWhatWasExpected) {
  test::TempDir dir;
  const std::string root = resizedKittiObject(dir, 1242, 375);
  const cv::Mat img = cv::imread(root + "/image_2/000001.png");
  cv::imwrite(root + "/image_2/000001.png", img(cv::Rect(100, 0, 1142, 375)).clone());
  try {
    make("{path: " + root + ", use_images: true}")->read(0);
    FAIL() << "expected InputError for the cropped image";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.file(), root + "/image_2/000001.png");
    EXPECT_NE(what.find("image is 1142x375 px"), std::string::npos) << what;
    EXPECT_NE(what.find("principal point (609.6, 172.9) px is not near its centre (571.0, 187.5)"),
              std::string::npos)
        << what;
    EXPECT_NE(what.find("expected within 2.5 % of its width and 8 % of its height of the centre"),
              std::string::npos)
        << what;
    EXPECT_NE(what.find(root + "/calib/000001.txt (P2, R0_rect, Tr_velo_to_cam)"),
              std::string::npos)
        << what;
  }
  // Both real frames of the shipped KITTI object data still read with their images.
  auto real = make("{path: " + test::dataPath("kitti_object_fusion/training") +
                   ", use_images: true, use_labels: false, use_poses: false}");
  for (int i = 0; i < 2; ++i) EXPECT_EQ(real->read(i).cameras.size(), 1u) << "frame " << i;
}

// KITTI's calib files store no image size and the source takes it from the image, so a resized
// image used to pass silently with a calibration that no longer fits (halved: 2180 of 20259
// points still in the image); the principal point check catches it.
TEST_F(SemanticKittiSourceTest, ResizedImageIsAnErrorNamingImageAndCalibration) {
  // Halved, three quarters, doubled (0.75× passed the middle-half rule; the 2.5 % bound on cx
  // catches it).
  for (const auto& [w, h] : {std::pair{621, 188}, std::pair{931, 281}, std::pair{2484, 750}}) {
    test::TempDir dir;
    const std::string root = resizedKittiObject(dir, w, h);
    auto src = make("{path: " + root + ", use_images: true}");
    try {
      src->read(0);
      FAIL() << "expected InputError for a " << w << "x" << h << " image";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_EQ(e.file(), root + "/image_2/000001.png");
      EXPECT_NE(what.find(std::to_string(w) + "x" + std::to_string(h) + " px"), std::string::npos);
      EXPECT_NE(what.find("principal point (609.6, 172.9) px"), std::string::npos) << what;
      EXPECT_NE(what.find(root + "/calib/000001.txt (P2, R0_rect, Tr_velo_to_cam)"),
                std::string::npos)
          << what;
    }
  }
  // The same frame at its own size reads, and so do KITTI odometry's 1241 × 376 (above).
  test::TempDir dir;
  const Frame f =
      make("{path: " + resizedKittiObject(dir, 1242, 375) + ", use_images: true}")->read(0);
  ASSERT_EQ(f.cameras.size(), 1u);
  EXPECT_EQ(f.cameras[0].image->width, 1242);
  // KITTI odometry calibration with a 16 × 8 image.
  test::TempDir odo;
  const std::string seq = tinySequence(odo);
  writeImageAtomic(seq + "/image_2/000000.png", Image(16, 8, 3));
  try {
    make("{path: " + seq + ", use_images: true}")->read(0);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), seq + "/image_2/000000.png");
    EXPECT_NE(std::string(e.what()).find(seq + "/calib.txt (P2, Tr)"), std::string::npos)
        << e.what();
  }
}

TEST_F(SemanticKittiSourceTest, ImageSizeParameterIsCompared) {
  // The two object frames are 1224 × 370 and 1242 × 375.
  auto src = make("{path: " + test::dataPath("kitti_object_fusion/training") +
                  ", use_images: true, image_size: [1242, 375]}");
  EXPECT_NO_THROW(src->read(1));
  try {
    src->read(0);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("image_2/000000.png"), std::string::npos) << what;
    EXPECT_NE(what.find("1224x370 px"), std::string::npos) << what;
    EXPECT_NE(what.find("1242x375 px"), std::string::npos) << what;
    EXPECT_NE(what.find("calib/000000.txt"), std::string::npos) << what;
  }
  for (const char* bad : {"[1242]", "[0, 375]", "[1242.5, 375]"})
    EXPECT_THROW(make("{path: " + test::dataPath("kitti_object_fusion/training") +
                      ", image_size: " + bad + "}"),
                 std::runtime_error)
        << bad;
}

TEST_F(SemanticKittiSourceTest, BadScansAndLabels) {
  test::TempDir dir;
  const std::string seq = tinySequence(dir);
  // Label count mismatch.
  writeU32(seq + "/labels/000000.label", {40, 72});
  auto src = make("{path: " + seq + "}");
  try {
    src->read(0);
    FAIL();
  } catch (const InputError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("000000.label"), std::string::npos) << w;
    EXPECT_NE(w.find("000000.bin"), std::string::npos) << w;
    EXPECT_NE(w.find("2 labels"), std::string::npos) << w;
    EXPECT_NE(w.find("3 points"), std::string::npos) << w;
  }
  // Unmapped id.
  writeU32(seq + "/labels/000000.label", {40, 72, 5});
  try {
    src->read(0);
    FAIL();
  } catch (const InputError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("semantickitti.yaml"), std::string::npos) << w;
    EXPECT_NE(w.find(" 5"), std::string::npos) << w;
    EXPECT_NE(w.find("000000.label"), std::string::npos) << w;
  }
  // NaN coordinates and no-return points are counted, with their labels dropped.
  const float nan = std::nanf("");
  writeFloats(seq + "/velodyne/000000.bin", {5, 0, -1.7f, 0.3f, nan, 1, 1, 0, 0, 0, 0, 0});
  writeU32(seq + "/labels/000000.label", {40, 72, 0});
  Frame f = src->read(0);
  EXPECT_EQ(f.points.size(), 1u);
  EXPECT_EQ(f.dropped_nonfinite_points, 1u);
  EXPECT_EQ(f.dropped_no_return_points, 1u);
  EXPECT_EQ(f.truth.raw, (std::vector<uint32_t>{40}));
  // Size not a multiple of 16.
  writeFloats(seq + "/velodyne/000000.bin", {1, 2, 3, 4, 5});
  try {
    src->read(0);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), seq + "/velodyne/000000.bin");
    EXPECT_NE(std::string(e.what()).find("20 bytes"), std::string::npos) << e.what();
  }
  // Empty scan: a valid empty frame.
  writeFloats(seq + "/velodyne/000000.bin", {});
  writeU32(seq + "/labels/000000.label", {});
  f = src->read(0);
  EXPECT_TRUE(f.points.empty());
  EXPECT_EQ(f.dropped_nonfinite_points + f.dropped_no_return_points, 0u);
  EXPECT_EQ(f.id, "000000");
}

// A velodyne/ folder without scans would be a run over no frames: refused at configure, naming
// the folder (the parameter error carries the parameter's name).
TEST_F(SemanticKittiSourceTest, NoScansInVelodyneIsAParameterErrorNamingTheFolder) {
  test::TempDir dir;
  const std::string seq = dir.str() + "/seq";
  std::filesystem::create_directories(seq + "/velodyne");
  std::ofstream(seq + "/velodyne/README.txt") << "not a scan\n";
  try {
    make("{path: " + seq + "}");
    FAIL() << "expected an error for a velodyne/ folder without .bin files";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("parameter 'path': no .bin scans in '" + seq + "/velodyne'"),
              std::string::npos)
        << what;
  }
}

// times.txt is read at configure; its InputError becomes an error of the 'path' parameter and
// keeps the file and line.
TEST_F(SemanticKittiSourceTest, BadTimesFileIsAParameterErrorNamingFileAndLine) {
  test::TempDir dir;
  const std::string seq = tinySequence(dir);
  std::ofstream(seq + "/times.txt") << "0.0\n0.1 s\n";
  try {
    make("{path: " + seq + "}");
    FAIL() << "expected an error for a bad times.txt";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("parameter 'path': " + seq + "/times.txt: line 2: expected one time [s]"),
              std::string::npos)
        << what;
  }
}

// A poses.txt shorter than the sequence: the frame past its end is an InputError naming the
// poses file, its pose count and the frame; earlier frames still read.
TEST_F(SemanticKittiSourceTest, PosesFileShorterThanTheSequenceNamesFileAndFrame) {
  test::TempDir dir;
  const std::string seq = tinySequence(dir);
  std::filesystem::copy_file(seq + "/velodyne/000000.bin", seq + "/velodyne/000001.bin");
  std::ofstream(seq + "/poses.txt") << "1 0 0 0 0 1 0 0 0 0 1 0\n";
  auto src = make("{path: " + seq + "}");
  ASSERT_EQ(src->size(), 2u);
  EXPECT_TRUE(src->read(0).pose.has_value());
  try {
    src->read(1);
    FAIL() << "expected InputError for frame 000001 past the poses";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), seq + "/poses.txt");
    EXPECT_NE(std::string(e.what()).find("has 1 poses; frame 000001 has none"), std::string::npos)
        << e.what();
  }
}

// The pose is declared written (stages that read it, such as a temporal one, are checked against
// the declaration) exactly when every frame has one: with a poses.txt read. The source declared
// nothing, so a stage that reads the pose was refused even over a sequence with poses.
TEST_F(SemanticKittiSourceTest, DeclaresThePoseWrittenWhenItReadsAPosesFile) {
  test::TempDir dir;
  const std::string seq = tinySequence(dir);
  EXPECT_TRUE(make("{path: " + seq + "}")->writes().empty());  // no poses.txt
  std::ofstream(seq + "/poses.txt") << "1 0 0 0 0 1 0 0 0 0 1 0\n";
  EXPECT_EQ(make("{path: " + seq + "}")->writes(), std::vector<std::string>{artefacts::kPose});
  EXPECT_TRUE(make("{path: " + seq + ", use_poses: false}")->writes().empty());
}

// A times.txt shorter than the sequence: the frame past its end is an InputError naming the
// file, its count and the frame (it used to get frame number x 0.1 s, silently on another time
// base than the frames before it). Without times.txt the 10 Hz rule stays.
TEST_F(SemanticKittiSourceTest, TimesFileShorterThanTheSequenceNamesFileCountAndFrame) {
  test::TempDir dir;
  const std::string seq = tinySequence(dir);
  std::filesystem::copy_file(seq + "/velodyne/000000.bin", seq + "/velodyne/000001.bin");
  auto plain = make("{path: " + seq + "}");
  EXPECT_NEAR(plain->read(1).timestamp_s, 0.1, 1e-12);  // no times.txt: 10 Hz
  std::ofstream(seq + "/times.txt") << "1.000000e+03\n";
  auto src = make("{path: " + seq + "}");
  ASSERT_EQ(src->size(), 2u);
  EXPECT_EQ(src->read(0).timestamp_s, 1000.0);
  try {
    const Frame f = src->read(1);
    FAIL() << "expected InputError for frame 000001 past times.txt, got time " << f.timestamp_s;
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), seq + "/times.txt");
    EXPECT_NE(std::string(e.what()).find("has 1 time(s), one per line, but frame 000001 needs "
                                         "line 2; expected a time for every frame"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace terramrf
