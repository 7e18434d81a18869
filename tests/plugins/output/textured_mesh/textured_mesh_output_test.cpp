// Output plugin "textured_mesh" driven like the runner drives it: simulator frames in, OBJ/PLY/glTF
// and report.md out; bad parameters and an unwritable output folder are clear errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>

#include "output_test_support.hpp"
#include "terramrf/adapters/opencv_image.hpp"
#include "terramrf/atomic_file.hpp"
#include "terramrf/meshing/mesh_builder.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/registry.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

namespace fs = std::filesystem;

TEST(TexturedMeshOutput, WritesAllFormatsAndAReport) {
  test::TempDir dir;
  PluginContext ctx;
  ctx.output_dir = dir.str();
  PluginRegistry reg({test::pluginDir()});
  auto src = reg.create("simulator");
  setParams(*src, "{seed: 2, frames: 3, camera_width: 256, camera_height: 128, camera_fx: 148, "
                  "azimuth_step_deg: 0.36}", ctx);
  auto* source = dynamic_cast<Source*>(src.get());
  ASSERT_NE(source, nullptr);
  auto out = test::makeOutput(
      "textured_mesh",
      "{tile_vertices: 81, texels_per_cell: 1, max_range_m: 20, write_overlays: true}", ctx);
  ASSERT_NE(out, nullptr);
  RunInfo info;
  info.output_dir = dir.str();
  out->begin(info);
  for (std::size_t i = 0; i < source->size(); ++i) {
    Frame f = source->read(i);
    if (i == 1) f.cameras.clear();  // a frame without its image
    FrameContext fc;
    fc.frame = &f;
    fc.index = i;
    out->write(fc);
  }
  out->end({});
  const fs::path mesh = dir.path() / "mesh";
  for (const char* f : {"terrain.obj", "terrain.mtl", "terrain.ply", "terrain.glb", "report.md"})
    EXPECT_TRUE(fs::exists(mesh / f)) << f;
  EXPECT_TRUE(fs::exists(mesh / "textures"));
  const std::string report = readFile((mesh / "report.md").string());
  EXPECT_NE(report.find("frames without a camera image (mesh untextured there): 1"), std::string::npos) << report;
  EXPECT_NE(report.find("Ground pixels found"), std::string::npos) << report;
  // One overlay per frame with an image, kept across the export's folder swap, the size of the
  // camera image.
  std::vector<std::string> overlays;
  for (const auto& e : fs::directory_iterator(mesh / "overlays"))
    overlays.push_back(e.path().filename().string());
  std::sort(overlays.begin(), overlays.end());
  EXPECT_EQ(overlays, (std::vector<std::string>{"000000_image_2.png", "000002_image_2.png"}));
  const Image o = readImage((mesh / "overlays" / "000002_image_2.png").string());
  EXPECT_EQ(o.width, 256);
  EXPECT_EQ(o.height, 128);
  EXPECT_EQ(o.channels, 3);
  EXPECT_FALSE(fs::exists(dir.path() / "mesh.overlays-new"));

  // A second run into the same folder replaces the export and its overlays: none of the first
  // run's is left beside the second's.
  auto again = test::makeOutput(
      "textured_mesh",
      "{tile_vertices: 81, texels_per_cell: 1, max_range_m: 20, write_overlays: true}", ctx);
  ASSERT_NE(again, nullptr);
  again->begin(info);
  Frame f = source->read(1);
  FrameContext fc;
  fc.frame = &f;
  fc.index = 1;
  again->write(fc);
  again->end({});
  overlays.clear();
  for (const auto& e : fs::directory_iterator(mesh / "overlays"))
    overlays.push_back(e.path().filename().string());
  EXPECT_EQ(overlays, (std::vector<std::string>{"000001_image_2.png"}));
}

// A LiDAR-only log: every frame has the same note. It is printed for the first three frames and
// then counted (one line per frame flooded the terminal for a long log), and report.md gives the
// frames as one range instead of a line each.
TEST(TexturedMeshOutput, RepeatedFrameNotesAreCountedNotPrintedEachTime) {
  test::TempDir dir;
  PluginContext ctx;
  ctx.output_dir = dir.str();
  PluginRegistry reg({test::pluginDir()});
  auto src = reg.create("simulator");
  setParams(*src, "{seed: 2, frames: 7, azimuth_step_deg: 0.72}", ctx);
  auto* source = dynamic_cast<Source*>(src.get());
  ASSERT_NE(source, nullptr);
  auto out = test::makeOutput("textured_mesh", "{tile_vertices: 81, max_range_m: 20}", ctx);
  ASSERT_NE(out, nullptr);
  RunInfo info;
  info.output_dir = dir.str();
  out->begin(info);
  testing::internal::CaptureStderr();
  for (std::size_t i = 0; i < source->size(); ++i) {
    Frame f = source->read(i);
    f.cameras.clear();
    FrameContext fc;
    fc.frame = &f;
    fc.index = i;
    out->write(fc);
  }
  out->end({});
  const std::string err = testing::internal::GetCapturedStderr();
  const std::string note = "no usable camera image: points meshed without texture or segmentation";
  std::size_t printed = 0;
  for (auto at = err.find(note); at != std::string::npos; at = err.find(note, at + 1)) ++printed;
  EXPECT_EQ(printed, 4u) << err;  // frames 000000–000002, then the total
  EXPECT_NE(err.find("textured_mesh: frame 000002: " + note +
                     " (further frames with this note are counted, not printed; report.md lists "
                     "them)"),
            std::string::npos)
      << err;
  EXPECT_EQ(err.find("frame 000003"), std::string::npos) << err;
  EXPECT_NE(err.find("textured_mesh: 7 frames in all: " + note), std::string::npos) << err;
  const std::string report = readFile((dir.path() / "mesh" / "report.md").string());
  EXPECT_NE(report.find("- frames without a camera image (mesh untextured there): 7\n"
                        "  - 000000–000006 (7 frames)\n"),
            std::string::npos)
      << report;
}

// Two cameras (simulator image_2 ahead, image_3 to the left): each overlay shows its own
// camera's segmentation; a camera whose image cannot be segmented gets none; names are safe.
TEST(TexturedMeshOutput, EachCameraOverlayShowsItsOwnSegmentation) {
  test::TempDir dir;
  PluginContext ctx;
  ctx.output_dir = dir.str();
  PluginRegistry reg({test::pluginDir()});
  auto src = reg.create("simulator");
  setParams(*src,
            "{seed: 2, frames: 2, camera_yaws_deg: [0, 90], camera_width: 256, "
            "camera_height: 128, camera_fx: 148, azimuth_step_deg: 0.36}",
            ctx);
  auto* source = dynamic_cast<Source*>(src.get());
  ASSERT_NE(source, nullptr);
  const std::string params =
      "{tile_vertices: 81, texels_per_cell: 1, max_range_m: 20, write_overlays: true}";
  auto out = test::makeOutput("textured_mesh", params, ctx);
  ASSERT_NE(out, nullptr);
  RunInfo info;
  info.output_dir = dir.str();
  out->begin(info);
  // The same frames through a MeshBuilder with the plugin's parameters give the expected overlays.
  meshing::MeshBuilderParams mp;
  mp.mesh.tile_vertices = 81;
  mp.mesh.texels_per_cell = 1;
  mp.max_range_m = 20;
  meshing::MeshBuilder ref(mp);
  std::map<std::string, Image> expected;
  for (std::size_t i = 0; i < source->size(); ++i) {
    Frame f = source->read(i);
    ASSERT_EQ(f.cameras.size(), 2u);
    if (i == 0) f.id = "run/7";  // a frame id that is no file name
    if (i == 1) {
      // image_3 unusable here (grey): no overlay, not another camera's.
      f.cameras[1].image = std::make_shared<Image>(256, 128, 1);
    }
    const meshing::FrameReport r = ref.addFrame(f);
    for (const auto& cs : r.segmentations)
      expected[safeFileName(f.id) + "_" + cs.camera + ".png"] = meshing::overlaySegmentation(
          *f.cameras[cs.camera_index].image, cs.ground.ground, cs.object_mask);
    FrameContext fc;
    fc.frame = &f;
    fc.index = i;
    out->write(fc);
  }
  out->end({});
  std::vector<std::string> overlays;
  for (const auto& e : fs::directory_iterator(dir.path() / "mesh" / "overlays"))
    overlays.push_back(e.path().filename().string());
  std::sort(overlays.begin(), overlays.end());
  EXPECT_EQ(overlays, (std::vector<std::string>{"000001_image_2.png", "run_7_image_2.png",
                                                "run_7_image_3.png"}));
  ASSERT_EQ(expected.size(), 3u);
  for (const auto& [name, want] : expected) {
    const Image got = readImage((dir.path() / "mesh" / "overlays" / name).string());
    EXPECT_TRUE(got.width == want.width && got.height == want.height && got.data == want.data)
        << name << " does not show its own camera's segmentation";
  }
  // Two cameras' segmentations differ, so a borrowed one would have been caught above.
  EXPECT_FALSE(expected.at("run_7_image_2.png").data == expected.at("run_7_image_3.png").data);
  const std::string report = readFile((dir.path() / "mesh" / "report.md").string());
  EXPECT_NE(report.find("camera images rejected: 1"), std::string::npos) << report;
}

// No point within max_range_m (1 m around the sensor): no mesh files (an empty .glb is invalid
// glTF), and report.md says why.
TEST(TexturedMeshOutput, NoPointInRangeWritesNoMeshAndSaysWhy) {
  test::TempDir dir;
  PluginContext ctx;
  ctx.output_dir = dir.str();
  PluginRegistry reg({test::pluginDir()});
  auto src = reg.create("simulator");
  setParams(*src,
            "{seed: 2, frames: 2, camera_width: 256, camera_height: 128, camera_fx: 148, "
            "azimuth_step_deg: 0.36}",
            ctx);
  auto* source = dynamic_cast<Source*>(src.get());
  ASSERT_NE(source, nullptr);
  auto out = test::makeOutput("textured_mesh", "{tile_vertices: 81, max_range_m: 1}", ctx);
  ASSERT_NE(out, nullptr);
  RunInfo info;
  info.output_dir = dir.str();
  out->begin(info);
  for (std::size_t i = 0; i < source->size(); ++i) {
    Frame f = source->read(i);
    FrameContext fc;
    fc.frame = &f;
    fc.index = i;
    out->write(fc);
  }
  out->end({});
  const fs::path mesh = dir.path() / "mesh";
  for (const char* f : {"terrain.obj", "terrain.mtl", "terrain.ply", "terrain.glb"})
    EXPECT_FALSE(fs::exists(mesh / f)) << f;
  const std::string report = readFile((mesh / "report.md").string());
  EXPECT_NE(report.find("exported: nothing (no mesh files written): no LiDAR point within "
                        "max_range_m = 1 m"),
            std::string::npos)
      << report;
}

// `terramrf mesh` names the folder the textured_mesh output really writes (its `subdir`).
TEST(TexturedMeshOutput, MeshCommandReportsTheConfiguredSubdir) {
  test::TempDir dir;
  const std::string cfg = (dir.path() / "mesh.yaml").string();
  writeFileAtomic(cfg,
                  "version: 1\ngrid: {size_m: 40, cell_m: 0.5}\nsource:\n  type: simulator\n"
                  "  params: {seed: 2, frames: 1, camera_width: 256, camera_height: 128, "
                  "camera_fx: 148, azimuth_step_deg: 0.36}\nstages: []\noutputs:\n"
                  "  - type: textured_mesh\n    params: {subdir: terrain3d, tile_vertices: 81, "
                  "max_range_m: 20, formats: [obj]}\n");
  const std::string out = (dir.path() / "out").string();
  const std::string cmd = test::cli() + " mesh " + cfg + " --no-progress --out " + out + " 2>&1";
  std::FILE* pipe = popen(cmd.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string text;
  char buf[4096];
  while (std::size_t n = std::fread(buf, 1, sizeof buf, pipe)) text.append(buf, n);
  ASSERT_EQ(pclose(pipe), 0) << text;
  EXPECT_TRUE(fs::exists(out + "/terrain3d/report.md")) << text;
  EXPECT_NE(text.find("mesh in " + out + "/terrain3d"), std::string::npos) << text;
  EXPECT_NE(text.find("mesh: " + out + "/terrain3d (report.md)"), std::string::npos) << text;
  EXPECT_EQ(text.find(out + "/mesh"), std::string::npos) << text;
}

TEST(TexturedMeshOutput, BadParametersAreRejected) {
  PluginContext ctx;
  PluginRegistry reg({test::pluginDir()});
  auto p = reg.create("textured_mesh");
  EXPECT_THROW(setParams(*p, "{formats: [stl]}", ctx), std::exception);
  EXPECT_THROW(setParams(*p, "{mode: icm}", ctx), std::exception);
  EXPECT_THROW(setParams(*p, "{subdir: /abs}", ctx), std::exception);
}

// tile_vertices ≤ 2001 and texels_per_cell ≤ 8 each allowed, together they made tiles of
// 1.85 GiB (a 16001² texel texture), allocated whole as soon as a point fell in one: 2.0 GB RSS
// for a single tile. Refused at the config with the estimate and both parameters.
TEST(TexturedMeshOutput, TilesAboveTheMemoryBudgetAreRefusedAtTheConfig) {
  PluginContext ctx;
  PluginRegistry reg({test::pluginDir()});
  auto p = reg.create("textured_mesh");
  try {
    setParams(*p, "{tile_vertices: 2001, texels_per_cell: 8}", ctx);
    FAIL() << "accepted 1.85 GiB tiles";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("parameter 'texels_per_cell': tile_vertices 2001 with texels_per_cell 8 "
                        "makes tiles of 1.87 GiB each"),
              std::string::npos)
        << what;
    EXPECT_NE(what.find("expected at most 256 MiB per tile"), std::string::npos) << what;
  }
  EXPECT_THROW(setParams(*reg.create("textured_mesh"), "{tile_vertices: 2001}", ctx),
               std::exception);  // 2 texels per cell by default: 309 MiB
  EXPECT_NO_THROW(setParams(*reg.create("textured_mesh"),
                            "{tile_vertices: 2001, texels_per_cell: 1}", ctx));  // 229 MiB
  EXPECT_NO_THROW(setParams(*reg.create("textured_mesh"),
                            "{tile_vertices: 151, texels_per_cell: 8}", ctx));  // 10.7 MiB
}

TEST(TexturedMeshOutput, UnwritableOutputFolderFailsBeforeTheRun) {
  test::TempDir dir;
  const std::string file = (dir.path() / "occupied").string();
  writeFileAtomic(file, "x");
  PluginContext ctx;
  ctx.output_dir = file;
  auto out = test::makeOutput("textured_mesh", "{}", ctx);
  ASSERT_NE(out, nullptr);
  RunInfo info;
  info.output_dir = file;
  try {
    out->begin(info);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("occupied"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace terramrf
