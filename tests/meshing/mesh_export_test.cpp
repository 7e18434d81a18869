// Tiled mesh (paper 004 §3.1) and its exports, read back with independent readers: CGAL for OBJ
// and PLY, tinygltf for the .glb. Bad output folders and partial exports.
#include "terramrf/meshing/mesh_export.hpp"

#include <CGAL/IO/OBJ.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <sstream>

#include "output_test_support.hpp"
#include "terramrf/adapters/opencv_image.hpp"
#include "terramrf/atomic_file.hpp"
#include "terramrf/meshing/decimation.hpp"
#include "terramrf/meshing/terrain_mesh.hpp"
#include "test_support.hpp"

namespace terramrf::meshing {
namespace {

namespace fs = std::filesystem;
using Kernel = CGAL::Simple_cartesian<double>;

TEST(TerrainMesh, TilesAreCreatedOnDemandAndShareBorders) {
  TerrainMeshParams p;
  p.tile_vertices = 11;  // 10 cells of 0.5 m = 5 m per tile
  p.cell_m = 0.5;
  TerrainMesh m(p);
  m.addPoint({1.0, 1.0, 0.2});
  EXPECT_EQ(m.tileCount(), 1u);
  m.addPoint({5.0, 1.0, 0.4});  // on the border x = 5 m: vertex shared by tiles (0,0) and (1,0)
  EXPECT_EQ(m.tileCount(), 2u);
  m.addPoint({-0.3, -7.0, 0.1});  // negative coordinates: tile (−1, −2)
  EXPECT_EQ(m.tileCount(), 3u);
  EXPECT_NE(m.tile(-1, -2), nullptr);
  // The border vertex exists in both tiles with the same data, and is counted once.
  const Tile* a = m.tile(0, 0);
  const Tile* b = m.tile(1, 0);
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->count[10 * 11 + 2], 1u);
  EXPECT_EQ(b->count[0 * 11 + 2], 1u);
  EXPECT_FLOAT_EQ(a->z_max[10 * 11 + 2], 0.4f);
  EXPECT_EQ(m.verticesWithData(), 3u);
  // A tile created later copies the border data already registered by its neighbour.
  m.addPoint({11.0, 1.0, 0.0});  // tile (2,0)
  m.addPoint({10.0, 1.0, 0.7});  // x = 10 m: border of tiles (1,0) and (2,0)
  EXPECT_FLOAT_EQ(m.tile(2, 0)->z_max[0 * 11 + 2], 0.7f);
  EXPECT_FLOAT_EQ(m.tile(1, 0)->z_max[10 * 11 + 2], 0.7f);
  // Height statistics and display height (unknown class: mean).
  m.addPoint({1.0, 1.0, 0.4});
  EXPECT_NEAR(m.displayHeight(*a, 2 * 11 + 2), 0.3f, 1e-6);
}

TEST(TerrainMesh, APointInsideATileNeverCreatesTheNextOne) {
  TerrainMesh m;  // 151 vertices, 0.125 m: tile 0 covers x ∈ [0, 18.75] m
  m.addPoint({1.0, 1.0, 0.0});
  // 18.70 m lies inside tile 0 but rounds to its far border vertex 150: no new tile (paper §3.1),
  // the vertex is tile 0's.
  m.addPoint({18.70, 1.0, 0.5});
  EXPECT_EQ(m.tileCount(), 1u);
  const Tile* t0 = m.tile(0, 0);
  ASSERT_NE(t0, nullptr);
  EXPECT_EQ(t0->count[150 * 151 + 8], 1u);
  EXPECT_FLOAT_EQ(t0->z_max[150 * 151 + 8], 0.5f);
  EXPECT_EQ(m.verticesWithData(), 2u);
  // 18.80 m is outside tile 0: tile 1 is created, and the shared vertex is updated in both.
  m.addPoint({18.80, 1.0, 0.7});
  EXPECT_EQ(m.tileCount(), 2u);
  const Tile* t1 = m.tile(1, 0);
  ASSERT_NE(t1, nullptr);
  EXPECT_EQ(t0->count[150 * 151 + 8], 2u);
  EXPECT_EQ(t1->count[0 * 151 + 8], 2u);
  EXPECT_FLOAT_EQ(t1->z_max[0 * 151 + 8], 0.7f);
  EXPECT_EQ(m.verticesWithData(), 2u);
}

TEST(TerrainMesh, ANewTileCopiesTheBorderRegisteredBeforeIt) {
  TerrainMeshParams p;
  p.tile_vertices = 11;  // 5 m tiles
  p.cell_m = 0.5;
  TerrainMesh m(p);
  m.addPoint({5.0, 1.0, 0.7});  // x = 5 m: tile (1,0), on its border with tile (0,0)
  ASSERT_EQ(m.tileCount(), 1u);
  ASSERT_EQ(m.tile(0, 0), nullptr);
  m.addPoint({1.0, 1.0, 0.2});  // inside the lower tile, created now: it must copy the border
  const Tile* a = m.tile(0, 0);
  ASSERT_NE(a, nullptr);
  EXPECT_EQ(a->count[10 * 11 + 2], 1u);
  EXPECT_FLOAT_EQ(a->z_max[10 * 11 + 2], 0.7f);
  EXPECT_EQ(m.verticesWithData(), 2u);
}

TEST(TerrainMesh, LowerBoundWinsOverALowerEstimate) {
  TerrainMeshParams p;
  p.tile_vertices = 11;
  p.cell_m = 0.5;
  TerrainMesh m(p);
  m.addPoint({1.0, 1.0, 1.0});  // LiDAR top 1 m
  Tile& t = *m.tiles().begin()->second;
  const int k = 2 * 11 + 2;
  t.cls[k] = VertexClass::kBuilding;
  t.rec_sum[k] = 3.f;  // one estimate: 3 m
  t.rec_weight[k] = 1.f;
  t.rec_lower[k] = 5.f;  // another view: the wall runs out of the image at 5 m
  EXPECT_FLOAT_EQ(m.displayHeight(t, k), 5.f);
  t.rec_lower[k] = 2.f;  // a bound below the estimate does not lower it
  EXPECT_FLOAT_EQ(m.displayHeight(t, k), 3.f);
  t.rec_weight[k] = 0.f;  // bound alone
  EXPECT_FLOAT_EQ(m.displayHeight(t, k), 2.f);
}

// A vehicle standing still in a georeferenced world frame (z ≈ 300 m) puts tens of thousands of
// points on one vertex. Their mean was summed in float: 60 000 points with a true mean of
// 300.37 m came out 300.1976 m in the OBJ.
TEST(TerrainMesh, MeanOfManyPointsHighInTheWorldFrameIsExact) {
  TerrainMeshParams p;
  p.tile_vertices = 11;
  p.cell_m = 0.5;
  TerrainMesh m(p);
  // Pairs 300.00 / 300.74 m: mean 300.37 m exactly.
  for (int i = 0; i < 60000; ++i) m.addPoint({1.0, 1.0, i % 2 ? 300.74 : 300.0});
  const Tile& t = *m.tile(0, 0);
  const int k = 2 * 11 + 2;
  ASSERT_EQ(t.count[k], 60000u);
  EXPECT_NEAR(m.displayHeight(t, k), 300.37, 1e-4);
  EXPECT_NEAR(m.vertexPosition(t, 2, 2).z(), 300.37, 1e-4);
  EXPECT_FLOAT_EQ(t.z_min[k], 300.f);
  EXPECT_FLOAT_EQ(t.z_max[k], 300.74f);
}

// The recovered height is a weighted mean too (weight 1/range⁴), one estimate per view: a vehicle
// parked for half an hour gives a wall vertex some 20 000. In float it was 6 mm high at 300 m.
TEST(TerrainMesh, RecoveredHeightOfManyEstimatesIsExact) {
  TerrainMeshParams p;
  p.tile_vertices = 11;
  p.cell_m = 0.5;
  TerrainMesh m(p);
  m.addPoint({1.0, 1.0, 299.0});  // LiDAR top below the estimates
  Tile& t = *m.tiles().begin()->second;
  const int k = 2 * 11 + 2;
  t.cls[k] = VertexClass::kBuilding;
  for (int i = 0; i < 20000; ++i) {
    const double r = 5 + (i / 2) % 40;  // ranges 5..44 m, each pair the same weight
    m.addHeightEstimate({2, 2}, 300.37 + (i % 2 ? 0.2 : -0.2), 1 / (r * r * r * r));
  }
  EXPECT_NEAR(m.displayHeight(t, k), 300.37, 1e-4);
}

// Every tile is allocated whole as soon as a point falls in it; at the textured_mesh output's
// parameter bounds (2001 vertices, 8 texels per cell) one took 1.7 GiB (2.0 GB RSS for one tile).
TEST(TerrainMesh, TilesAboveTheMemoryBudgetAreRefused) {
  TerrainMeshParams p;
  p.tile_vertices = 2001;
  p.texels_per_cell = 8;
  try {
    TerrainMesh m(p);
    FAIL() << "accepted tiles of " << tileBytes(p) << " bytes";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()),
              "tile_vertices 2001 with texels_per_cell 8 makes tiles of 1.87 GiB each (2001 x 2001 "
              "vertices: 202 MiB, a 16001 x 16001 texel texture: 1.67 GiB); expected at most "
              "256 MiB per tile: every tile is allocated whole as soon as a point falls in it. "
              "Lower texels_per_cell or tile_vertices (the defaults, 151 and 2: 1.76 MiB per "
              "tile)");
  }
  p.texels_per_cell = 2;  // 309 MiB: still too large
  EXPECT_THROW(TerrainMesh{p}, std::invalid_argument);
  p.texels_per_cell = 1;  // 229 MiB: the largest within the bounds that fits
  EXPECT_NO_THROW(TerrainMesh{p});
  EXPECT_LE(tileBytes(p), kMaxTileBytes);
  // Parameters far outside any bound cannot overflow the estimate into "fits".
  p.tile_vertices = 1 << 30;
  p.texels_per_cell = 1 << 30;
  EXPECT_THROW(TerrainMesh{p}, std::invalid_argument);
}

// The estimate is what a tile really allocates (its arrays and texture), so the budget holds.
TEST(TerrainMesh, TileBytesIsWhatATileAllocates) {
  TerrainMeshParams p;
  p.tile_vertices = 31;
  p.texels_per_cell = 3;
  TerrainMesh m(p);
  m.addPoint({0.1, 0.1, 0});
  const Tile& t = *m.tile(0, 0);
  auto bytes = [](const auto& v) { return double(v.size() * sizeof(v[0])); };
  const double allocated = bytes(t.z_max) + bytes(t.z_min) + bytes(t.z_sum) + bytes(t.count) +
                           bytes(t.ground_votes) + bytes(t.object_votes) + bytes(t.rec_sum) +
                           bytes(t.rec_weight) + bytes(t.rec_lower) + bytes(t.cls) +
                           bytes(t.mask_response) + bytes(t.texture.data) + bytes(t.texel_range);
  EXPECT_DOUBLE_EQ(tileBytes(p), allocated);
}

TEST(TerrainMesh, PaperDefaults) {
  TerrainMesh m;
  EXPECT_EQ(m.params().tile_vertices, 151);
  EXPECT_DOUBLE_EQ(m.params().cell_m, 0.125);
  m.addPoint({0.01, 0.01, 0});
  EXPECT_EQ(m.tile(0, 0)->vertices(), 151u * 151u);
  EXPECT_EQ(m.textureSize(), 150 * 2 + 1);
}

// A sloped patch of ground, 12 m × 12 m, seen by a camera 3 m above its centre looking down; the
// image is a colour ramp so the baked texture can be checked.
struct Scene {
  TerrainMesh mesh;
  Image image{200, 200, 3};
  CameraModel cam;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  Scene() : mesh([] {
      TerrainMeshParams p;
      p.tile_vertices = 21;
      p.cell_m = 0.25;  // 5 m tiles
      return p;
    }()) {
    for (double x = -1; x <= 11; x += 0.1)
      for (double y = -1; y <= 11; y += 0.1) mesh.addPoint({x, y, 0.05 * x});
    for (int v = 0; v < 200; ++v)
      for (int u = 0; u < 200; ++u) {
        uint8_t* px = image.at(u, v);
        px[0] = uint8_t(u);
        px[1] = uint8_t(v);
        px[2] = 100;
      }
    cam.name = "down";
    cam.width = cam.height = 200;
    cam.P << 60, 0, 100, 0, 0, 60, 100, 0, 0, 0, 1, 0;
    // Camera looking straight down from (5, 5, 3): optical axis −z, image x = −y, image y = −x.
    Eigen::Matrix3d R;  // rows: camera axes in the LiDAR/world frame
    R << 0, -1, 0, -1, 0, 0, 0, 0, -1;
    Eigen::Isometry3d T_cam_world = Eigen::Isometry3d::Identity();
    T_cam_world.linear() = R;
    T_cam_world.translation() = -R * Eigen::Vector3d(5, 5, 3);
    cam.T_camera_lidar = T_cam_world;  // pose = identity: LiDAR frame = world
    // No LiDAR points: nothing hides any texel.
    mesh.bakeTexture(CameraView(cam, pose, PointCloud{}), image, 50);
  }
};

std::size_t countLines(const std::string& text, const std::string& prefix) {
  std::istringstream in(text);
  std::string line;
  std::size_t n = 0;
  while (std::getline(in, line))
    if (line.rfind(prefix, 0) == 0) ++n;
  return n;
}

TEST(MeshExport, AllFormatsReadBackWithIndependentReaders) {
  Scene s;
  ASSERT_GT(s.mesh.texturedVertices(), 0u);
  EXPECT_LT(s.mesh.texturedVertices(), s.mesh.verticesWithData());  // the camera sees a part
  test::TempDir dir;
  const std::string out = (dir.path() / "mesh").string();
  const ExportStats st = exportMesh(s.mesh, out, {});
  EXPECT_EQ(st.tiles, 16u);  // x, y ∈ [−1, 11] m with 5 m tiles: tiles −1..2 on each axis
  // 12 m / 0.25 m: 49 × 49 global vertices with data, split into tiles with duplicated borders.
  EXPECT_GT(st.vertices, 49u * 49u);
  EXPECT_GT(st.triangles, 2u * 48u * 48u - 1u);

  // OBJ through CGAL (polygon soup: no manifold requirement).
  std::vector<Kernel::Point_3> pts;
  std::vector<std::vector<std::size_t>> polys;
  ASSERT_TRUE(CGAL::IO::read_OBJ(out + "/terrain.obj", pts, polys));
  EXPECT_EQ(pts.size(), st.vertices);
  EXPECT_EQ(polys.size(), st.triangles);
  const std::string obj = readFile(out + "/terrain.obj");
  EXPECT_EQ(countLines(obj, "vt "), st.vertices);
  std::istringstream in(obj);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("vt ", 0) != 0) continue;
    double u = -1, v = -1;
    std::sscanf(line.c_str(), "vt %lf %lf", &u, &v);
    ASSERT_TRUE(u >= 0 && u <= 1 && v >= 0 && v <= 1) << line;
  }
  const std::string mtl = readFile(out + "/terrain.mtl");
  EXPECT_EQ(countLines(mtl, "map_Kd "), st.tiles);
  for (const auto& f : st.files) EXPECT_TRUE(fs::exists(out + "/" + f)) << f;

  // PLY through CGAL::Surface_mesh with its vertex properties.
  CGAL::Surface_mesh<Kernel::Point_3> sm;
  std::ifstream ply(out + "/terrain.ply", std::ios::binary);
  ASSERT_TRUE(CGAL::IO::read_PLY(ply, sm));
  EXPECT_EQ(sm.number_of_faces(), st.triangles);
  EXPECT_GE(sm.number_of_vertices(), st.vertices);
  auto cls = sm.property_map<CGAL::Surface_mesh<Kernel::Point_3>::Vertex_index, uint8_t>("v:class");
  EXPECT_TRUE(cls.second) << "PLY has no 'class' vertex property";
  auto col = sm.property_map<CGAL::Surface_mesh<Kernel::Point_3>::Vertex_index, CGAL::IO::Color>("v:color");
  EXPECT_TRUE(col.second) << "PLY has no vertex colour";

  // glTF through tinygltf.
  tinygltf::TinyGLTF loader;
  tinygltf::Model model;
  std::string err, warn;
  ASSERT_TRUE(loader.LoadBinaryFromFile(&model, &err, &warn, out + "/terrain.glb")) << err;
  EXPECT_EQ(model.meshes.size(), st.tiles);
  EXPECT_EQ(model.images.size(), st.tiles);
  std::size_t nv = 0, ni = 0;
  for (const auto& mesh : model.meshes) {
    ASSERT_EQ(mesh.primitives.size(), 1u);
    const auto& prim = mesh.primitives[0];
    nv += model.accessors.at(prim.attributes.at("POSITION")).count;
    ni += model.accessors.at(prim.indices).count;
    const auto& acc = model.accessors.at(prim.attributes.at("TEXCOORD_0"));
    const auto& bv = model.bufferViews.at(acc.bufferView);
    const unsigned char* base = model.buffers.at(bv.buffer).data.data() + bv.byteOffset + acc.byteOffset;
    for (std::size_t k = 0; k < acc.count * 2; ++k) {
      float f;
      std::memcpy(&f, base + 4 * k, 4);
      ASSERT_TRUE(f >= 0.f && f <= 1.f) << f;
    }
    const auto& mat = model.materials.at(prim.material);
    const int tex = mat.pbrMetallicRoughness.baseColorTexture.index;
    ASSERT_GE(tex, 0);
    const auto& img = model.images.at(model.textures.at(tex).source);
    EXPECT_EQ(img.width, s.mesh.textureSize());
    EXPECT_EQ(img.height, s.mesh.textureSize());
  }
  EXPECT_EQ(nv, st.vertices);
  EXPECT_EQ(ni, 3 * st.triangles);
}

TEST(MeshExport, TextureComesFromTheImage) {
  Scene s;
  // World (5, 5) is the image centre (100, 100): colour (100, 100, 100). Tile (1,1) starts at
  // (5, 5) m, so its texel (0, 0) is there.
  const Tile* t = s.mesh.tile(1, 1);
  ASSERT_NE(t, nullptr);
  const uint8_t* px = t->texture.at(0, 0);
  EXPECT_NEAR(px[0], 100, 2);
  EXPECT_NEAR(px[1], 100, 4);  // the slope moves the point a little in the image
  EXPECT_EQ(px[2], 100);
}

// Camera `f` px focal length, principal point at the image centre, at `at` in the world (pose =
// identity), looking along +x (image right = −y, image down = −z).
CameraModel forwardCamera(const Eigen::Vector3d& at, int w, int h, double f) {
  CameraModel cam;
  cam.name = "front";
  cam.width = w;
  cam.height = h;
  cam.P << f, 0, w / 2.0, 0, 0, f, h / 2.0, 0, 0, 0, 1, 0;
  Eigen::Matrix3d R;  // rows: camera axes in the world
  R << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = -R * at;
  cam.T_camera_lidar = T;
  return cam;
}

TEST(MeshTexture, GroundBehindAWallKeepsNoWallColour) {
  // Flat ground z = 0 over a 10 m tile; a 3 m wall at x = 4 m, y ∈ [3, 7] m in the LiDAR scan;
  // a camera at (0, 5, 1.5) m looks along +x. The image is red where it shows the wall.
  TerrainMeshParams p;
  p.tile_vertices = 41;
  p.cell_m = 0.25;
  TerrainMesh mesh(p);
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j) mesh.addPoint({0.25 * i, 0.25 * j, 0.0});
  const Eigen::Vector3d C(0, 5, 1.5);
  const int W = 200, H = 150;
  const double f = 100;
  const CameraModel cam = forwardCamera(C, W, H, f);
  Image img(W, H, 3);
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      // The pixel's ray meets the wall's plane x = 4 m at (y, z).
      const double y = C.y() - (u - W / 2.0) * 4.0 / f, z = C.z() - (v - H / 2.0) * 4.0 / f;
      const bool wall = y >= 3 && y <= 7 && z >= 0 && z <= 3;
      uint8_t* px = img.at(u, v);
      px[0] = wall ? 255 : 0;
      px[1] = wall ? 0 : 255;
      px[2] = 0;
    }
  PointCloud wall;
  for (double y = 3; y <= 7; y += 0.04)
    for (double z = 0; z <= 3; z += 0.04) wall.push_back(4.0, float(y), float(z), 0);
  mesh.bakeTexture(CameraView(cam, Eigen::Isometry3d::Identity(), wall), img, 40);
  const Tile& t = *mesh.tile(0, 0);
  const int T = mesh.textureSize();  // 81: texel (a, b) at (a, b) · 0.125 m
  // (6, 5, 0) m: behind the wall, its pixel shows the wall: no colour from this image.
  const int a_behind = 48, b = 40;
  const uint8_t* behind = t.texture.at(b, a_behind);
  EXPECT_FALSE(behind[0] == 255 && behind[1] == 0)
      << "ground behind the wall took the wall's colour";
  EXPECT_TRUE(std::isinf(t.texel_range[std::size_t(a_behind) * T + b]));
  // (2.5, 5, 0) m: in front of the wall, visible: the ground's green.
  const uint8_t* front = t.texture.at(b, 20);
  EXPECT_EQ(front[0], 0);
  EXPECT_EQ(front[1], 255);
}

TEST(MeshTexture, ANewTileCopiesTheBorderTexels) {
  // Tile (1,0) is textured before tile (0,0) exists; when (0,0) is created its border texels
  // (shared with (1,0)) must be the same, or the export shows a grey seam along the border.
  TerrainMeshParams p;
  p.tile_vertices = 11;  // 5 m tiles
  p.cell_m = 0.5;
  TerrainMesh mesh(p);
  for (double x = 5.0; x < 10; x += 0.1)
    for (double y = 0.0; y < 5; y += 0.1) mesh.addPoint({x, y, 0.0});
  ASSERT_EQ(mesh.tileCount(), 1u);
  const CameraModel cam = forwardCamera({1.0, 2.5, 2.0}, 200, 150, 100);
  Image img(200, 150, 3);
  for (int v = 0; v < 150; ++v)
    for (int u = 0; u < 200; ++u) {
      uint8_t* px = img.at(u, v);
      px[0] = uint8_t(u);
      px[1] = uint8_t(v);
      px[2] = 7;
    }
  ASSERT_GT(mesh.bakeTexture(CameraView(cam, Eigen::Isometry3d::Identity(), PointCloud{}), img, 40),
            0u);
  mesh.addPoint({4.0, 2.0, 0.0});  // creates tile (0,0)
  const Tile& lo = *mesh.tile(0, 0);
  const Tile& hi = *mesh.tile(1, 0);
  const int T = mesh.textureSize();
  std::size_t coloured = 0;
  for (int b = 0; b < T; ++b) {
    const uint8_t* x = lo.texture.at(b, T - 1);
    const uint8_t* y = hi.texture.at(b, 0);
    EXPECT_TRUE(x[0] == y[0] && x[1] == y[1] && x[2] == y[2]) << "texel column " << b;
    EXPECT_EQ(lo.texel_range[std::size_t(T - 1) * T + b], hi.texel_range[b])
        << "texel column " << b;
    coloured += y[2] == 7;
  }
  EXPECT_GT(coloured, std::size_t(T / 2));
}

// Samples an exported texture at a vertex's exported (u, v): must be the colour the camera saw
// at that vertex (the Scene's image is a ramp: red = image column, green = image row), so a
// flipped or shifted v picks another row and fails. OBJ: v up; glTF: v down.
TEST(MeshExport, TextureCoordinatesSampleTheVertexColour) {
  Scene s;
  test::TempDir dir;
  const std::string out = (dir.path() / "mesh").string();
  ExportOptions o;
  o.ply = false;
  exportMesh(s.mesh, out, o);
  const Eigen::Isometry3d T_lw = s.pose.inverse();
  // Expected colour of world point p: the ramp pixel it projects to; nullopt outside the image.
  auto expected = [&](const Eigen::Vector3d& p) -> std::optional<std::array<int, 2>> {
    const auto uv = s.cam.project(T_lw * p);
    if (!uv) return std::nullopt;
    return std::array<int, 2>{int(uv->x() + 0.5), int(uv->y() + 0.5)};
  };
  auto sample = [](const Image& img, double u, double v_down) {
    const int col = std::clamp(int(std::floor(u * img.width)), 0, img.width - 1);
    const int row = std::clamp(int(std::floor(v_down * img.height)), 0, img.height - 1);
    return img.at(col, row);
  };

  // OBJ: objects in order, vertex k of the file ↔ vt k; textures from the MTL's map_Kd.
  std::map<std::string, Image> textures;
  std::vector<std::array<double, 3>> v;
  std::vector<std::array<double, 2>> vt;
  std::vector<std::string> tex_of;  // texture of each vertex
  std::string current;
  std::istringstream in(readFile(out + "/terrain.obj"));
  std::string line;
  while (std::getline(in, line)) {
    double a, b, c;
    if (line.rfind("usemtl ", 0) == 0) {
      current = line.substr(7);
      textures.emplace(current, readImage(out + "/textures/" + current + ".png"));
    } else if (std::sscanf(line.c_str(), "v %lf %lf %lf", &a, &b, &c) == 3) {
      v.push_back({a, b, c});
    } else if (std::sscanf(line.c_str(), "vt %lf %lf", &a, &b) == 2) {
      vt.push_back({a, b});
      tex_of.push_back(current);
    }
  }
  ASSERT_EQ(v.size(), vt.size());
  std::size_t checked = 0;
  for (std::size_t k = 0; k < v.size(); k += 7) {
    const auto e = expected({v[k][0], v[k][1], v[k][2]});
    if (!e) continue;
    const uint8_t* px = sample(textures.at(tex_of[k]), vt[k][0], 1.0 - vt[k][1]);
    if (px[2] != 100) continue;  // untextured texel (grey) next to the image edge
    EXPECT_NEAR(px[0], (*e)[0], 1) << "OBJ vertex " << k;
    EXPECT_NEAR(px[1], (*e)[1], 1) << "OBJ vertex " << k;
    ++checked;
  }
  EXPECT_GT(checked, 100u);

  // glTF: positions relative to the root node, y-up (x, z, −y); TEXCOORD_0 with v down.
  tinygltf::TinyGLTF loader;
  tinygltf::Model model;
  std::string err, warn;
  ASSERT_TRUE(loader.LoadBinaryFromFile(&model, &err, &warn, out + "/terrain.glb")) << err;
  const tinygltf::Node& root = model.nodes.at(model.scenes.at(0).nodes.at(0));
  ASSERT_EQ(root.translation.size(), 3u);
  auto floats = [&](int accessor, std::size_t k, int n) {
    const auto& acc = model.accessors.at(accessor);
    const auto& bv = model.bufferViews.at(acc.bufferView);
    const unsigned char* base =
        model.buffers.at(bv.buffer).data.data() + bv.byteOffset + acc.byteOffset;
    std::array<float, 3> r{};
    std::memcpy(r.data(), base + (k * n) * 4, n * 4);
    return r;
  };
  checked = 0;
  for (const int child : root.children) {
    const auto& prim = model.meshes.at(model.nodes.at(child).mesh).primitives.at(0);
    const auto& img = model.images.at(
        model.textures
            .at(model.materials.at(prim.material).pbrMetallicRoughness.baseColorTexture.index)
            .source);
    ASSERT_GE(img.component, 3);
    Image tex(img.width, img.height, 3);
    for (int q = 0; q < img.width * img.height; ++q)
      for (int c = 0; c < 3; ++c)
        tex.data[std::size_t(q) * 3 + c] = img.image[std::size_t(q) * img.component + c];
    const int a_pos = prim.attributes.at("POSITION"), a_uv = prim.attributes.at("TEXCOORD_0");
    for (std::size_t k = 0; k < model.accessors.at(a_pos).count; k += 7) {
      const auto g = floats(a_pos, k, 3);
      const Eigen::Vector3d p(g[0] + root.translation[0], -(g[2] + root.translation[2]),
                              g[1] + root.translation[1]);
      const auto e = expected(p);
      if (!e) continue;
      const auto uv = floats(a_uv, k, 2);
      const uint8_t* px = sample(tex, uv[0], uv[1]);
      if (px[2] != 100) continue;
      EXPECT_NEAR(px[0], (*e)[0], 1) << "glTF vertex " << k << " at " << p.transpose();
      EXPECT_NEAR(px[1], (*e)[1], 1) << "glTF vertex " << k << " at " << p.transpose();
      ++checked;
    }
  }
  EXPECT_GT(checked, 100u);
}

TEST(MeshExport, EmptyMeshWritesNoMeshFiles) {
  // No triangle (two lone points): no .glb with an empty buffer (invalid glTF), no empty OBJ/PLY.
  TerrainMesh m;
  m.addPoint({1, 1, 0});
  m.addPoint({5, 5, 0});
  test::TempDir dir;
  const std::string out = (dir.path() / "mesh").string();
  ExportOptions o;
  bool called = false;
  o.add_files = [&](const std::string& folder, const ExportStats& st) {
    called = true;
    EXPECT_EQ(st.tiles, 0u);
    writeFileAtomic(folder + "/report.md", "why");
  };
  const ExportStats st = exportMesh(m, out, o);
  EXPECT_TRUE(called);
  EXPECT_EQ(st.tiles, 0u);
  EXPECT_TRUE(st.files.empty());
  for (const char* f : {"terrain.obj", "terrain.mtl", "terrain.ply", "terrain.glb"})
    EXPECT_FALSE(fs::exists(out + "/" + f)) << f;
  EXPECT_EQ(readFile(out + "/report.md"), "why");  // swapped in with the export
}

TEST(MeshExport, UnwritableFolderIsAClearError) {
  Scene s;
  test::TempDir dir;
  const std::string file = (dir.path() / "not_a_folder").string();
  writeFileAtomic(file, "x");
  try {
    exportMesh(s.mesh, file + "/mesh", {});
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("not_a_folder"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("cannot be created"), std::string::npos) << e.what();
  }
  EXPECT_THROW(checkWritableFolder(file), std::runtime_error);
}

TEST(MeshExport, FailedExportKeepsThePreviousOne) {
  Scene s;
  test::TempDir dir;
  const std::string out = (dir.path() / "mesh").string();
  exportMesh(s.mesh, out, {});
  const std::string obj = readFile(out + "/terrain.obj"), glb = readFile(out + "/terrain.glb");
  s.mesh.addPoint({20, 20, 1});  // changes the mesh
  {
    test::FileSizeLimit limit(4096);
    ASSERT_TRUE(limit.ok());
    try {
      exportMesh(s.mesh, out, {});
      FAIL() << "expected the size limit to break the export";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("previous export is kept"), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(readFile(out + "/terrain.obj"), obj);
  EXPECT_EQ(readFile(out + "/terrain.glb"), glb);
  for (const auto& e : fs::directory_iterator(dir.path()))
    EXPECT_EQ(e.path().filename(), "mesh") << "left behind: " << e.path();
}

// Each format is streamed to its file: a disk that fills up midway is an error naming that file
// and the reason, and neither the file nor a temporary one is left.
TEST(MeshExport, EachWriterNamesItsFileWhenTheDiskFills) {
  Scene s;
  const std::vector<TileMesh> tiles = extractTileMeshes(s.mesh);
  ASSERT_FALSE(tiles.empty());
  test::TempDir dir;
  const std::string obj = (dir.path() / "terrain.obj").string();
  const std::string ply = (dir.path() / "terrain.ply").string();
  const std::string glb = (dir.path() / "terrain.glb").string();
  const std::vector<std::pair<std::string, std::function<void()>>> writers = {
      {obj, [&] { writeObj(tiles, dir.str(), "terrain"); }},
      {ply, [&] { writePly(tiles, ply); }},
      {glb, [&] { writeGlb(tiles, glb); }}};
  for (const auto& [path, write] : writers) {
    std::string what;
    {
      test::FileSizeLimit limit(8192);
      ASSERT_TRUE(limit.ok());
      try {
        write();
      } catch (const std::runtime_error& e) {
        what = e.what();
      }
    }
    EXPECT_EQ(what, "cannot write output '" + path + "': " + std::strerror(EFBIG)) << path;
    EXPECT_FALSE(fs::exists(path)) << path;
  }
  for (const auto& e : fs::recursive_directory_iterator(dir.path()))
    EXPECT_EQ(e.path().filename().string().find(".tmp."), std::string::npos) << "left behind: " << e.path();
}

// A .glb's total length and chunk lengths are uint32, and tinygltf truncates larger sizes without
// a word: a mesh above 4 GiB was written as a corrupt file. The size rule, without writing 4 GiB.
TEST(MeshExport, GlbSizeIsCheckedAgainstItsThirtyTwoBitLengths) {
  EXPECT_EQ(glbFileBytes(0, 0), 20u);                  // header + empty JSON chunk
  EXPECT_EQ(glbFileBytes(5, 7), 12u + 8 + 8 + 8 + 8);  // chunks padded to 4 bytes
  // A binary chunk that fits alone no longer fits with the JSON and headers.
  const std::uint64_t bin = kMaxGlbBytes - 100;
  EXPECT_GT(glbFileBytes(80, bin), kMaxGlbBytes);
  EXPECT_NO_THROW(checkGlbSize(kMaxGlbBytes, 7));
  try {
    checkGlbSize(glbFileBytes(80, bin), 1234);
    FAIL() << "accepted a .glb above 4 GiB";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              "glTF: 1234 tile(s) make a .glb of 4 GiB (4294967304 bytes) or more, meshes and PNG "
              "textures together; expected at most 4294967295 bytes (4 GiB - 1: a .glb's lengths "
              "are 32-bit). Export formats: [obj, ply] instead (separate files per tile "
              "texture), or a smaller mesh (lower texels_per_cell, decimate: true, or fewer "
              "frames per run)");
  }
}

// writeGlb applies the rule to the whole file, the PNG textures in its binary chunk included,
// and writes nothing when it fails (tested with a small limit in place of 4 GiB).
TEST(MeshExport, GlbAboveTheLimitIsRefusedTexturesIncluded) {
  Scene s;
  std::vector<TileMesh> tiles = extractTileMeshes(s.mesh);
  ASSERT_FALSE(tiles.empty());
  test::TempDir dir;
  const std::string textured = (dir.path() / "textured.glb").string();
  writeGlb(tiles, textured);
  const std::uint64_t with_textures = fs::file_size(textured);
  std::vector<TileMesh> bare = tiles;
  for (auto& m : bare) m.texture = nullptr;
  const std::string untextured = (dir.path() / "untextured.glb").string();
  writeGlb(bare, untextured);
  const std::uint64_t without = fs::file_size(untextured);
  ASSERT_LT(without, with_textures);

  // Exactly the file's size passes (and writes the same file); one byte less does not.
  const std::string at_limit = (dir.path() / "at_limit.glb").string();
  writeGlb(tiles, at_limit, with_textures);
  EXPECT_EQ(readFile(at_limit), readFile(textured));
  const std::string over = (dir.path() / "over.glb").string();
  EXPECT_THROW(writeGlb(tiles, over, with_textures - 1), std::runtime_error);
  // A limit the meshes fit but not their textures: the textures count.
  try {
    writeGlb(tiles, over, without + (with_textures - without) / 2);
    FAIL() << "textures not counted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("Export formats: [obj, ply] instead"), std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(fs::exists(over));
  // A limit below the first tile's geometry stops at that tile, before encoding the others.
  try {
    writeGlb(tiles, over, 100);
    FAIL() << "accepted a .glb above 100 bytes";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("glTF: 1 tile(s) make a .glb of"), std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(fs::exists(over));
}

// Decimation of flat regions (decimation.hpp). Heights are given exactly at the vertices (one
// point each) so the original surface is known.
struct HeightField {
  TerrainMesh mesh;
  explicit HeightField(double (*height)(double x, double y), VertexClass (*cls)(double x) = nullptr)
      : mesh([] {
          TerrainMeshParams p;
          p.tile_vertices = 41;
          p.cell_m = 0.25;  // 10 m tiles
          return p;
        }()) {
    for (int i = 0; i <= 40; ++i)
      for (int j = 0; j <= 40; ++j) {
        const double x = 0.25 * i, y = 0.25 * j;
        mesh.addPoint({x, y, height(x, y)});
        if (cls) mesh.forEachCopy({i, j}, [&](Tile& t, int k) { t.cls[k] = cls(x); });
      }
  }
};

// Height of a triangle mesh at (x, y) (x-y projection); NaN outside.
double heightAt(const TileMesh& m, double x, double y) {
  for (const auto& t : m.triangles) {
    const auto &A = m.positions[t[0]], &B = m.positions[t[1]], &C = m.positions[t[2]];
    const double d = (B[1] - C[1]) * (A[0] - C[0]) + (C[0] - B[0]) * (A[1] - C[1]);
    const double l1 = ((B[1] - C[1]) * (x - C[0]) + (C[0] - B[0]) * (y - C[1])) / d;
    const double l2 = ((C[1] - A[1]) * (x - C[0]) + (A[0] - C[0]) * (y - C[1])) / d;
    const double l3 = 1 - l1 - l2;
    if (l1 >= -1e-9 && l2 >= -1e-9 && l3 >= -1e-9) return l1 * A[2] + l2 * B[2] + l3 * C[2];
  }
  return NAN;
}

// Samples every original vertex and triangle centroid: largest vertical distance of the
// decimated surface from the original one.
double maxDeviation(const TileMesh& orig, const TileMesh& dec) {
  double worst = 0;
  auto probe = [&](double x, double y, double z) {
    const double h = heightAt(dec, x, y);
    worst = std::isnan(h) ? INFINITY : std::max(worst, std::abs(h - z));
  };
  for (const auto& p : orig.positions) probe(p[0], p[1], p[2]);
  for (const auto& t : orig.triangles) {
    double c[3] = {0, 0, 0};
    for (int e = 0; e < 3; ++e)
      for (int a = 0; a < 3; ++a) c[a] += orig.positions[t[e]][a] / 3;
    probe(c[0], c[1], c[2]);
  }
  return worst;
}

// Kept vertices keep their own texture coordinate and colour (texture stays exact).
void expectAttributesOfOriginals(const TileMesh& orig, const TileMesh& dec) {
  std::map<std::pair<long, long>, std::size_t> at;
  for (std::size_t k = 0; k < orig.positions.size(); ++k)
    at[{std::lround(orig.positions[k][0] * 1000), std::lround(orig.positions[k][1] * 1000)}] = k;
  for (std::size_t k = 0; k < dec.positions.size(); ++k) {
    const auto it = at.find({std::lround(dec.positions[k][0] * 1000), std::lround(dec.positions[k][1] * 1000)});
    ASSERT_NE(it, at.end());
    EXPECT_EQ(dec.positions[k], orig.positions[it->second]);
    EXPECT_EQ(dec.uvs[k], orig.uvs[it->second]);
    EXPECT_EQ(dec.classes[k], orig.classes[it->second]);
    EXPECT_TRUE(dec.uvs[k][0] >= 0 && dec.uvs[k][0] <= 1 && dec.uvs[k][1] >= 0 && dec.uvs[k][1] <= 1);
  }
}

TEST(Decimation, FlatTileBecomesFewTriangles) {
  // A tilted plane: flat within any tolerance, so only the border vertices must stay.
  HeightField f([](double x, double y) { return 0.03 * x - 0.02 * y + 1.0; });
  const std::vector<TileMesh> tiles = extractTileMeshes(f.mesh);
  ASSERT_EQ(tiles.size(), 1u);
  TileMesh dec = tiles[0];
  const DecimationStats st = decimateTileMesh(dec, 0.02);
  std::printf("flat tile: %zu -> %zu triangles, %zu -> %zu vertices\n", st.triangles_before,
              st.triangles_after, st.vertices_before, st.vertices_after);
  EXPECT_EQ(st.triangles_before, 2u * 40 * 40);
  EXPECT_EQ(st.triangles_after, dec.triangles.size());
  // 160 border vertices fan into ~2·160 triangles at most (3200 before).
  EXPECT_LE(st.triangles_after, 330u);
  // The tile border (160 vertices, shared with neighbours) stays; next to nothing inside.
  EXPECT_GE(st.vertices_after, 160u);
  EXPECT_LE(st.vertices_after, 170u);
  EXPECT_LE(maxDeviation(tiles[0], dec), 1e-6);
  expectAttributesOfOriginals(tiles[0], dec);
  // Every triangle still counter-clockwise seen from above.
  for (const auto& t : dec.triangles) {
    const auto &A = dec.positions[t[0]], &B = dec.positions[t[1]], &C = dec.positions[t[2]];
    EXPECT_GT((B[0] - A[0]) * (C[1] - A[1]) - (B[1] - A[1]) * (C[0] - A[0]), 0);
  }
}

TEST(Decimation, BuildingStepKeepsItsEdgeWithinTolerance) {
  // Ground with 3 cm bumps, a 3 m building from x = 5 m: the wall and the roof edge stay, the
  // bumpy ground is decimated only within the tolerance.
  auto height = [](double x, double y) {
    return x >= 5.0 ? 3.0 : 0.03 * std::sin(1.3 * x) * std::cos(0.9 * y);
  };
  auto cls = [](double x) { return x >= 5.0 ? VertexClass::kBuilding : VertexClass::kGround; };
  HeightField f(height, cls);
  const std::vector<TileMesh> tiles = extractTileMeshes(f.mesh);
  ASSERT_EQ(tiles.size(), 1u);
  for (double tol : {0.005, 0.02}) {
    TileMesh dec = tiles[0];
    const DecimationStats st = decimateTileMesh(dec, tol);
    const double dev = maxDeviation(tiles[0], dec);
    std::printf("step, tolerance %.3f m: %zu -> %zu triangles, sampled deviation %.4f m (bound %.4f)\n",
                tol, st.triangles_before, st.triangles_after, dev, st.max_deviation_m);
    EXPECT_LT(st.triangles_after, st.triangles_before / 2);
    EXPECT_LE(dev, tol + 1e-9);
    EXPECT_LE(st.max_deviation_m, tol + 1e-9);
    expectAttributesOfOriginals(tiles[0], dec);
    // Both rows of the class boundary (last ground row x = 4.75 m, first roof row x = 5 m) are
    // kept entirely: the wall is exactly where it was.
    std::size_t foot = 0, top = 0;
    for (const auto& p : dec.positions) {
      foot += std::abs(p[0] - 4.75) < 1e-9;
      top += std::abs(p[0] - 5.0) < 1e-9 && std::abs(p[2] - 3.0) < 1e-9;
    }
    EXPECT_EQ(foot, 41u);
    EXPECT_EQ(top, 41u);
  }
}

TEST(Decimation, HoleOutlinesStayExact) {
  // A flat tile with a 2 m × 1.5 m hole (no data): the hole's straight edges lose their inner
  // vertices, the outline keeps its place, so the mesh covers exactly the same area.
  TerrainMeshParams p;
  p.tile_vertices = 41;
  p.cell_m = 0.25;
  TerrainMesh mesh(p);
  for (int i = 0; i <= 40; ++i)
    for (int j = 0; j <= 40; ++j) {
      const double x = 0.25 * i, y = 0.25 * j;
      if (x > 3.1 && x < 5.1 && y > 4.1 && y < 5.6) continue;
      mesh.addPoint({x, y, 0.2});
    }
  const std::vector<TileMesh> tiles = extractTileMeshes(mesh);
  ASSERT_EQ(tiles.size(), 1u);
  TileMesh dec = tiles[0];
  const DecimationStats st = decimateTileMesh(dec, 0.01);
  auto area = [](const TileMesh& m) {
    double a = 0;
    for (const auto& t : m.triangles) {
      const auto &A = m.positions[t[0]], &B = m.positions[t[1]], &C = m.positions[t[2]];
      a += 0.5 * ((B[0] - A[0]) * (C[1] - A[1]) - (B[1] - A[1]) * (C[0] - A[0]));
    }
    return a;
  };
  std::printf("tile with a hole: %zu -> %zu triangles, area %.4f -> %.4f m²\n", st.triangles_before,
              st.triangles_after, area(tiles[0]), area(dec));
  EXPECT_LT(st.triangles_after * 5, st.triangles_before);
  EXPECT_NEAR(area(dec), area(tiles[0]), 1e-6);
  EXPECT_LE(maxDeviation(tiles[0], dec), 1e-9);  // every original sample still covered
}

TEST(Decimation, AllFormatsExportTheDecimatedMesh) {
  Scene s;  // the sloped, textured patch: planar, so it decimates strongly
  test::TempDir dir;
  const std::string full_dir = (dir.path() / "full").string(), dec_dir = (dir.path() / "dec").string();
  const ExportStats full = exportMesh(s.mesh, full_dir, {});
  ExportOptions o;
  o.decimate = true;
  o.flat_tolerance_m = 0.01;
  const ExportStats st = exportMesh(s.mesh, dec_dir, o);
  std::printf("export: %zu -> %zu triangles, %zu -> %zu vertices\n", full.triangles, st.triangles,
              full.vertices, st.vertices);
  EXPECT_EQ(st.triangles_before_decimation, full.triangles);
  EXPECT_LT(st.triangles * 4, full.triangles);
  EXPECT_EQ(st.tiles, full.tiles);
  // OBJ (CGAL polygon soup), texture coordinates in [0, 1].
  std::vector<Kernel::Point_3> pts;
  std::vector<std::vector<std::size_t>> polys;
  ASSERT_TRUE(CGAL::IO::read_OBJ(dec_dir + "/terrain.obj", pts, polys));
  EXPECT_EQ(pts.size(), st.vertices);
  EXPECT_EQ(polys.size(), st.triangles);
  const std::string obj = readFile(dec_dir + "/terrain.obj");
  EXPECT_EQ(countLines(obj, "vt "), st.vertices);
  std::istringstream in(obj);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("vt ", 0) != 0) continue;
    double u = -1, v = -1;
    std::sscanf(line.c_str(), "vt %lf %lf", &u, &v);
    ASSERT_TRUE(u >= 0 && u <= 1 && v >= 0 && v <= 1) << line;
  }
  // PLY (CGAL::Surface_mesh).
  CGAL::Surface_mesh<Kernel::Point_3> sm;
  std::ifstream ply(dec_dir + "/terrain.ply", std::ios::binary);
  ASSERT_TRUE(CGAL::IO::read_PLY(ply, sm));
  EXPECT_EQ(sm.number_of_faces(), st.triangles);
  // glb (tinygltf).
  tinygltf::TinyGLTF loader;
  tinygltf::Model model;
  std::string err, warn;
  ASSERT_TRUE(loader.LoadBinaryFromFile(&model, &err, &warn, dec_dir + "/terrain.glb")) << err;
  std::size_t nv = 0, ni = 0;
  for (const auto& mesh : model.meshes) {
    const auto& prim = mesh.primitives.at(0);
    nv += model.accessors.at(prim.attributes.at("POSITION")).count;
    ni += model.accessors.at(prim.indices).count;
    const auto& acc = model.accessors.at(prim.attributes.at("TEXCOORD_0"));
    const auto& bv = model.bufferViews.at(acc.bufferView);
    const unsigned char* base = model.buffers.at(bv.buffer).data.data() + bv.byteOffset + acc.byteOffset;
    for (std::size_t k = 0; k < acc.count * 2; ++k) {
      float f;
      std::memcpy(&f, base + 4 * k, 4);
      ASSERT_TRUE(f >= 0.f && f <= 1.f) << f;
    }
  }
  EXPECT_EQ(nv, st.vertices);
  EXPECT_EQ(ni, 3 * st.triangles);
}

TEST(Decimation, NegativeToleranceIsRejected) {
  TileMesh m;
  EXPECT_THROW(decimateTileMesh(m, -0.1), std::invalid_argument);
}

}  // namespace
}  // namespace terramrf::meshing
