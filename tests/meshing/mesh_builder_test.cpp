// The whole paper 004 pipeline on a simulated drive: complete scene recovery (§3.3: building
// heights beyond the LiDAR's reach) and building/tree masking (§3.4) against the simulator's
// ground truth; frames without images and cameras looking away.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "sim_scene.hpp"
#include "terramrf/meshing/mesh_builder.hpp"

namespace terramrf::meshing {
namespace {

using test::SimScene;

int buildingAt(const sim::World& w, double x, double y, double margin) {
  const auto& bs = w.buildings();
  for (std::size_t i = 0; i < bs.size(); ++i) {
    const auto& b = bs[i];
    const double c = std::cos(b.yaw_rad), s = std::sin(b.yaw_rad);
    const double dx = x - b.centre_m.x(), dy = y - b.centre_m.y();
    const double lx = c * dx + s * dy, ly = -s * dx + c * dy;
    if (std::abs(lx) <= b.half_size_m.x() + margin && std::abs(ly) <= b.half_size_m.y() + margin)
      return int(i);
  }
  return -1;
}

bool treeAt(const sim::World& w, double x, double y, double margin) {
  for (const auto& t : w.trees())
    if ((t.position_m - Eigen::Vector2d(x, y)).norm() <= t.crown_radius_m + margin) return true;
  return false;
}

struct Drive {
  SimScene scene{3};
  MeshBuilder builder;
  MaskStats mask;
  std::vector<FrameReport> reports;
  explicit Drive(std::size_t frames, std::size_t step) : builder([] {
        MeshBuilderParams p;
        return p;
      }()) {
    for (std::size_t i = 0; i < frames; i += step) reports.push_back(builder.addFrame(scene.frame(i)));
    mask = builder.finish();
  }
};

const Drive& drive() {
  static const Drive d(150, 5);
  return d;
}

TEST(MeshBuilder, RecoversBuildingHeightsBeyondLidarReach) {
  const Drive& d = drive();
  const TerrainMesh& mesh = d.builder.mesh();
  const sim::World& w = d.scene.world;
  double abs_sum = 0, raised_abs_sum = 0;
  std::size_t n = 0, n_raised = 0, n_building = 0;
  std::map<int, std::vector<float>> per_building;
  mesh.forEachVertex([&](const Tile& t, int k, const VertexKey& key) {
    const double x = key.first * mesh.params().cell_m, y = key.second * mesh.params().cell_m;
    const int b = buildingAt(w, x, y, 0.2);
    if (b < 0 || t.cls[k] == VertexClass::kGround || t.cls[k] == VertexClass::kUnknown) return;
    ++n_building;
    if (t.rec_weight[k] <= 0) return;
    const double h = mesh.displayHeight(t, k);
    const double e = std::abs(h - w.buildings()[b].top_z_m);
    abs_sum += e;
    ++n;
    if (t.z_max[k] < w.buildings()[b].top_z_m - 0.5) {
      raised_abs_sum += e;
      ++n_raised;
    }
    per_building[b].push_back(float(h));
  });
  std::printf("building vertices %zu, with height estimates %zu, MAE %.3f m; beyond LiDAR reach %zu, MAE %.3f m\n",
              n_building, n, n ? abs_sum / n : NAN, n_raised, n_raised ? raised_abs_sum / n_raised : NAN);
  // A building's recovered height: the median over its raised vertices (the paper compares the
  // average estimated height with the actual one, §4).
  double bsum = 0;
  for (const auto& [b, hs] : per_building) {
    std::vector<float> v = hs;
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    bsum += std::abs(v[v.size() / 2] - w.buildings()[b].top_z_m);
    std::printf("  building %d: true top %.2f m, median recovered %.2f m over %zu vertices\n", b,
                w.buildings()[b].top_z_m, v[v.size() / 2], v.size());
  }
  ASSERT_GE(per_building.size(), 2u);
  ASSERT_GT(n_raised, 50u);
  const double building_mae = bsum / per_building.size();
  std::printf("per-building height MAE %.3f m (target 0.11 m)\n", building_mae);
  EXPECT_LE(building_mae, 0.11);
  // Single vertices scatter more (columns at a building's corner that leave the silhouette, walls
  // seen only from far): ~0.21 m (1.30 m before crowns were kept as objects, docs/meshing.md).
  EXPECT_LE(raised_abs_sum / n_raised, 0.3);
}

TEST(MeshBuilder, ClassifiesBuildingsAndTreesAtCloseRange) {
  const Drive& d = drive();
  const TerrainMesh& mesh = d.builder.mesh();
  const sim::World& w = d.scene.world;
  std::size_t tp_b = 0, fn_b = 0, fp_b = 0, tn_t = 0;
  std::vector<float> resp_b, resp_t;
  mesh.forEachVertex([&](const Tile& t, int k, const VertexKey& key) {
    if (t.cls[k] != VertexClass::kBuilding && t.cls[k] != VertexClass::kTree) return;
    const double x = key.first * mesh.params().cell_m, y = key.second * mesh.params().cell_m;
    // Close range: within 15 m of the road's centre line.
    if (std::abs(w.lateralOffset(x, y)) > 15) return;
    const bool is_b = buildingAt(w, x, y, 0.2) >= 0;
    const bool is_t = !is_b && treeAt(w, x, y, 0.3);
    if (!is_b && !is_t) return;
    const bool pred_b = t.cls[k] == VertexClass::kBuilding;
    (is_b ? resp_b : resp_t).push_back(t.mask_response[k]);
    if (is_b) (pred_b ? tp_b : fn_b)++;
    else (pred_b ? fp_b : tn_t)++;
  });
  for (auto* v : {&resp_b, &resp_t}) {
    std::sort(v->begin(), v->end());
    if (!v->empty())
      std::printf("mask response %s: 10%% %.2f 50%% %.2f 90%% %.2f\n", v == &resp_b ? "building" : "tree",
                  (*v)[v->size() / 10], (*v)[v->size() / 2], (*v)[v->size() * 9 / 10]);
  }
  const std::size_t total = tp_b + fn_b + fp_b + tn_t;
  const double acc = total ? double(tp_b + tn_t) / total : 0;
  std::printf("truth tree / inferred tree %zu building %zu; truth building / tree %zu building %zu; accuracy %.2f %%\n",
              tn_t, fp_b, fn_b, tp_b, 100 * acc);
  ASSERT_GT(tp_b + fn_b, 100u);
  ASSERT_GT(tn_t + fp_b, 100u);
  // Paper Table 5 (close range): 98.9 %. This drive: 97.1 % (seeds 5, 7, 11: 98.2–98.7 %); the
  // remaining errors are wall ends/corners and crown returns next to a wall (docs/meshing.md).
  EXPECT_GE(acc, 0.96);
}

TEST(MeshBuilder, MissingImagesAndCamerasLookingAwayAreReported) {
  SimScene s(5);
  MeshBuilder b;
  Frame with = s.frame(0);
  Frame without = s.frame(5, /*with_camera=*/false);
  Frame away = s.frame(10);
  // Turn the camera round and drop the points behind the vehicle: it sees none of them.
  Eigen::Isometry3d turn = Eigen::Isometry3d::Identity();
  turn.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  away.cameras[0].model.T_camera_lidar = away.cameras[0].model.T_camera_lidar * turn;
  PointCloud ahead;
  for (std::size_t i = 0; i < away.points.size(); ++i)
    if (away.points.x[i] > 0) ahead.push_back(away.points.x[i], away.points.y[i], away.points.z[i], 0);
  away.points = ahead;
  b.addFrame(with);
  const std::size_t textured_before = b.mesh().texturedVertices();
  const FrameReport r = b.addFrame(without);
  EXPECT_FALSE(r.notes.empty());
  const FrameReport ra = b.addFrame(away);
  ASSERT_FALSE(ra.notes.empty());
  EXPECT_NE(ra.notes[0].find("no LiDAR point projects"), std::string::npos) << ra.notes[0];
  const BuilderSummary& sum = b.summary();
  ASSERT_EQ(sum.frames_without_image.size(), 2u);  // the frame without camera, the one looking away
  EXPECT_EQ(sum.frames_without_image[0], without.id);
  ASSERT_EQ(sum.cameras_looking_away.size(), 1u);
  EXPECT_EQ(b.mesh().texturedVertices(), textured_before);
  EXPECT_GT(b.mesh().verticesWithData(), b.mesh().texturedVertices());
  const std::string report = b.report();
  EXPECT_NE(report.find("frames without a camera image"), std::string::npos) << report;
  EXPECT_NE(report.find("cameras that see none of the points"), std::string::npos) << report;
}

TEST(MeshBuilder, EachCameraKeepsItsOwnSegmentation) {
  SimScene s(5);
  sim::CameraParams cp = SimScene::cameraParams();
  cp.name = "image_3";
  cp.yaw_deg = 90;  // looking left
  const sim::CameraRenderer side(s.world, cp);
  Frame f = s.frame(0);
  f.cameras.push_back(side.render(*f.pose, 77));
  // A third camera with an unusable (grey) image: no segmentation of its own, and none borrowed.
  CameraImage grey = f.cameras[0];
  grey.model.name = "image_4";
  grey.image = std::make_shared<Image>(512, 256, 1);
  grey.truth = nullptr;
  f.cameras.push_back(grey);
  MeshBuilder b;
  const FrameReport r = b.addFrame(f);
  ASSERT_EQ(r.segmentations.size(), 2u);
  for (std::size_t c = 0; c < 2; ++c) {
    const CameraSegmentation& cs = r.segmentations[c];
    EXPECT_EQ(cs.camera_index, c);
    EXPECT_EQ(cs.camera, f.cameras[c].model.name);
    const GroundSegmentation own =
        segmentGround(*f.cameras[c].image, f.cameras[c].model, f.points, b.params().ground);
    EXPECT_TRUE(cs.ground.ground == own.ground) << cs.camera << ": not its own segmentation";
    EXPECT_EQ(cs.object_mask.size(), own.ground.size()) << cs.camera;
  }
  EXPECT_FALSE(r.segmentations[0].ground.ground == r.segmentations[1].ground.ground);
  EXPECT_EQ(b.summary().images_rejected.size(), 1u);
}

TEST(MeshBuilder, RejectedImagesAndTruthAreListedApart) {
  SimScene s(5);
  MeshBuilder b;
  Frame grey = s.frame(0);
  grey.cameras[0].image = std::make_shared<Image>(512, 256, 1);
  const FrameReport rg = b.addFrame(grey);
  EXPECT_TRUE(rg.segmentations.empty());
  EXPECT_EQ(rg.images_used, 0);
  Frame bad_truth = s.frame(5);
  ASSERT_TRUE(bad_truth.cameras[0].truth);
  bad_truth.cameras[0].truth = std::make_shared<Image>(256, 128, 1);
  const FrameReport rt = b.addFrame(bad_truth);
  EXPECT_FALSE(rt.has_truth);
  EXPECT_EQ(rt.segmentations.size(), 1u);  // the image itself is fine and used
  const BuilderSummary& sum = b.summary();
  // Neither is a camera that sees none of the points.
  EXPECT_TRUE(sum.cameras_looking_away.empty());
  ASSERT_EQ(sum.images_rejected.size(), 1u);
  EXPECT_NE(sum.images_rejected[0].find("1 channel(s); expected RGB"), std::string::npos)
      << sum.images_rejected[0];
  ASSERT_EQ(sum.truth_rejected.size(), 1u);
  EXPECT_NE(sum.truth_rejected[0].find("pixel truth"), std::string::npos) << sum.truth_rejected[0];
  EXPECT_NE(sum.truth_rejected[0].find("256x128"), std::string::npos) << sum.truth_rejected[0];
  EXPECT_NE(sum.truth_rejected[0].find("512x256"), std::string::npos) << sum.truth_rejected[0];
  // Not counted as an evaluated image.
  EXPECT_EQ(sum.truth_frames, 0u);
  EXPECT_EQ(sum.confusion.total(), 0u);
  const std::string report = b.report();
  EXPECT_NE(report.find("camera images rejected: 1"), std::string::npos) << report;
  EXPECT_NE(report.find("pixel truth images rejected (not evaluated): 1"), std::string::npos)
      << report;
  EXPECT_EQ(report.find("cameras that see none of the points"), std::string::npos) << report;
  EXPECT_EQ(report.find("Image ground segmentation vs pixel truth"), std::string::npos) << report;
}

TEST(MeshBuilder, WithoutSegmentationAnImageOfAnotherSizeIsRejected) {
  SimScene s(5);
  MeshBuilderParams p;
  p.segment = false;
  MeshBuilder b(p);
  Frame f = s.frame(0);
  f.cameras[0].image = std::make_shared<Image>(256, 128, 3);  // the model says 512 x 256
  const FrameReport r = b.addFrame(f);
  EXPECT_EQ(r.images_used, 0);
  // Nothing baked from pixels clamped to the image edge.
  EXPECT_EQ(b.mesh().texturedVertices(), 0u);
  const BuilderSummary& sum = b.summary();
  ASSERT_EQ(sum.images_rejected.size(), 1u);
  EXPECT_NE(sum.images_rejected[0].find("256x128"), std::string::npos) << sum.images_rejected[0];
  EXPECT_NE(sum.images_rejected[0].find("512x256"), std::string::npos) << sum.images_rejected[0];
  EXPECT_NE(sum.images_rejected[0].find("image_2"), std::string::npos) << sum.images_rejected[0];
}

TEST(SceneRecovery, BorderVerticesAreTriedAndCountedOnce) {
  // Object vertices on the border x = 5 m of tiles (0,0) and (1,0) (5 m tiles): each is in both
  // tiles and must be tried once. A camera at (0, 2.5, 1) m looks along +x at a wall x = 5 m,
  // y ∈ [0.5, 4.5] m, 2 m tall (brown) under the sky (blue); the LiDAR saw it up to 0.5 m.
  TerrainMeshParams tp;
  tp.tile_vertices = 11;
  tp.cell_m = 0.5;
  TerrainMesh mesh(tp);
  for (int j = 2; j <= 8; ++j) mesh.addPoint({5.0, 0.5 * j, 0.5});  // 7 vertices, tile (1,0)
  mesh.addPoint({4.0, 2.0, 0.0});  // creates tile (0,0): the 7 now have two copies
  ASSERT_EQ(mesh.tileCount(), 2u);
  for (int j = 2; j <= 8; ++j)
    mesh.forEachCopy({10, j}, [](Tile& t, int k) {
      t.object_votes[k] = 1;
      t.cls[k] = VertexClass::kObject;
    });
  const int W = 200, H = 150;
  const double f = 100;
  CameraModel cam;
  cam.name = "front";
  cam.width = W;
  cam.height = H;
  cam.P << f, 0, W / 2.0, 0, 0, f, H / 2.0, 0, 0, 0, 1, 0;
  Eigen::Matrix3d R;
  R << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  const Eigen::Vector3d C(0, 2.5, 1.0);
  T.translation() = -R * C;
  cam.T_camera_lidar = T;
  Image img(W, H, 3);
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const double y = C.y() - (u - W / 2.0) * 5.0 / f, z = C.z() - (v - H / 2.0) * 5.0 / f;
      const bool wall = y >= 0.5 && y <= 4.5 && z <= 2.0;
      uint8_t* px = img.at(u, v);
      px[0] = wall ? 140 : 60;
      px[1] = wall ? 90 : 120;
      px[2] = wall ? 40 : 230;
    }
  GroundSegmentation none;  // no ground pixel
  none.width = W;
  none.height = H;
  none.ground.assign(std::size_t(W) * H, 0);
  const CameraView view(cam, Eigen::Isometry3d::Identity(), PointCloud{});
  const SceneRecoveryStats st = recoverHeights(mesh, view, img, none, PointCloud{}, {});
  std::printf("tried %zu, estimates %zu, lower bounds %zu, raised %zu\n", st.vertices_tried,
              st.estimates, st.lower_bounds, st.raised);
  EXPECT_EQ(st.vertices_tried, 7u);
  EXPECT_EQ(st.estimates + st.lower_bounds, 7u);
  EXPECT_EQ(st.raised, 7u);  // every top found at the wall's 2 m, above the LiDAR's 0.5 m
  // Both copies of a vertex carry the same single estimate.
  const Tile& a = *mesh.tile(0, 0);
  const Tile& b = *mesh.tile(1, 0);
  for (int j = 2; j <= 8; ++j) {
    EXPECT_FLOAT_EQ(a.rec_weight[10 * 11 + j], b.rec_weight[0 * 11 + j]) << j;
    EXPECT_NEAR(mesh.displayHeight(b, j), 2.0, 0.15) << j;
  }
}

TEST(MeshBuilder, GroundSegmentationOverTheDrive) {
  const Drive& d = drive();
  const GroundConfusion& c = d.builder.summary().confusion;
  std::printf("drive: %zu images, ground found %.2f %%, errors %.2f %%\n", d.builder.summary().truth_frames,
              100 * c.groundFound(), 100 * c.errorRate());
  // Paper Table 1: 97.68 % found, 3.19 % errors. This drive (half-resolution LiDAR) reaches
  // 99.2 % / 1.7 %; the full-resolution demo config 98.3 % / 1.05 % (docs/meshing.md).
  EXPECT_GE(c.groundFound(), 0.977);
  EXPECT_LE(c.errorRate(), 0.032);
}

}  // namespace
}  // namespace terramrf::meshing

namespace terramrf::meshing {
namespace {

// A wall patch (ground around a 3 m wall, 5 m long) at `x0, y0`.
void addWallPatch(TerrainMesh& mesh, double x0, double y0) {
  const double cell = mesh.params().cell_m;
  for (int i = 0; i <= 48; ++i)
    for (int j = 0; j <= 48; ++j) {
      const double x = x0 + i * cell, y = y0 + j * cell;
      const bool wall = i == 24 && j >= 4 && j <= 44;
      mesh.addPoint({x, y, wall ? 3.0 : 0.0});
    }
}

}  // namespace

// The masking works tile by tile with a margin: two patches 37.5 km apart (2000 tiles) cost two
// tiles' arrays, not ones over the 37.5 km box between them (~9e10 cells: the whole-box arrays
// threw std::bad_alloc), and both are masked alike.
TEST(BuildingMask, FarApartPatchesAreMaskedTileByTileAndAlike) {
  TerrainMesh mesh;
  const double far = 2000 * mesh.tileSpan() * mesh.params().cell_m;
  addWallPatch(mesh, 1.0, 1.0);
  addWallPatch(mesh, far + 1.0, far + 1.0);
  for (auto& [key, tp] : mesh.tiles()) {
    Tile& t = *tp;
    for (std::size_t k = 0; k < t.vertices(); ++k)
      if (t.hasData(int(k)))
        (t.z_sum[k] / t.count[k] > 1 ? t.object_votes[k] : t.ground_votes[k]) = 1;
  }
  MaskStats st;
  ASSERT_NO_THROW(st = classifyVertices(mesh, MaskParams{}));
  EXPECT_EQ(st.object_vertices, 2u * 41);
  EXPECT_EQ(st.buildings, 2u * 41);  // a straight 3 m wall: building along its whole length
  EXPECT_EQ(st.trees, 0u);
}

// A vertex in view of more than 65 535 images keeps its majority: the 16-bit counts saturated,
// both tied at 65 535 and every such vertex was called ground.
TEST(MeshBuilder, VotesCountPastSixteenBits) {
  SimScene s(5);
  MeshBuilder b;
  const Frame f = s.frame(0);
  b.addFrame(f);
  // What this frame's image says of each vertex, then both counts as after 65 535 such frames.
  std::map<std::pair<const Tile*, int>, bool> said_object;
  for (auto& [key, tp] : b.mesh().tiles()) {
    Tile& t = *tp;
    for (std::size_t k = 0; k < t.vertices(); ++k) {
      if (t.ground_votes[k] + t.object_votes[k] == 0) continue;
      said_object[{&t, int(k)}] = t.object_votes[k] > 0;
      t.ground_votes[k] = t.object_votes[k] = 65535;
    }
  }
  ASSERT_GT(said_object.size(), 100u);
  b.addFrame(f);  // the same view once more breaks every tie its own way
  std::size_t objects = 0;
  for (const auto& [vertex, object] : said_object) {
    const Tile& t = *vertex.first;
    const int k = vertex.second;
    objects += object;
    EXPECT_EQ(object ? t.object_votes[k] : t.ground_votes[k], 65536u);
    EXPECT_EQ(object ? t.ground_votes[k] : t.object_votes[k], 65535u);
  }
  EXPECT_GT(objects, 0u);
  EXPECT_LT(objects, said_object.size());
}

// Runs of consecutive numeric ids of one width collapse; everything else is kept as it is.
TEST(MeshReport, CompactFrameIdsIsLosslessAndKeepsOrder) {
  EXPECT_EQ(compactFrameIds({}), std::vector<std::string>{});
  EXPECT_EQ(compactFrameIds({"000001", "000002", "000003", "000004", "000009", "000010", "x7",
                             "000011", "000012", "000013", "0098", "0099", "0100", "99", "100",
                             "101"}),
            (std::vector<std::string>{"000001–000004 (4 frames)", "000009", "000010", "x7",
                                      "000011–000013 (3 frames)", "0098–0100 (3 frames)", "99",
                                      "100", "101"}));
  // A repeated id is not a run.
  EXPECT_EQ(compactFrameIds({"5", "5", "6"}), (std::vector<std::string>{"5", "5", "6"}));
}

}  // namespace terramrf::meshing
