// The "rellis3d" source on the RELLIS-3D example frame, plus bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "terramrf/errors.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

class Rellis3dSourceTest : public ::testing::Test {
 protected:
  Rellis3dSourceTest() : reg_({test::pluginDir()}) { ctx_.labels = &labels_; }
  std::unique_ptr<Source> make(const std::string& params) {
    auto p = reg_.create("rellis3d");
    setParams(*p, params, ctx_);
    return std::unique_ptr<Source>(dynamic_cast<Source*>(p.release()));
  }
  PluginRegistry reg_;
  LabelSet labels_ = LabelSet::defaults();
  PluginContext ctx_;
};

TEST_F(Rellis3dSourceTest, ExampleFrameWithLabelsRingsAndCamera) {
  const std::string dir = test::dataPath("rellis3d_example_000104");
  auto src = make("{path: " + dir + ", use_images: true}");
  ASSERT_EQ(src->size(), 1u);  // vel000104.bin (Velodyne) is not a frame
  EXPECT_EQ(src->frameId(0), "000104");
  const Frame f = src->read(0);
  EXPECT_EQ(f.points.size(), 131072u - 53364u);
  EXPECT_EQ(f.dropped_no_return_points, 53364u);  // Ouster no-returns at the origin
  EXPECT_EQ(f.dropped_nonfinite_points, 0u);
  EXPECT_NEAR(f.timestamp_s, 1581624663.149, 1e-3);
  ASSERT_TRUE(f.points.hasRing());
  std::map<int, std::size_t> per_ring;
  for (uint16_t r : f.points.ring) ++per_ring[r];
  EXPECT_EQ(per_ring.size(), 64u);
  ASSERT_EQ(f.truth.label.size(), f.points.size());
  std::map<LabelId, std::size_t> mapped;
  for (LabelId l : f.truth.label) ++mapped[l];
  // PROVENANCE.md histogram mapped by configs/label_maps/rellis3d.yaml, no-returns dropped.
  EXPECT_EQ(mapped[labels::kUnknown], 68284u - 53364u);
  EXPECT_EQ(mapped[labels::kRoad], 20242u);
  EXPECT_EQ(mapped[labels::kRough], 18040u + 1269u + 100u);
  EXPECT_EQ(mapped[labels::kObstacle], 17872u + 1310u + 595u + 3360u);

  ASSERT_EQ(f.cameras.size(), 1u);
  const CameraImage& cam = f.cameras[0];
  ASSERT_TRUE(cam.image);
  ASSERT_TRUE(cam.truth);
  EXPECT_EQ(cam.image->width, 1920);
  EXPECT_EQ(cam.image->height, 1200);
  EXPECT_EQ(cam.truth->channels, 1);
  // Pixel histogram of PROVENANCE.md (RELLIS ids) mapped to project classes.
  std::map<int, std::size_t> px;
  for (uint8_t v : cam.truth->data) ++px[v];
  EXPECT_EQ(px[labels::kRough], 415080u + 401363u + 22443u);
  EXPECT_EQ(px[labels::kObstacle], 475286u + 207u + 6727u + 49037u + 4880u + 430063u);
  EXPECT_EQ(px[labels::kUnknown], 498914u);
  EXPECT_EQ(px[labels::kRoad], 0u);
  // Labelled points that land in the image mostly hit a pixel of the same project class.
  std::size_t both = 0, same = 0;
  for (std::size_t i = 0; i < f.points.size(); ++i) {
    const auto uv = cam.model.project({f.points.x[i], f.points.y[i], f.points.z[i]});
    if (!uv) continue;
    const LabelId p = *cam.truth->at(int(uv->x()), int(uv->y()));
    if (p == labels::kUnknown || f.truth.label[i] == labels::kUnknown) continue;
    ++both;
    same += p == f.truth.label[i];
  }
  std::printf("RELLIS 000104: %zu labelled points in the image, %.3f same project class\n", both,
              double(same) / both);
  EXPECT_GT(both, 7000u);
  EXPECT_GT(double(same) / both, 0.8);
}

TEST_F(Rellis3dSourceTest, WithoutImagesNoCamera) {
  const Frame f = make("{path: " + test::dataPath("rellis3d_example_000104") + "}")->read(0);
  EXPECT_TRUE(f.cameras.empty());
  const Frame g = make("{path: " + test::dataPath("rellis3d_example_000104") +
                       ", drop_no_return: false, use_labels: false}")
                      ->read(0);
  EXPECT_EQ(g.points.size(), 131072u);
  EXPECT_TRUE(g.truth.empty());
  EXPECT_EQ(g.points.ring[64], 0);
  EXPECT_EQ(g.points.ring[65], 1);
}

/// The example frame in `dir` (scan, labels and calibration linked, not copied) with its camera
/// image resized to w × h px by OpenCV and no pixel-label image.
std::string resizedExample(const test::TempDir& dir, int w, int h) {
  const std::string real = test::dataPath("rellis3d_example_000104");
  for (const char* f : {"000104.bin", "000104.label", "camera_info.txt", "transforms.yaml"})
    std::filesystem::create_symlink(real + "/" + f, dir.str() + "/" + f);
  const std::string jpg = "/frame000104-1581624663_149.jpg";
  cv::Mat img = cv::imread(real + jpg), out;
  EXPECT_EQ(img.cols, 1920);
  cv::resize(img, out, cv::Size(w, h), 0, 0, cv::INTER_AREA);
  cv::imwrite(dir.str() + jpg, out);
  return dir.str() + jpg;
}

// camera_info.txt stores no image size; a halved image used to be fused with the full-size
// intrinsics without an error.
TEST_F(Rellis3dSourceTest, ResizedImageIsAnErrorNamingImageAndCalibration) {
  test::TempDir dir;
  const std::string jpg = resizedExample(dir, 960, 600);
  try {
    make("{path: " + dir.str() + ", use_images: true}")->read(0);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.file(), jpg);
    EXPECT_NE(what.find("960x600 px"), std::string::npos) << what;
    EXPECT_NE(what.find("principal point (969.3, 624.0) px"), std::string::npos) << what;
    EXPECT_NE(what.find(dir.str() + "/camera_info.txt"), std::string::npos) << what;
    EXPECT_NE(what.find(dir.str() + "/transforms.yaml"), std::string::npos) << what;
  }
  // Its own size reads (also with image_size), and the camera names its calibration files.
  test::TempDir same;
  resizedExample(same, 1920, 1200);
  const Frame f =
      make("{path: " + same.str() + ", use_images: true, image_size: [1920, 1200]}")->read(0);
  ASSERT_EQ(f.cameras.size(), 1u);
  EXPECT_NE(f.cameras[0].model.calibration.find(same.str() + "/camera_info.txt"),
            std::string::npos);
  // image_size is compared exactly.
  EXPECT_THROW(
      make("{path: " + same.str() + ", use_images: true, image_size: [1920, 1080]}")->read(0),
      InputError);
}

// The pixel label image is mapped pixel for pixel onto the camera image: one of another size, or
// a colour rendering of the labels instead of the ids, is refused naming it, the size and channels
// expected and those found.
TEST_F(Rellis3dSourceTest, PixelLabelImageOfTheWrongSizeOrChannelsIsNamed) {
  test::TempDir dir;
  resizedExample(dir, 1920, 1200);
  const std::string png = dir.str() + "/frame000104-1581624663_149.png";
  struct Case {
    cv::Mat image;
    std::string got;
  };
  for (const Case& c :
       {Case{cv::Mat(600, 960, CV_8UC1, cv::Scalar(3)), "1 channels 960x600"},
        Case{cv::Mat(1200, 1920, CV_8UC3, cv::Scalar(3, 3, 3)), "3 channels 1920x1200"}}) {
    ASSERT_TRUE(cv::imwrite(png, c.image));
    try {
      make("{path: " + dir.str() + ", use_images: true}")->read(0);
      ADD_FAILURE() << "accepted a label image of " << c.got;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), png);
      EXPECT_NE(std::string(e.what()).find(
                    "expected a 1-channel label image of 1920x1200 px, got " + c.got),
                std::string::npos)
          << e.what();
    }
  }
  // Without use_image_labels the file is not read.
  const Frame f =
      make("{path: " + dir.str() + ", use_images: true, use_image_labels: false}")->read(0);
  ASSERT_EQ(f.cameras.size(), 1u);
  EXPECT_FALSE(f.cameras[0].truth);
}

/// `n` points along x (all at elevation 0, so any ring order is consistent) as scan
/// `<dir>/<id>.bin`.
void writeFlatScan(const std::string& dir, const std::string& id, int n = 128) {
  std::vector<float> pts(4 * n, 0.f);
  for (int i = 0; i < n; ++i) pts[4 * i] = 1.f + i;
  std::ofstream(dir + "/" + id + ".bin", std::ios::binary)
      .write(reinterpret_cast<const char*>(pts.data()), std::streamsize(pts.size() * 4));
}

// One time base per sequence: frames with a camera image take its epoch stamp, and frames without
// one are placed from the nearest frame that has one at the Ouster's 10 Hz. They used to get
// id x 0.1 s, ~1.6e9 s away from their neighbours, within the same sequence.
TEST_F(Rellis3dSourceTest, FramesWithoutAnImageAreTimedOnTheImagesEpochBase) {
  test::TempDir dir;
  for (const char* id : {"000000", "000001", "000002", "000005", "000006"})
    writeFlatScan(dir.str(), id);
  // Only the names matter here (use_images is off): frame<id>-<seconds>_<fraction>.jpg.
  std::ofstream(dir.str() + "/frame000001-1581624663_149.jpg") << "";
  std::ofstream(dir.str() + "/frame000005-1581624663_560.jpg") << "";
  auto src = make("{path: " + dir.str() + ", use_labels: false}");
  ASSERT_EQ(src->size(), 5u);
  const double expected[] = {1581624663.049, 1581624663.149, 1581624663.249, 1581624663.560,
                             1581624663.660};
  for (std::size_t i = 0; i < 5; ++i)
    EXPECT_NEAR(src->read(i).timestamp_s, expected[i], 1e-6) << src->frameId(i);
  // No image at all: id x 0.1 s for every frame, one base again.
  test::TempDir bare;
  for (const char* id : {"000003", "000004"}) writeFlatScan(bare.str(), id);
  auto plain = make("{path: " + bare.str() + ", use_labels: false}");
  EXPECT_NEAR(plain->read(0).timestamp_s, 0.3, 1e-12);
  EXPECT_NEAR(plain->read(1).timestamp_s, 0.4, 1e-12);
}

// ring = index % 64 holds only for an organised scan stored column by column. A scan that merely
// has a multiple of 64 points used to pass and get rings that mix every elevation: the
// VLP-32C scan of the example cut to 37 312 points, or an Ouster scan stored ring by ring. Both
// are refused naming the file, the ring and its spread; the real 000104 (< 1e-5° per ring) reads.
TEST_F(Rellis3dSourceTest, ScanThatIsNotOrganisedColumnByColumnIsRefused) {
  std::vector<float> vel(37334 * 4);
  std::ifstream(test::dataPath("rellis3d_example_000104/vel000104.bin"), std::ios::binary)
      .read(reinterpret_cast<char*>(vel.data()), std::streamsize(vel.size() * 4));
  vel.resize(37312 * 4);  // 583 "columns" of 64
  // An organised 64 × 128 scan (ring r at 15° − 0.5° r, 10 m) stored ring by ring.
  std::vector<float> rows;
  for (int r = 0; r < 64; ++r)
    for (int c = 0; c < 128; ++c) {
      const double el = (15.0 - 0.5 * r) * M_PI / 180, az = 2 * M_PI * c / 128;
      rows.insert(rows.end(),
                  {float(10 * std::cos(el) * std::cos(az)), float(10 * std::cos(el) * std::sin(az)),
                   float(10 * std::sin(el)), 0.f});
    }
  for (const auto& [points, what] : {std::pair{vel, "VLP-32C cut to 64-point columns"},
                                     std::pair{rows, "Ouster stored ring by ring"}}) {
    test::TempDir dir;
    const std::string bin = dir.str() + "/000104.bin";
    std::ofstream(bin, std::ios::binary)
        .write(reinterpret_cast<const char*>(points.data()), std::streamsize(points.size() * 4));
    try {
      make("{path: " + dir.str() + ", use_labels: false}")->read(0);
      ADD_FAILURE() << "read the " << what << " with rings index % 64";
    } catch (const InputError& e) {
      const std::string w = e.what();
      EXPECT_EQ(e.file(), bin) << what;
      EXPECT_NE(w.find("not an organised scan of 64 rings stored column by column: ring "),
                std::string::npos)
          << w;
      EXPECT_NE(w.find("of elevation among its returns; expected at most 2°"), std::string::npos)
          << w;
    }
  }
}

TEST_F(Rellis3dSourceTest, MissingFilesAreNamed) {
  test::TempDir dir;
  std::vector<float> pts(4 * 128, 0.f);
  for (int i = 0; i < 128; ++i) pts[4 * i] = 1.f + i;
  std::ofstream(dir.str() + "/000001.bin", std::ios::binary)
      .write(reinterpret_cast<const char*>(pts.data()), std::streamsize(pts.size() * 4));
  auto src = make("{path: " + dir.str() + ", use_images: true}");
  try {
    src->read(0);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("frame000001"), std::string::npos) << e.what();
  }
  // Image present, calibration missing.
  std::filesystem::copy_file(
      test::dataPath("rellis3d_example_000104/frame000104-1581624663_149.jpg"),
      dir.str() + "/frame000001-1581624663_149.jpg");
  src = make("{path: " + dir.str() + ", use_images: true}");
  try {
    src->read(0);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), dir.str() + "/camera_info.txt");
  }
  // Not whole columns of 64 rings.
  pts.resize(4 * 100);
  std::ofstream(dir.str() + "/000001.bin", std::ios::binary)
      .write(reinterpret_cast<const char*>(pts.data()), std::streamsize(pts.size() * 4));
  EXPECT_THROW(make("{path: " + dir.str() + "}")->read(0), InputError);
  test::TempDir empty;
  EXPECT_THROW(make("{path: " + empty.str() + "}"), std::exception);
}

}  // namespace
}  // namespace terramrf
