// fusion_overlay: the debug PNG shows points in their cell's class colour and tints the cells'
// pixels; written atomically under <output_dir>/<subdir>/<frame_id>_<camera>.png.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <set>

#include "output_test_support.hpp"
#include "plugins/feature/camera_fusion/fusion_test_frame.hpp"
#include "terramrf/adapters/opencv_image.hpp"
#include "terramrf/atomic_file.hpp"

namespace terramrf {
namespace {

namespace fs = std::filesystem;
using test::forwardCamera;
using test::groundFrame;
using test::StageRunner;

void dark(int, int, uint8_t* p) { p[0] = p[1] = p[2] = 40; }

struct Fixture {
  Frame frame = groundFrame(forwardCamera(), dark);
  StageRunner runner;
  test::TempDir dir;
  PluginContext pctx;
  int cell = 0;

  Fixture() {
    runner.add("camera_fusion");
    runner.run(frame);
    // Every cell with points is road; cell (3, 4) is an obstacle.
    for (std::size_t c = 0; c < runner.grid.cells(); ++c)
      if (runner.grid.count(int(c)) > 0) runner.grid.labels()[c] = labels::kRoad;
    cell = runner.grid.index(3, 4);
    runner.grid.labels()[cell] = labels::kObstacle;
    pctx.output_dir = dir.str();
    pctx.labels = &runner.labels;
  }
  std::unique_ptr<Output> output(const std::string& params) {
    return test::makeOutput("fusion_overlay", params, pctx);
  }
  std::string png() const { return (dir.path() / "fusion" / "000007_front.png").string(); }
};

TEST(FusionOverlay, DrawsPointsAndCellsInClassColours) {
  Fixture fx;
  auto out = fx.output("{point_radius_px: 0, cell_alpha: 0.5}");
  out->write(fx.runner.ctx);
  const Image img = readImage(fx.png());
  ASSERT_EQ(img.width, 200);
  ASSERT_EQ(img.height, 100);
  ASSERT_EQ(img.channels, 3);
  const CellPixels& cp = fx.runner.grid.cellPixels()[0];
  // A point of the obstacle cell: (5.125, 0.125, −1) → (97.56, 69.51) → pixel (98, 70).
  std::size_t point = 0;
  for (; point < fx.frame.points.size(); ++point)
    if (fx.frame.points.x[point] == 5.125f && fx.frame.points.y[point] == 0.125f) break;
  ASSERT_EQ(cp.pixel_of_point.at(point), 70 * 200 + 98);
  const uint8_t* p = img.at(98, 70);
  EXPECT_EQ(p[0], 220);
  EXPECT_EQ(p[1], 30);
  EXPECT_EQ(p[2], 30);
  // A footprint pixel of the obstacle cell that no point hits: half dark, half red.
  std::set<int32_t> point_px(cp.pixel_of_point.begin(), cp.pixel_of_point.end());
  int tinted = 0;
  for (const uint32_t* it = cp.begin(fx.cell); it != cp.end(fx.cell); ++it) {
    if (point_px.count(int32_t(*it))) continue;
    const uint8_t* q = &img.data[std::size_t(*it) * 3];
    EXPECT_EQ(q[0], 130);  // round(0.5 · 40 + 0.5 · 220)
    EXPECT_EQ(q[1], 35);
    EXPECT_EQ(q[2], 35);
    ++tinted;
  }
  EXPECT_GT(tinted, 30);
  // Above the horizon nothing is drawn.
  EXPECT_EQ(img.at(10, 10)[0], 40);
  EXPECT_EQ(img.at(190, 20)[2], 40);
}

// Unknown cells are drawn (draw_unknown) in the label set's unknown colour, never in a class's:
// they were grey, road's colour.
TEST(FusionOverlay, UnknownIsDrawnInTheUnknownColour) {
  Fixture fx;
  fx.runner.grid.labels()[fx.cell] = labels::kUnknown;
  auto out = fx.output("{point_radius_px: 0, cell_alpha: 0, draw_unknown: true}");
  out->write(fx.runner.ctx);
  const Image img = readImage(fx.png());
  const uint8_t* p = img.at(98, 70);  // a point of the cell (first test)
  const auto want = fx.runner.labels[labels::kUnknown].rgb;
  EXPECT_EQ(p[0], want[0]);
  EXPECT_EQ(p[1], want[1]);
  EXPECT_EQ(p[2], want[2]);
  EXPECT_NE(want, fx.runner.labels[labels::kRoad].rgb);
}

TEST(FusionOverlay, WritesAtomically) {
  Fixture fx;
  auto out = fx.output("{}");
  out->write(fx.runner.ctx);
  const std::string good = readFile(fx.png());
  fx.runner.grid.labels()[fx.cell] = labels::kRough;  // a different image next time
  {
    test::FileSizeLimit limit(64);
    ASSERT_TRUE(limit.ok());
    try {
      out->write(fx.runner.ctx);
      ADD_FAILURE() << "write beyond the file size limit succeeded";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(fx.png()), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(readFile(fx.png()), good);
  std::size_t files = 0;
  for (const auto& f : fs::directory_iterator(fx.dir.path() / "fusion"))
    files += f.is_regular_file();
  EXPECT_EQ(files, 1u);
  out->write(fx.runner.ctx);
  EXPECT_NE(readFile(fx.png()), good);
}

TEST(FusionOverlay, NeedsFusedPixels) {
  Fixture fx;
  fx.runner.grid.cellPixels().clear();
  auto out = fx.output("{}");
  EXPECT_THROW(out->write(fx.runner.ctx), std::runtime_error);
  Fixture other;
  auto left = other.output("{cameras: [left]}");
  EXPECT_THROW(left->write(other.runner.ctx), std::runtime_error);
  EXPECT_FALSE(fs::exists(other.png()));
}

// An empty subdir would put the overlays loose in the run's output folder.
TEST(FusionOverlay, RejectsEmptySubdirNamingTheParameter) {
  Fixture fx;
  try {
    fx.output("{subdir: ''}");
    FAIL() << "accepted an empty subdir";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "parameter 'subdir': is empty; expected a folder name such as 'fusion'"),
              std::string::npos)
        << e.what();
  }
}

TEST(FusionOverlay, RejectsAbsoluteSubdir) {
  Fixture fx;
  EXPECT_THROW(fx.output("{subdir: /tmp/x}"), std::runtime_error);
  EXPECT_THROW(fx.output("{cell_alpha: 2}"), std::runtime_error);
}

}  // namespace
}  // namespace terramrf
