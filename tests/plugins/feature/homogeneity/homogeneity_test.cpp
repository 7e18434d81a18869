// homogeneity: f_th = mean over the cell of 1 / (1 + |I − mean3×3(I)| / s), against values
// computed by hand.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "plugins/feature/camera_fusion/fusion_test_frame.hpp"

namespace terramrf {
namespace {

using test::forwardCamera;
using test::groundFrame;
using test::setCellRect;
using test::StageRunner;

void grey(uint8_t* p, int g) { p[0] = p[1] = p[2] = uint8_t(g); }

template <class Fill>
float run(const std::string& params, Fill fill, int u0, int u1, int v0, int v1) {
  Frame f = groundFrame(forwardCamera(), fill);
  StageRunner r;
  r.add("homogeneity", params);
  r.prepare(f);
  setCellRect(r.grid, 200, 100, 0, u0, u1, v0, v1);
  r.process();
  for (std::size_t c = 1; c < r.grid.cells(); ++c)
    EXPECT_TRUE(std::isnan(r.grid.layer("homogeneity")[c]));
  return r.grid.layer("homogeneity")[0];
}

TEST(Homogeneity, FlatPatchIsOne) {
  EXPECT_FLOAT_EQ(run(
                      "{}", [](int, int, uint8_t* p) { grey(p, 140); }, 0, 200, 0, 100),
                  1.0f);
}

TEST(Homogeneity, LinearShadingIsStillHomogeneous) {
  // The 3×3 mean of a linear ramp equals the centre value: gradual shading is not texture.
  auto ramp = [](int u, int v, uint8_t* p) { grey(p, u + v); };
  EXPECT_FLOAT_EQ(run("{}", ramp, 10, 50, 10, 50), 1.0f);
}

TEST(Homogeneity, SingleBrightPixelByHand) {
  // Grey 90 at (100, 50) on black. Centre: mean3×3 = 10, |90 − 10| = 80 → 1/81; its 8
  // neighbours: mean3×3 = 10, |0 − 10| = 10 → 1/11. Cell = the 3×3 block.
  auto dot = [](int u, int v, uint8_t* p) { grey(p, u == 100 && v == 50 ? 90 : 0); };
  EXPECT_NEAR(run("{}", dot, 99, 102, 49, 52), (1.0 / 81 + 8.0 / 11) / 9, 1e-6);
  // contrast_scale 10: 1/(1 + 8) and 1/(1 + 1).
  EXPECT_NEAR(run("{contrast_scale: 10}", dot, 99, 102, 49, 52), (1.0 / 9 + 8.0 / 2) / 9, 1e-6);
  // The centre pixel alone.
  EXPECT_NEAR(run("{}", dot, 100, 101, 50, 51), 1.0 / 81, 1e-6);
}

TEST(Homogeneity, NoiseIsLowerThanFlat) {
  std::mt19937 rng(42);
  std::vector<uint8_t> noise(200 * 100);
  for (auto& n : noise) n = uint8_t(100 + std::uniform_int_distribution<int>(-20, 20)(rng));
  auto fill = [&](int u, int v, uint8_t* p) { grey(p, noise[v * 200 + u]); };
  const float h = run("{}", fill, 20, 60, 20, 60);
  EXPECT_GT(h, 0.0f);
  EXPECT_LT(h, 0.2f);  // |I − mean| is ~10 grey levels for ±20 uniform noise
  // Weaker noise is more homogeneous.
  auto weak = [&](int u, int v, uint8_t* p) { grey(p, 100 + (noise[v * 200 + u] - 100) / 10); };
  const float hw = run("{}", weak, 20, 60, 20, 60);
  EXPECT_GT(hw, h);
  EXPECT_LT(hw, 1.0f);
}

TEST(Homogeneity, MinPixels) {
  auto flat = [](int, int, uint8_t* p) { grey(p, 1); };
  EXPECT_TRUE(std::isnan(run("{min_pixels: 10}", flat, 0, 3, 0, 3)));
  EXPECT_FLOAT_EQ(run("{min_pixels: 9}", flat, 0, 3, 0, 3), 1.0f);
}

TEST(HomogeneityBadInput, NoFusedPixels) {
  Frame f = groundFrame(forwardCamera(), [](int, int, uint8_t* p) { grey(p, 1); });
  StageRunner r;
  r.add("homogeneity");
  try {
    r.run(f);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), f.source_path);
  }
}

}  // namespace
}  // namespace terramrf
