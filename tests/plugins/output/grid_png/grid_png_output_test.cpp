// The "grid_png" output end to end: pixel colours at known places, orientation, sensor cross,
// camera images, and atomic writes.
#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "grid_render.hpp"
#include "output_test_support.hpp"
#include "terramrf/atomic_file.hpp"

namespace terramrf {
namespace {

namespace fs = std::filesystem;

class GridPngTest : public ::testing::Test {
 protected:
  GridPngTest() : grid(test::outputTestGeometry()) {
    frame.id = "000042";
    grid.labels()[grid.index(3, 0)] = labels::kObstacle;
    grid.labels()[grid.index(0, 3)] = labels::kRoad;
    grid.labels()[grid.index(0, 0)] = labels::kRough;
  }
  PluginContext pctx() const {
    PluginContext c;
    c.output_dir = dir.str();
    c.grid = test::outputTestGeometry();
    c.labels = &labels;
    return c;
  }
  RunInfo info() const {
    RunInfo r;
    r.output_dir = dir.str();
    r.labels = &labels;
    r.grid = test::outputTestGeometry();
    return r;
  }
  FrameContext ctx() {
    FrameContext c;
    c.frame = &frame;
    c.grid = &grid;
    c.labels = &labels;
    return c;
  }
  std::unique_ptr<Output> make(const std::string& params) {
    auto out = test::makeOutput("grid_png", params, pctx());
    if (out) out->begin(info());
    return out;
  }
  /// RGB at pixel (u, v) of a PNG read back with OpenCV (which stores BGR).
  static std::array<int, 3> rgbAt(const cv::Mat& m, int u, int v) {
    const cv::Vec3b p = m.at<cv::Vec3b>(v, u);
    return {p[2], p[1], p[0]};
  }

  test::TempDir dir;
  LabelSet labels = LabelSet::defaults();
  Frame frame;
  TerrainGrid grid;
};

using Rgb = std::array<int, 3>;

TEST_F(GridPngTest, CellsAreDrawnForwardUpLeftLeftWithLabelColours) {
  auto out = make("{pixels_per_cell: 8}");
  ASSERT_TRUE(out);
  out->write(ctx());
  const std::string path = dir.str() + "/grid/000042.png";
  ASSERT_TRUE(fs::exists(path));
  const cv::Mat m = cv::imread(path, cv::IMREAD_COLOR);
  ASSERT_EQ(m.cols, 32);
  ASSERT_EQ(m.rows, 32);
  // Cell (row r, col c) covers image rows (3-r)*8.., columns (3-c)*8..
  EXPECT_EQ(rgbAt(m, 28, 4), (Rgb{220, 30, 30}));    // (3,0) obstacle: forward-right = top-right
  EXPECT_EQ(rgbAt(m, 4, 28), (Rgb{128, 128, 128}));  // (0,3) road: back-left = bottom-left
  EXPECT_EQ(rgbAt(m, 28, 28), (Rgb{139, 90, 43}));   // (0,0) rough: back-right = bottom-right
  EXPECT_EQ(rgbAt(m, 4, 4), (Rgb{0, 0, 0}));         // (3,3) unknown: forward-left = top-left
  // Whole block has one colour.
  EXPECT_EQ(rgbAt(m, 24, 0), (Rgb{220, 30, 30}));
  EXPECT_EQ(rgbAt(m, 31, 7), (Rgb{220, 30, 30}));
  EXPECT_EQ(rgbAt(m, 23, 0), (Rgb{0, 0, 0}));
  // Sensor cross at the image centre (the sensor sits on the corner of four cells), arms 8 px.
  EXPECT_EQ(rgbAt(m, 16, 16), (Rgb{255, 255, 255}));
  EXPECT_EQ(rgbAt(m, 24, 16), (Rgb{255, 255, 255}));
  EXPECT_EQ(rgbAt(m, 8, 16), (Rgb{255, 255, 255}));
  EXPECT_EQ(rgbAt(m, 16, 9), (Rgb{255, 255, 255}));
  EXPECT_EQ(rgbAt(m, 20, 20), (Rgb{0, 0, 0}));  // off the cross
  EXPECT_EQ(rgbAt(m, 26, 16), (Rgb{0, 0, 0}));  // past the arm
}

TEST_F(GridPngTest, PixelsPerCellScalesTheImage) {
  auto out = make("{pixels_per_cell: 3, subdir: png}");
  out->write(ctx());
  const cv::Mat m = cv::imread(dir.str() + "/png/000042.png", cv::IMREAD_COLOR);
  ASSERT_EQ(m.cols, 12);
  EXPECT_EQ(rgbAt(m, 10, 1), (Rgb{220, 30, 30}));
  EXPECT_THROW(test::makeOutput("grid_png", "{pixels_per_cell: 0}", pctx()), std::exception);
  EXPECT_THROW(test::makeOutput("grid_png", "{subdir: ''}", pctx()), std::exception);
}

// pixels_per_cell allowed 1–64 whatever the grid: a 2000-cell grid at 64 px per cell asked for a
// 128000² px image (45.8 GiB) and every frame failed with a bare std::bad_alloc. Refused at the
// config, where the grid's size is known, naming the parameter, the grid and the image.
TEST_F(GridPngTest, ImageTooLargeForTheGridIsRefusedAtTheConfig) {
  PluginContext c = pctx();
  c.grid.size_m = 100;
  c.grid.cell_m = 0.05;  // 2000 x 2000 cells
  try {
    test::makeOutput("grid_png", "{pixels_per_cell: 64}", c);
    FAIL() << "accepted a 128000 px image";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "parameter 'pixels_per_cell': pixels_per_cell 64 on the grid's 2000 x 2000 "
                  "cells makes a 128000 x 128000 px image (45.8 GiB RGB per frame); expected at "
                  "most 16384 px per side: pixels_per_cell <= 8 for this grid"),
              std::string::npos)
        << e.what();
  }
  EXPECT_NO_THROW(test::makeOutput("grid_png", "{pixels_per_cell: 8}", c));  // 16000 px
  // A grid with more cells per side than any image may have: no pixels_per_cell helps.
  EXPECT_NE(gridImageSizeProblem(20000, 20000, 1).find("write it with grid_csv"),
            std::string::npos);
  // The limit itself, and renderGrid refusing (not allocating) for callers of the C++ API.
  EXPECT_EQ(gridImageSizeProblem(4, 4, 4096), "");
  EXPECT_NE(gridImageSizeProblem(4, 4, 4097), "");
  EXPECT_NE(gridImageSizeProblem(2000, 2000, 1 << 30), "");  // no int overflow into "fits"
  try {
    renderGrid(grid, labels, 1 << 30);
    FAIL() << "drew a 2^32 px image";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("renderGrid: pixels_per_cell 1073741824 on the grid's 4 x "
                                         "4 cells makes a 4294967296 x 4294967296 px image"),
              std::string::npos)
        << e.what();
  }
}

// An absolute subdir would write outside the run's output folder: refused, naming it.
TEST_F(GridPngTest, AbsoluteSubdirIsRefusedNamingIt) {
  test::TempDir elsewhere;
  try {
    test::makeOutput("grid_png", "{subdir: " + elsewhere.str() + "}", pctx());
    FAIL() << "accepted an absolute subdir";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("parameter 'subdir': '" + elsewhere.str() +
                                         "' is absolute; expected a folder relative to the "
                                         "run's output folder"),
              std::string::npos)
        << e.what();
  }
}

TEST_F(GridPngTest, CameraImagesAreWrittenBesideTheGrid) {
  auto img = std::make_shared<Image>(5, 3, 3);
  img->at(4, 2)[0] = 200;
  img->at(4, 2)[1] = 100;
  img->at(4, 2)[2] = 50;
  CameraImage cam;
  cam.model.name = "image_2";
  cam.image = img;
  frame.cameras.push_back(cam);
  CameraImage calib_only;
  calib_only.model.name = "image_3";
  frame.cameras.push_back(calib_only);

  make("{}")->write(ctx());
  const std::string path = dir.str() + "/grid/000042_image_2.png";
  ASSERT_TRUE(fs::exists(path));
  const cv::Mat m = cv::imread(path, cv::IMREAD_COLOR);
  ASSERT_EQ(m.cols, 5);
  ASSERT_EQ(m.rows, 3);
  EXPECT_EQ(rgbAt(m, 4, 2), (Rgb{200, 100, 50}));
  EXPECT_FALSE(fs::exists(dir.str() + "/grid/000042_image_3.png"));

  test::TempDir other;
  PluginContext c = pctx();
  c.output_dir = other.str();
  auto no_cams = test::makeOutput("grid_png", "{write_camera_images: false}", c);
  no_cams->write(ctx());
  EXPECT_TRUE(fs::exists(other.str() + "/grid/000042.png"));
  EXPECT_FALSE(fs::exists(other.str() + "/grid/000042_image_2.png"));
}

// What a failed frame may have left: its grid image and one image per camera it knows of (the
// source's, those of frames written, the failed frame's own), named exactly, so frame "a"
// never claims frame "a_b"'s files.
TEST_F(GridPngTest, FrameFilesAreExactlyTheFramesGridAndCameraImages) {
  auto out = test::makeOutput("grid_png", "{}", pctx());
  RunInfo ri = info();
  ri.cameras = {"image_2"};
  out->begin(ri);
  const std::string grid = dir.str() + "/grid/";
  using Files = std::vector<std::string>;
  EXPECT_EQ(out->frameFiles("a", nullptr), (Files{grid + "a.png", grid + "a_image_2.png"}));

  CameraImage cam;
  cam.model.name = "left cam";  // made safe as a file name
  cam.image = std::make_shared<Image>(2, 2, 3);
  frame.cameras.push_back(cam);
  frame.cameras.push_back(CameraImage{});  // no name: camera1
  frame.cameras.back().image = std::make_shared<Image>(2, 2, 3);
  out->write(ctx());
  EXPECT_EQ(out->frameFiles("a", nullptr),
            (Files{grid + "a.png", grid + "a_image_2.png", grid + "a_left_cam.png",
                   grid + "a_camera1.png"}));
  Frame failed;
  failed.cameras.resize(1);
  failed.cameras[0].model.name = "image_3";
  EXPECT_EQ(out->frameFiles("a/b", &failed).back(), grid + "a_b_image_3.png");

  auto no_cams = test::makeOutput("grid_png", "{write_camera_images: false}", pctx());
  no_cams->begin(ri);
  EXPECT_EQ(no_cams->frameFiles("a", &failed), (Files{grid + "a.png"}));
}

TEST_F(GridPngTest, UnwritableFolderThrowsNamingThePath) {
  // A file where the output folder should be: fails for root too, unlike chmod.
  writeFileAtomic(dir.str() + "/grid", "not a folder");
  auto out = make("{}");
  try {
    out->write(ctx());
    FAIL() << "writing into a non-folder succeeded";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(dir.str() + "/grid"), std::string::npos) << e.what();
  }
}

TEST_F(GridPngTest, FailedWriteLeavesTheGoodFileIntact) {
  auto out = make("{pixels_per_cell: 16}");
  out->write(ctx());
  const std::string path = dir.str() + "/grid/000042.png";
  const std::string good = readFile(path);
  ASSERT_GT(good.size(), 64u);
  grid.labels()[grid.index(1, 1)] = labels::kObstacle;  // a different picture
  {
    test::FileSizeLimit limit(32);  // the new PNG cannot be written in full
    ASSERT_TRUE(limit.ok());
    try {
      out->write(ctx());
      ADD_FAILURE() << "write beyond the file size limit succeeded";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(readFile(path), good);
  // No temporary files are left behind.
  std::size_t files = 0;
  for (const auto& f : fs::directory_iterator(dir.path() / "grid")) files += f.is_regular_file();
  EXPECT_EQ(files, 1u);
  out->write(ctx());  // and the next write works again
  EXPECT_NE(readFile(path), good);
}

}  // namespace
}  // namespace terramrf
