// camera_fusion and the image features on real calibrations: KITTI object (P2 with its baseline
// column, R0_rect, Tr_velo_to_cam), RELLIS-3D (Ouster → Basler extrinsic, 1920×1200) and the
// simulator's camera. The projection is checked against an independent computation from the
// calibration file (KITTI) and against the per-pixel ground truth (RELLIS-3D, simulator): a point
// projected to the right pixel mostly carries the same class as that pixel.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "plugins/feature/camera_fusion/fusion_test_frame.hpp"

namespace terramrf {
namespace {

using test::StageRunner;

Frame readFrame(const std::string& type, const std::string& params, std::size_t i = 0) {
  PluginRegistry reg({test::pluginDir()});
  auto p = reg.create(type);
  PluginContext ctx;
  ctx.config_dir = test::sourceDir() + "/configs";
  setParams(*p, params, ctx);
  return static_cast<Source&>(*p).read(i);
}

GridGeometry grid40() { return GridGeometry{}; }  // 40 m, 0.5 m cells (80 × 80)

/// Runs fusion + the three image features (all colour spaces) and checks the layers are filled
/// where there are pixels and in range.
void runAll(Frame& f, StageRunner& r) {
  r.add("camera_fusion");
  r.add("haralick");
  r.add("homogeneity");
  r.add("homogeneity", "{layer: homogeneity_local_mean, definition: local_mean}");
  r.add("colour", "{space: rgb}");
  r.add("colour", "{space: hsv}");
  r.add("colour", "{space: lab}");
  r.run(f);
  ASSERT_EQ(r.grid.cellPixels().size(), f.cameras.size());
  std::size_t pixels = 0;
  for (const CellPixels& cp : r.grid.cellPixels()) pixels += cp.pixels.size();
  int with_pixels = 0, texture = 0;
  for (int c = 0; c < int(r.grid.cells()); ++c) {
    std::size_t n = 0;  // in any camera
    for (const CellPixels& cp : r.grid.cellPixels()) n += cp.count(c);
    if (n == 0) {
      EXPECT_TRUE(std::isnan(r.grid.layer("homogeneity")[c]));
      EXPECT_TRUE(std::isnan(r.grid.layer("colour_r")[c]));
      continue;
    }
    ++with_pixels;
    const float h = r.grid.layer("homogeneity")[c];
    EXPECT_GT(h, 0.f);
    EXPECT_LE(h, 1.f);
    for (const char* l : {"colour_r", "colour_g", "colour_b", "colour_s", "colour_v",
                          "colour_lab_l", "colour_lab_b"})
      EXPECT_FALSE(std::isnan(r.grid.layer(l)[c])) << l << " cell " << c;
    const float a = r.grid.layer("haralick_asm")[c];
    if (std::isnan(a)) continue;  // point-pixel cells may have no pixel pair
    ++texture;
    EXPECT_GT(a, 0.f);
    EXPECT_LE(a, 1.f + 1e-6f);
    EXPECT_GE(r.grid.layer("haralick_variance")[c], 0.f);
    EXPECT_LE(r.grid.layer("haralick_idm")[c], 1.f + 1e-6f);
  }
  EXPECT_GT(with_pixels, 300);
  EXPECT_GT(texture, with_pixels / 2);
  std::printf("  cells with pixels %d, with texture %d, pixels %zu\n", with_pixels, texture,
              pixels);
}

/// Numbers of "KEY: v v v" lines of a KITTI calibration file.
std::map<std::string, std::vector<double>> readCalib(const std::string& path) {
  std::map<std::string, std::vector<double>> out;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::istringstream ss(line.substr(colon + 1));
    double v;
    while (ss >> v) out[line.substr(0, colon)].push_back(v);
  }
  return out;
}

TEST(CameraFusionReal, KittiObjectMatchesTheCalibrationFile) {
  const std::string root = test::dataPath("kitti_object_fusion/training");
  Frame f =
      readFrame("semantickitti",
                "{path: " + root + ", use_images: true, use_labels: false, use_poses: false}");
  ASSERT_EQ(f.cameras.size(), 1u);
  StageRunner r(grid40());
  runAll(f, r);
  const CellPixels& cp = r.grid.cellPixels()[0];
  ASSERT_EQ(cp.width, 1224);
  ASSERT_EQ(cp.height, 370);

  // image point = P2 · R0_rect · Tr_velo_to_cam · X, straight from calib/000000.txt.
  auto c = readCalib(test::dataPath("kitti_object_fusion/training/calib/000000.txt"));
  ASSERT_EQ(c["P2"].size(), 12u);
  ASSERT_EQ(c["R0_rect"].size(), 9u);
  ASSERT_EQ(c["Tr_velo_to_cam"].size(), 12u);
  Eigen::Matrix<double, 3, 4> P2, Tr;
  Eigen::Matrix3d R0;
  for (int i = 0; i < 12; ++i)
    P2(i / 4, i % 4) = c["P2"][i], Tr(i / 4, i % 4) = c["Tr_velo_to_cam"][i];
  for (int i = 0; i < 9; ++i) R0(i / 3, i % 3) = c["R0_rect"][i];
  std::size_t visible = 0, mismatch = 0;
  for (std::size_t i = 0; i < f.points.size(); ++i) {
    const Eigen::Vector3d x =
        R0 * (Tr * Eigen::Vector4d(f.points.x[i], f.points.y[i], f.points.z[i], 1));
    int expect = -1;
    if (x.z() > 1e-6) {
      const Eigen::Vector3d q = P2 * x.homogeneous();
      const double u = q.x() / q.z(), v = q.y() / q.z();
      // Pixel centres at integer coordinates: pixel k covers [k − 0.5, k + 0.5).
      if (u >= -0.5 && v >= -0.5 && u < 1224 - 0.5 && v < 370 - 0.5)
        expect = int(std::lround(v)) * 1224 + int(std::lround(u));
    }
    visible += expect >= 0;
    if (cp.pixel_of_point[i] != expect) {
      ++mismatch;  // only a rounding tie may differ, and then by one pixel
      ASSERT_TRUE(expect >= 0 && cp.pixel_of_point[i] >= 0) << "point " << i;
      EXPECT_LE(std::abs(cp.pixel_of_point[i] % 1224 - expect % 1224), 1);
      EXPECT_LE(std::abs(cp.pixel_of_point[i] / 1224 - expect / 1224), 1);
    }
  }
  EXPECT_LE(mismatch, 3u);
  // The front camera sees roughly a fifth of the HDL-64E sweep.
  EXPECT_GT(visible, 15000u);
  EXPECT_LT(visible, 40000u);
  EXPECT_EQ(r.ctx.metrics.at("camera_fusion.image_2.visible_points"), double(visible));
  std::printf("  KITTI 000000: %zu of %zu points visible\n", visible, f.points.size());
}

/// Mean of `layer` over cells whose points are mostly of class `cls` (≥ 80 %).
double classMean(const Frame& f, const TerrainGrid& g, const std::string& layer, LabelId cls) {
  double s = 0;
  int n = 0;
  for (int c = 0; c < int(g.cells()); ++c) {
    const float v = g.layer(layer)[c];
    if (std::isnan(v) || g.count(c) < 5) continue;
    int k = 0;
    for (const uint32_t* it = g.pointsBegin(c); it != g.pointsEnd(c); ++it)
      k += f.truth.label[*it] == cls;
    if (k < 0.8 * g.count(c)) continue;
    s += v, ++n;
  }
  return n ? s / n : std::nan("");
}

/// Share of visible, labelled points whose pixel carries the same class in the image truth.
double pointPixelAgreement(const Frame& f, const CellPixels& cp) {
  const Image& truth = *f.cameras[cp.camera].truth;
  std::size_t n = 0, same = 0;
  for (std::size_t i = 0; i < f.points.size(); ++i) {
    const int32_t px = cp.pixel_of_point[i];
    if (px < 0 || f.truth.label[i] == labels::kUnknown) continue;
    const LabelId t = truth.data[std::size_t(px)];
    if (t == labels::kUnknown) continue;
    ++n;
    same += t == f.truth.label[i];
  }
  EXPECT_GT(n, 1000u);
  return n ? double(same) / n : 0;
}

TEST(CameraFusionReal, Rellis3dPointsLandOnPixelsOfTheirClass) {
  Frame f = readFrame("rellis3d", "{path: " + test::dataPath("rellis3d_example_000104") +
                                      ", use_images: true, use_labels: true, "
                                      "use_image_labels: true}");
  ASSERT_EQ(f.cameras.size(), 1u);
  ASSERT_TRUE(f.cameras[0].truth);
  StageRunner r(grid40());
  runAll(f, r);
  const double agree = pointPixelAgreement(f, r.grid.cellPixels()[0]);
  std::printf("  RELLIS-3D 000104: point/pixel class agreement %.3f\n", agree);
  EXPECT_GT(agree, 0.85);  // measured 0.935
}

TEST(CameraFusionReal, SimulatorPointsLandOnPixelsOfTheirClass) {
  Frame f = readFrame("simulator", "{frames: 1, enable_camera: true}");
  ASSERT_EQ(f.cameras.size(), 1u);
  ASSERT_TRUE(f.cameras[0].truth);
  StageRunner r(grid40());
  runAll(f, r);
  const double agree = pointPixelAgreement(f, r.grid.cellPixels()[0]);
  std::printf("  simulator frame 0: point/pixel class agreement %.3f\n", agree);
  // The simulator's asphalt is smooth and grey, its grass textured and green: the image
  // features must see that (measured road/rough: local-mean homogeneity 0.38/0.19, ASM
  // 0.77/0.21, IDM 0.94/0.66, saturation 0.05/0.51). Cheng & Sun's homogeneity (the default)
  // does not: gradient × spread is large only at edges (lane markings, the road's border), not
  // on the grass's fine low-contrast noise (road/rough 0.993/0.996, both near 1).
  auto mean = [&](const char* l, LabelId c) { return classMean(f, r.grid, l, c); };
  EXPECT_GT(mean("homogeneity_local_mean", labels::kRoad),
            1.5 * mean("homogeneity_local_mean", labels::kRough));
  EXPECT_GT(mean("homogeneity", labels::kRough), 0.98);
  EXPECT_LT(mean("homogeneity", labels::kRoad), mean("homogeneity", labels::kRough));
  EXPECT_GT(mean("haralick_asm", labels::kRoad), 2.0 * mean("haralick_asm", labels::kRough));
  EXPECT_GT(mean("haralick_idm", labels::kRoad), mean("haralick_idm", labels::kRough) + 0.1);
  EXPECT_GT(mean("colour_s", labels::kRough), 3.0 * mean("colour_s", labels::kRoad));
}

// Two cameras of one frame (the simulator's front and rear): each gets its own pixel sets, a
// point lands on a pixel of its class in both, and the image features (camera: −1, per cell the
// camera that sees it with most pixels) now also cover the cells behind the vehicle, which the
// front camera alone leaves NaN.
TEST(CameraFusionReal, FrontAndRearCamerasCoverBothHalvesOfTheGrid) {
  Frame f = readFrame("simulator", "{frames: 1, camera_yaws_deg: [0, 180]}");
  ASSERT_EQ(f.cameras.size(), 2u);
  Frame front = f;
  front.cameras.pop_back();
  StageRunner r(grid40()), r1(grid40());
  runAll(f, r);
  runAll(front, r1);
  ASSERT_EQ(r.grid.cellPixels().size(), 2u);
  for (int c = 0; c < 2; ++c) {
    const double agree = pointPixelAgreement(f, r.grid.cellPixels()[c]);
    std::printf("  simulator frame 0, camera %s: point/pixel class agreement %.3f\n",
                f.cameras[c].model.name.c_str(), agree);
    EXPECT_GT(agree, 0.9);
  }
  const GridGeometry& g = r.grid.geometry();
  int behind_two = 0, behind_one = 0, ahead_two = 0, ahead_one = 0;
  for (int row = 0; row < g.rows(); ++row) {
    const double x = g.cellCentre(row, 0).x();  // LiDAR frame: x forward
    if (std::abs(x) < 2) continue;
    for (int col = 0; col < g.cols(); ++col) {
      const int c = row * g.cols() + col;
      const int two = !std::isnan(r.grid.layer("colour_r")[c]);
      const int one = !std::isnan(r1.grid.layer("colour_r")[c]);
      (x < 0 ? behind_two : ahead_two) += two;
      (x < 0 ? behind_one : ahead_one) += one;
    }
  }
  std::printf("  cells with colour behind / ahead: front camera %d / %d, both %d / %d\n",
              behind_one, ahead_one, behind_two, ahead_two);
  EXPECT_EQ(behind_one, 0);
  EXPECT_GT(behind_two, 300);
  EXPECT_EQ(ahead_two, ahead_one);  // the rear camera adds nothing ahead of the vehicle
}

/// camera_fusion's InputError on `f`, "" if none.
std::string fusionError(Frame& f) {
  StageRunner r(grid40());
  r.add("camera_fusion");
  try {
    r.run(f);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// A calibration that fits the image (principal point central) but puts the camera 1 km ahead of
// the LiDAR: no point is in front of it. The error must name the dataset's calibration file and
// entries, not only the image.
TEST(CameraFusionReal, CalibrationProjectingNothingIsNamedInTheDatasetsTerms) {
  const std::string real = test::dataPath("kitti_object_fusion/training");
  test::TempDir dir;
  const std::string root = dir.str() + "/training";
  for (const char* sub : {"velodyne", "image_2", "calib"})
    std::filesystem::create_directories(root + "/" + sub);
  std::filesystem::create_symlink(real + "/velodyne/000001.bin", root + "/velodyne/000001.bin");
  std::filesystem::create_symlink(real + "/image_2/000001.png", root + "/image_2/000001.png");
  {
    std::ifstream in(real + "/calib/000001.txt");
    std::ofstream out(root + "/calib/000001.txt");
    std::string line;
    while (std::getline(in, line)) {
      if (line.rfind("Tr_velo_to_cam:", 0) == 0)
        line = "Tr_velo_to_cam: 0 -1 0 0 0 0 -1 0 1 0 0 -1000";
      out << line << "\n";
    }
  }
  Frame k = readFrame("semantickitti", "{path: " + root + ", use_images: true, use_labels: false}");
  std::string what = fusionError(k);
  EXPECT_NE(what.find(root + "/image_2/000001.png"), std::string::npos) << what;
  EXPECT_NE(what.find("projects none"), std::string::npos) << what;
  EXPECT_NE(what.find(root + "/calib/000001.txt (P2, R0_rect, Tr_velo_to_cam)"), std::string::npos)
      << what;

  // RELLIS-3D: transforms.yaml with the camera 1 km ahead (it looks along the Ouster's −x).
  const std::string rel = test::dataPath("rellis3d_example_000104");
  test::TempDir rdir;
  for (const char* f : {"000104.bin", "camera_info.txt", "frame000104-1581624663_149.jpg"})
    std::filesystem::create_symlink(rel + "/" + f, rdir.str() + "/" + f);
  std::ofstream(rdir.str() + "/transforms.yaml")
      << "os1_cloud_node-pylon_camera_node:\n  q: {w: -0.50507811, x: 0.51206185, y: 0.49024953, "
         "z: -0.49228464}\n  t: {x: -1000, y: 0, z: 0}\n";
  Frame r =
      readFrame("rellis3d", "{path: " + rdir.str() + ", use_images: true, use_labels: false}");
  what = fusionError(r);
  EXPECT_NE(what.find("projects none"), std::string::npos) << what;
  EXPECT_NE(what.find(rdir.str() + "/camera_info.txt"), std::string::npos) << what;
  EXPECT_NE(what.find(rdir.str() + "/transforms.yaml"), std::string::npos) << what;
}

}  // namespace
}  // namespace terramrf
