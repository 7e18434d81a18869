// haralick: co-occurrence features against values computed by hand — Haralick et al.'s own 4×4
// example (1973, Fig. 2), a 2-level checkerboard, a flat patch — plus cell masking, camera
// choice and bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "plugins/feature/camera_fusion/fusion_test_frame.hpp"

namespace terramrf {
namespace {

using test::forwardCamera;
using test::groundFrame;
using test::setCellRect;
using test::StageRunner;

struct Result {
  float asm_, variance, idm;
};

/// Runs haralick with `params` on cell 0 covering [u0,u1)×[v0,v1) of an image filled by `fill`.
template <class Fill>
Result run(const std::string& params, Fill fill, int u0, int u1, int v0, int v1, int channels = 3) {
  Frame f = groundFrame(forwardCamera(), fill, channels);
  StageRunner r;
  r.add("haralick", params);
  r.prepare(f);
  setCellRect(r.grid, 200, 100, 0, u0, u1, v0, v1);
  r.process();
  for (const char* l : {"haralick_asm", "haralick_variance", "haralick_idm"})
    for (std::size_t c = 1; c < r.grid.cells(); ++c)
      EXPECT_TRUE(std::isnan(r.grid.layer(l)[c])) << l << " cell " << c << " has no pixels";
  return {r.grid.layer("haralick_asm")[0], r.grid.layer("haralick_variance")[0],
          r.grid.layer("haralick_idm")[0]};
}

void grey(uint8_t* p, int g) { p[0] = p[1] = p[2] = uint8_t(g); }

// Haralick, Shanmugam & Dinstein (1973), Fig. 2: grey tones 0..3
//   0 0 1 1 / 0 0 1 1 / 0 2 2 2 / 2 2 3 3
// placed at u 20..23, v 30..33; tone t is drawn as grey 64·t (level ⌊64t·4/256⌋ = t).
void haralickExample(int u, int v, uint8_t* p) {
  static const int tone[4][4] = {{0, 0, 1, 1}, {0, 0, 1, 1}, {0, 2, 2, 2}, {2, 2, 3, 3}};
  const bool in = u >= 20 && u < 24 && v >= 30 && v < 34;
  grey(p, in ? 64 * tone[v - 30][u - 20] : 255);
}

TEST(Haralick, PaperExampleHorizontal) {
  // P_H = [4 2 1 0; 2 4 0 0; 1 0 6 1; 0 0 1 2], R = 24.
  //   ASM = (16+4+1+4+16+1+36+1+1+4)/576 = 84/576
  //   μ = (1·6 + 2·8 + 3·3)/24 = 31/24, E[i²] = (6 + 32 + 27)/24 = 65/24, var = E[i²] − μ²
  //   IDM = (16 + 6·½ + 2·⅕)/24 = 19.4/24
  const Result r = run("{levels: 4, offsets: [1, 0]}", haralickExample, 20, 24, 30, 34);
  EXPECT_NEAR(r.asm_, 84.0 / 576, 1e-6);
  EXPECT_NEAR(r.variance, 65.0 / 24 - (31.0 / 24) * (31.0 / 24), 1e-6);
  EXPECT_NEAR(r.idm, 19.4 / 24, 1e-6);
}

TEST(Haralick, PaperExampleVertical) {
  // P_V = [6 0 2 0; 0 4 2 0; 2 2 2 2; 0 0 2 0]: ASM = 80/576, μ = 28/24, E[i²] = 56/24,
  // IDM = (12 + 8·½ + 4·⅕)/24 = 16.8/24. Offset (0, −1) and (0, 1) give the same matrix.
  for (const char* off : {"[0, -1]", "[0, 1]"}) {
    const Result r =
        run(std::string("{levels: 4, offsets: ") + off + "}", haralickExample, 20, 24, 30, 34);
    EXPECT_NEAR(r.asm_, 80.0 / 576, 1e-6) << off;
    EXPECT_NEAR(r.variance, 56.0 / 24 - (28.0 / 24) * (28.0 / 24), 1e-6) << off;
    EXPECT_NEAR(r.idm, 16.8 / 24, 1e-6) << off;
  }
}

void checker(int u, int v, uint8_t* p) { grey(p, (u + v) % 2 ? 255 : 0); }

TEST(Haralick, TwoLevelCheckerboard) {
  // 9 × 9 checkerboard of single pixels, 2 levels.
  // Horizontal/vertical neighbours always differ: P = [0 n; n 0] / 2n → ASM = ½, μ = ½,
  // var = ½ − ¼ = ¼, IDM = ½. Diagonal neighbours always agree, and for 8 × 8 diagonal pairs the
  // two colours occur 32 times each: P = [n 0; 0 n] / 2n → ASM = ½, var = ¼, IDM = 1.
  const Result h = run("{levels: 2, offsets: [1, 0]}", checker, 10, 19, 10, 19);
  EXPECT_FLOAT_EQ(h.asm_, 0.5f);
  EXPECT_FLOAT_EQ(h.variance, 0.25f);
  EXPECT_FLOAT_EQ(h.idm, 0.5f);
  const Result d = run("{levels: 2, offsets: [1, 1]}", checker, 10, 19, 10, 19);
  EXPECT_FLOAT_EQ(d.asm_, 0.5f);
  EXPECT_FLOAT_EQ(d.variance, 0.25f);
  EXPECT_FLOAT_EQ(d.idm, 1.0f);
  // Default: 0°, 45°, 90°, 135° averaged → IDM (½ + 1 + ½ + 1) / 4.
  const Result all = run("{levels: 2}", checker, 10, 19, 10, 19);
  EXPECT_FLOAT_EQ(all.asm_, 0.5f);
  EXPECT_FLOAT_EQ(all.variance, 0.25f);
  EXPECT_FLOAT_EQ(all.idm, 0.75f);
}

TEST(Haralick, FlatPatch) {
  const Result r = run(
      "{}", [](int, int, uint8_t* p) { grey(p, 77); }, 0, 30, 0, 30);
  EXPECT_FLOAT_EQ(r.asm_, 1.0f);
  EXPECT_FLOAT_EQ(r.variance, 0.0f);
  EXPECT_FLOAT_EQ(r.idm, 1.0f);
}

TEST(Haralick, OnlyPairsInsideTheCellCount) {
  // The cell is flat; everything around it is a checkerboard. Pairs reaching out of the cell
  // would lower ASM below 1.
  auto fill = [](int u, int v, uint8_t* p) {
    const bool in = u >= 50 && u < 60 && v >= 40 && v < 50;
    grey(p, in ? 100 : ((u + v) % 2 ? 255 : 0));
  };
  const Result r = run("{}", fill, 50, 60, 40, 50);
  EXPECT_FLOAT_EQ(r.asm_, 1.0f);
  EXPECT_FLOAT_EQ(r.variance, 0.0f);
  EXPECT_FLOAT_EQ(r.idm, 1.0f);
}

TEST(Haralick, SparsePixelSetWithoutPairsIsNoData) {
  Frame f = groundFrame(forwardCamera(), checker);
  StageRunner r;
  r.add("haralick", "{offsets: [1, 0]}");
  r.prepare(f);
  setCellRect(r.grid, 200, 100, 0, 0, 1, 0, 1);
  // Three isolated pixels: no horizontal pair.
  CellPixels& cp = r.grid.cellPixels()[0];
  cp.pixels = {0, 2, 4};
  for (std::size_t c = 1; c < cp.offsets.size(); ++c) cp.offsets[c] = 3;
  r.process();
  EXPECT_TRUE(std::isnan(r.grid.layer("haralick_asm")[0]));
  EXPECT_TRUE(std::isnan(r.grid.layer("haralick_idm")[0]));
}

// CellPixels only promises pixels grouped by cell, not sorted. A reversed list made the row range
// taken from the first and last pixel negative (std::length_error); any other order wrote past
// the cell's box.
TEST(Haralick, PixelOrderWithinACellDoesNotMatter) {
  auto texture = [](int u, int v, uint8_t* p) { grey(p, (u * 37 + v * 101 + u * v * 7) % 256); };
  Frame f = groundFrame(forwardCamera(), texture);
  auto features = [&](void (*reorder)(uint32_t*, uint32_t*)) {
    StageRunner r;
    r.add("haralick", "{levels: 8}");
    r.prepare(f);
    setCellRect(r.grid, 200, 100, 0, 40, 52, 20, 32);
    CellPixels& cp = r.grid.cellPixels()[0];
    // Not a rectangle: drop the top-left 4 × 4 corner, so the per-row column ranges matter.
    cp.pixels.erase(std::remove_if(cp.pixels.begin(), cp.pixels.end(),
                                   [](uint32_t p) { return p % 200 < 44 && p / 200 < 24; }),
                    cp.pixels.end());
    for (std::size_t c = 1; c < cp.offsets.size(); ++c) cp.offsets[c] = uint32_t(cp.pixels.size());
    reorder(cp.pixels.data(), cp.pixels.data() + cp.pixels.size());
    r.process();
    return Result{r.grid.layer("haralick_asm")[0], r.grid.layer("haralick_variance")[0],
                  r.grid.layer("haralick_idm")[0]};
  };
  const Result sorted = features([](uint32_t*, uint32_t*) {});
  ASSERT_FALSE(std::isnan(sorted.asm_));
  ASSERT_LT(sorted.asm_, 0.5f) << "the texture should not be flat";
  const Result reversed = features([](uint32_t* b, uint32_t* e) { std::reverse(b, e); });
  const Result shuffled = features([](uint32_t* b, uint32_t* e) {
    std::mt19937 rng(7);
    std::shuffle(b, e, rng);
  });
  for (const Result& r : {reversed, shuffled}) {
    EXPECT_EQ(r.asm_, sorted.asm_);
    EXPECT_EQ(r.variance, sorted.variance);
    EXPECT_EQ(r.idm, sorted.idm);
  }
}

TEST(Haralick, GreyFromRgbAndQuantisation) {
  // Luma of (255, 0, 0) is 76 and of (0, 0, 255) is 29: with 16 levels both are level ⌊g/16⌋ =
  // 4 and 1; with 2 levels both are level 0 (one grey level → flat).
  auto fill = [](int u, int, uint8_t* p) {
    p[0] = u % 2 ? 255 : 0, p[1] = 0, p[2] = u % 2 ? 0 : 255;
  };
  const Result two = run("{levels: 2, offsets: [1, 0]}", fill, 0, 10, 0, 10);
  EXPECT_FLOAT_EQ(two.asm_, 1.0f);
  const Result sixteen = run("{levels: 16, offsets: [1, 0]}", fill, 0, 10, 0, 10);
  EXPECT_FLOAT_EQ(sixteen.asm_, 0.5f);
  EXPECT_FLOAT_EQ(sixteen.variance, 2.25f);  // levels 1 and 4: ((4 − 1)/2)²
  EXPECT_FLOAT_EQ(sixteen.idm, 0.1f);        // 1 / (1 + 3²)
  // A 1-channel image is used as grey directly (its fill writes one byte per pixel).
  auto checker_grey = [](int u, int v, uint8_t* p) { p[0] = (u + v) % 2 ? 255 : 0; };
  const Result g = run("{levels: 2, offsets: [1, 0]}", checker_grey, 10, 19, 10, 19, 1);
  EXPECT_FLOAT_EQ(g.asm_, 0.5f);
}

TEST(Haralick, ChoosesTheCameraThatSeesTheCellBest) {
  // Camera 0 flat, camera 1 checkerboard; the cell has 100 px in camera 0 and 400 in camera 1.
  Frame f = groundFrame(forwardCamera(), [](int, int, uint8_t* p) { grey(p, 9); });
  Frame g = groundFrame(forwardCamera("second"), checker, 3, "/data/second/000007.png");
  f.cameras.push_back(g.cameras[0]);
  for (int cam : {-1, 0, 1}) {
    StageRunner r;
    r.add("haralick", "{levels: 2, offsets: [1, 0], camera: " + std::to_string(cam) + "}");
    r.prepare(f);
    setCellRect(r.grid, 200, 100, 0, 0, 20, 0, 20);
    CellPixels big = r.grid.cellPixels()[0];
    big.camera = 1;
    setCellRect(r.grid, 200, 100, 0, 0, 10, 0, 10);  // camera 0: 100 px
    r.grid.cellPixels().push_back(big);
    ASSERT_EQ(r.grid.cellPixels()[1].count(0), 400u);
    r.process();
    const float expect = cam == 0 ? 1.0f : 0.5f;
    EXPECT_FLOAT_EQ(r.grid.layer("haralick_asm")[0], expect) << "camera " << cam;
  }
}

TEST(HaralickBadInput, NoFusedPixels) {
  Frame f = groundFrame(forwardCamera(), checker);
  StageRunner r;
  r.add("haralick");
  try {
    r.run(f);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), f.source_path);
    EXPECT_NE(std::string(e.what()).find("camera_fusion"), std::string::npos) << e.what();
  }
}

TEST(HaralickBadInput, ImageDiffersFromFusedSizeOrIsMissing) {
  Frame f = groundFrame(forwardCamera(), checker);
  StageRunner r;
  r.add("haralick");
  r.prepare(f);
  setCellRect(r.grid, 200, 100, 0, 0, 10, 0, 10);
  f.cameras[0].image = std::make_shared<Image>(50, 100, 3);
  try {
    r.process();
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "/data/front/000007.png");
    EXPECT_NE(std::string(e.what()).find("50x100"), std::string::npos) << e.what();
  }
  f.cameras[0].image.reset();
  try {
    r.process();
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "/data/front/000007.png");
  }
}

TEST(HaralickParams, RejectsBadOffsetsAndLevels) {
  StageRunner r;
  EXPECT_THROW(r.add("haralick", "{offsets: [1, 0, 1]}"), std::runtime_error);
  EXPECT_THROW(r.add("haralick", "{offsets: [0, 0]}"), std::runtime_error);
  EXPECT_THROW(r.add("haralick", "{offsets: [0.5, 1]}"), std::runtime_error);
  EXPECT_THROW(r.add("haralick", "{offsets: []}"), std::runtime_error);
  EXPECT_THROW(r.add("haralick", "{levels: 1}"), std::runtime_error);
  EXPECT_NO_THROW(r.add("haralick", "{levels: 32, offsets: [2, 0, 0, 2]}"));
}

}  // namespace
}  // namespace terramrf
