// The "grid_csv" output end to end: header, known rows, NaN as empty field, layer selection,
// atomic writes.
#include <gtest/gtest.h>

#include <filesystem>
#include <sstream>
#include <vector>

#include "output_test_support.hpp"
#include "terramrf/atomic_file.hpp"

namespace terramrf {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

class GridCsvTest : public ::testing::Test {
 protected:
  GridCsvTest() : grid(test::outputTestGeometry()) {
    frame.id = "000007";
    grid.labels()[grid.index(3, 0)] = labels::kObstacle;
    grid.labels()[grid.index(0, 3)] = labels::kRoad;
    Layer& h = grid.add("height");
    h[grid.index(3, 0)] = 0.25f;
    h[grid.index(0, 3)] = -1.5f;
    grid.add("slope", 0.1f);
    // Two points in cell (3,0) (x in [1,2), y in [-2,-1)), one outside the grid.
    frame.points.push_back(1.5f, -1.5f, 0.f, 0.f);
    frame.points.push_back(1.2f, -1.9f, 0.f, 0.f);
    frame.points.push_back(9.f, 9.f, 0.f, 0.f);
    grid.binPoints(frame.points);
  }
  PluginContext pctx() const {
    PluginContext c;
    c.output_dir = dir.str();
    c.grid = test::outputTestGeometry();
    c.labels = &labels;
    return c;
  }
  std::unique_ptr<Output> make(const std::string& params) {
    auto out = test::makeOutput("grid_csv", params, pctx());
    RunInfo r;
    r.output_dir = dir.str();
    r.labels = &labels;
    r.grid = test::outputTestGeometry();
    if (out) out->begin(r);
    return out;
  }
  FrameContext ctx() {
    FrameContext c;
    c.frame = &frame;
    c.grid = &grid;
    c.labels = &labels;
    return c;
  }
  test::TempDir dir;
  LabelSet labels = LabelSet::defaults();
  Frame frame;
  TerrainGrid grid;
};

TEST_F(GridCsvTest, KnownRowsWithSelectedLayer) {
  auto out = make("{layers: [height]}");
  ASSERT_TRUE(out);
  out->write(ctx());
  const auto l = lines(readFile(dir.str() + "/grid_csv/000007.csv"));
  ASSERT_EQ(l.size(), 17u);
  EXPECT_EQ(l[0], "row,col,x_m,y_m,label,label_name,points,height");
  EXPECT_EQ(l[1], "0,0,-1.5,-1.5,0,unknown,0,");           // NaN = empty field
  EXPECT_EQ(l[1 + 3], "0,3,-1.5,1.5,1,road,0,-1.5");       // back-left
  EXPECT_EQ(l[1 + 12], "3,0,1.5,-1.5,3,obstacle,2,0.25");  // forward-right, 2 points
  EXPECT_EQ(l[16], "3,3,1.5,1.5,0,unknown,0,");
}

// Cell centres of a non-binary cell size read as written: −0.45, −0.15, 0.15, 0.45 for 0.3 m
// cells, not −0.15000000000000036.
TEST(GridCsvFormat, CellCentresCarryNoFloatNoise) {
  GridGeometry g;
  g.size_m = 1.2;
  g.cell_m = 0.3;
  test::TempDir dir;
  LabelSet labels = LabelSet::defaults();
  PluginContext pc;
  pc.output_dir = dir.str();
  pc.grid = g;
  pc.labels = &labels;
  auto out = test::makeOutput("grid_csv", "{}", pc);
  ASSERT_TRUE(out);
  RunInfo info;
  info.output_dir = dir.str();
  info.labels = &labels;
  info.grid = g;
  out->begin(info);
  Frame frame;
  frame.id = "000001";
  TerrainGrid grid(g);
  grid.binPoints(frame.points);
  FrameContext c;
  c.frame = &frame;
  c.grid = &grid;
  c.labels = &labels;
  out->write(c);
  const auto l = lines(readFile(dir.str() + "/grid_csv/000001.csv"));
  ASSERT_EQ(l.size(), 17u);
  std::vector<std::string> xs;
  for (int r = 0; r < 4; ++r) {
    const std::string& row = l[1 + r * 4];
    const std::size_t a = row.find(',', row.find(',') + 1) + 1;
    xs.push_back(row.substr(a, row.find(',', a) - a));
  }
  EXPECT_EQ(xs, (std::vector<std::string>{"-0.45", "-0.15", "0.15", "0.45"}));
}

TEST_F(GridCsvTest, AllLayersByDefaultInNameOrder) {
  make("{subdir: tables}")->write(ctx());
  const auto l = lines(readFile(dir.str() + "/tables/000007.csv"));
  ASSERT_EQ(l.size(), 17u);
  EXPECT_EQ(l[0], "row,col,x_m,y_m,label,label_name,points,height,slope");
  EXPECT_EQ(l[1 + 12], "3,0,1.5,-1.5,3,obstacle,2,0.25,0.1");
}

TEST_F(GridCsvTest, MissingLayerAndBadParams) {
  auto out = make("{layers: [roughness]}");
  try {
    out->write(ctx());
    FAIL() << "missing layer accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'roughness'"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir.str() + "/grid_csv/000007.csv"));
  EXPECT_THROW(test::makeOutput("grid_csv", "{layers: [a, a]}", pctx()), std::exception);
  EXPECT_THROW(test::makeOutput("grid_csv", "{subdir: /abs}", pctx()), std::exception);
}

// An empty subdir would write the tables straight into the run's output folder, beside the other
// outputs' files: refused, naming the parameter and what it expects.
TEST_F(GridCsvTest, EmptySubdirIsRefusedNamingTheParameter) {
  try {
    test::makeOutput("grid_csv", "{subdir: ''}", pctx());
    FAIL() << "accepted an empty subdir";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "parameter 'subdir': is empty; expected a folder name such as 'grid_csv'"),
              std::string::npos)
        << e.what();
  }
}

// Cell (3,0) holds one road and one obstacle point: obstacle by the one-point rule although the
// cell is labelled obstacle either way; the point outside the grid counts nowhere.
TEST_F(GridCsvTest, TruthColumnsFollowTheEvaluationRule) {
  frame.truth.label = {labels::kRoad, labels::kObstacle, labels::kRough};
  make("{layers: [height], truth: true}")->write(ctx());
  const auto l = lines(readFile(dir.str() + "/grid_csv/000007.csv"));
  ASSERT_EQ(l.size(), 17u);
  EXPECT_EQ(l[0], "row,col,x_m,y_m,label,label_name,points,truth,truth_name,truth_points,height");
  EXPECT_EQ(l[1 + 12], "3,0,1.5,-1.5,3,obstacle,2,3,obstacle,2,0.25");
  EXPECT_EQ(l[1 + 3], "0,3,-1.5,1.5,1,road,0,,,,-1.5");  // no points: no truth

  frame.truth.label = {labels::kRoad, labels::kRoad, labels::kUnknown};
  make("{layers: [], truth: true}")->write(ctx());
  EXPECT_NE(readFile(dir.str() + "/grid_csv/000007.csv").find("\n3,0,1.5,-1.5,3,obstacle,2,1,road,2,"),
            std::string::npos);

  frame.truth.label.clear();  // a frame without labels: the columns stay, empty
  make("{layers: [height], truth: true}")->write(ctx());
  EXPECT_EQ(lines(readFile(dir.str() + "/grid_csv/000007.csv"))[1 + 12],
            "3,0,1.5,-1.5,3,obstacle,2,,,,0.25");

  frame.truth.label = {labels::kRoad, 99, labels::kRough};  // not a class id: named, nothing written
  fs::remove(dir.str() + "/grid_csv/000007.csv");
  try {
    make("{truth: true}")->write(ctx());
    FAIL() << "bad truth id accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("label 99"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir.str() + "/grid_csv/000007.csv"));
}

TEST_F(GridCsvTest, UnwritableFolderThrowsNamingThePath) {
  writeFileAtomic(dir.str() + "/grid_csv", "not a folder");
  try {
    make("{}")->write(ctx());
    FAIL() << "writing into a non-folder succeeded";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(dir.str() + "/grid_csv"), std::string::npos) << e.what();
  }
}

TEST_F(GridCsvTest, FailedWriteLeavesTheGoodFileIntact) {
  auto out = make("{}");
  out->write(ctx());
  const std::string path = dir.str() + "/grid_csv/000007.csv";
  const std::string good = readFile(path);
  grid.labels()[grid.index(1, 1)] = labels::kRough;
  {
    test::FileSizeLimit limit(100);  // far less than the ~600-byte table
    ASSERT_TRUE(limit.ok());
    try {
      out->write(ctx());
      ADD_FAILURE() << "write beyond the file size limit succeeded";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(readFile(path), good);
  out->write(ctx());
  EXPECT_NE(readFile(path).find("1,1,-0.5,-0.5,2,rough,0"), std::string::npos);
}

}  // namespace
}  // namespace terramrf
