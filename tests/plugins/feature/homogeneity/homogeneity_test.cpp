// homogeneity: f_th = mean over the cell of Cheng & Sun's H = 1 − E·V (default), of 1 − V
// (definition: local_std) or of 1 / (1 + |I − mean3×3(I)| / s) (definition: local_mean), against
// values computed by hand.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "plugins/feature/camera_fusion/fusion_test_frame.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

using test::forwardCamera;
using test::groundFrame;
using test::setCellRect;
using test::StageRunner;

void grey(uint8_t* p, int g) { p[0] = p[1] = p[2] = uint8_t(g); }

const char* const kLocalMean = "{definition: local_mean}";
const char* const kImage = "{normalise: image}";  // Cheng & Sun as published

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

TEST(HomogeneityLocalMean, FlatPatchIsOne) {
  EXPECT_FLOAT_EQ(run(
                      kLocalMean, [](int, int, uint8_t* p) { grey(p, 140); }, 0, 200, 0, 100),
                  1.0f);
}

TEST(HomogeneityLocalMean, LinearShadingIsStillHomogeneous) {
  // The 3×3 mean of a linear ramp equals the centre value: gradual shading is not texture.
  auto ramp = [](int u, int v, uint8_t* p) { grey(p, u + v); };
  EXPECT_FLOAT_EQ(run(kLocalMean, ramp, 10, 50, 10, 50), 1.0f);
}

TEST(HomogeneityLocalMean, SingleBrightPixelByHand) {
  // Grey 90 at (100, 50) on black. Centre: mean3×3 = 10, |90 − 10| = 80 → 1/81; its 8
  // neighbours: mean3×3 = 10, |0 − 10| = 10 → 1/11. Cell = the 3×3 block.
  auto dot = [](int u, int v, uint8_t* p) { grey(p, u == 100 && v == 50 ? 90 : 0); };
  EXPECT_NEAR(run(kLocalMean, dot, 99, 102, 49, 52), (1.0 / 81 + 8.0 / 11) / 9, 1e-6);
  // contrast_scale 10: 1/(1 + 8) and 1/(1 + 1).
  EXPECT_NEAR(run("{definition: local_mean, contrast_scale: 10}", dot, 99, 102, 49, 52),
              (1.0 / 9 + 8.0 / 2) / 9, 1e-6);
  // The centre pixel alone.
  EXPECT_NEAR(run(kLocalMean, dot, 100, 101, 50, 51), 1.0 / 81, 1e-6);
}

TEST(HomogeneityLocalMean, NoiseIsLowerThanFlat) {
  std::mt19937 rng(42);
  std::vector<uint8_t> noise(200 * 100);
  for (auto& n : noise) n = uint8_t(100 + std::uniform_int_distribution<int>(-20, 20)(rng));
  auto fill = [&](int u, int v, uint8_t* p) { grey(p, noise[v * 200 + u]); };
  const float h = run(kLocalMean, fill, 20, 60, 20, 60);
  EXPECT_GT(h, 0.0f);
  EXPECT_LT(h, 0.2f);  // |I − mean| is ~10 grey levels for ±20 uniform noise
  // Weaker noise is more homogeneous.
  auto weak = [&](int u, int v, uint8_t* p) { grey(p, 100 + (noise[v * 200 + u] - 100) / 10); };
  const float hw = run(kLocalMean, weak, 20, 60, 20, 60);
  EXPECT_GT(hw, h);
  EXPECT_LT(hw, 1.0f);
}

// A vertical step: grey 0 left of column 100, 200 from it on. Sobel: |Gx| = (1 + 2 + 1)·200 = 800
// at columns 99 and 100 (one neighbour on each side of the step), 0 elsewhere. 5 × 5 standard
// deviation: 200·√(p(1 − p)), p the window's bright fraction: 2/5 at column 99, 3/5 at 100, so
// both reach the image maximum 200·√0.24; columns 98 and 101 have p = 1/5 and 4/5 (160) but no
// gradient. So H = 0 at columns 99–100 and 1 everywhere else.
void step(int u, int, uint8_t* p) { grey(p, u >= 100 ? 200 : 0); }

TEST(HomogeneityChengSun, StepEdgeByHand) {
  EXPECT_FLOAT_EQ(run(kImage, step, 99, 101, 10, 90), 0.0f);
  EXPECT_FLOAT_EQ(run(kImage, step, 98, 102, 10, 90), 0.5f);  // two of the four columns
  EXPECT_FLOAT_EQ(run(kImage, step, 101, 150, 10, 90), 1.0f);
  EXPECT_FLOAT_EQ(run(kImage, step, 0, 98, 10, 90), 1.0f);
  // normalise: fixed (the default) divides by 1020·√2 and 127.5 instead of the image's maxima.
  const double h_edge =
      1.0 - (800.0 / (1020.0 * std::sqrt(2.0))) * (200.0 * std::sqrt(0.24) / 127.5);
  EXPECT_NEAR(run("{normalise: fixed}", step, 99, 101, 10, 90), h_edge, 1e-6);
  EXPECT_NEAR(run("{normalise: fixed}", step, 98, 102, 10, 90), (h_edge + 1.0) / 2, 1e-6);
  EXPECT_NEAR(run("{}", step, 98, 102, 10, 90), (h_edge + 1.0) / 2, 1e-6);
  // A 3 × 3 window: p = 1/3 and 2/3 at columns 99 and 100, the same H there.
  EXPECT_FLOAT_EQ(run("{window: 3, normalise: image}", step, 99, 101, 10, 90), 0.0f);
  EXPECT_NEAR(run("{window: 3, normalise: fixed}", step, 99, 101, 10, 90),
              1.0 - (800.0 / (1020.0 * std::sqrt(2.0))) * (200.0 * std::sqrt(2.0 / 9) / 127.5),
              1e-6);
}

// local_std: the spread alone. On the step, the 5 × 5 standard deviation is 200·√(p(1 − p)): p =
// 1/5, 2/5, 3/5, 4/5 at columns 98–101 (80, 200·√0.24, 200·√0.24, 80), 0 elsewhere.
TEST(HomogeneityLocalStd, StepEdgeByHand) {
  const char* const image = "{definition: local_std, normalise: image}";
  const char* const fixed = "{definition: local_std}";  // normalise: fixed is the default
  const double v_edge = 200 * std::sqrt(0.24);
  EXPECT_FLOAT_EQ(run(image, step, 99, 101, 10, 90), 0.0f);
  EXPECT_NEAR(run(image, step, 98, 99, 10, 90), 1.0 - 80.0 / v_edge, 1e-6);
  EXPECT_NEAR(run(image, step, 101, 102, 10, 90), 1.0 - 80.0 / v_edge, 1e-6);
  EXPECT_FLOAT_EQ(run(image, step, 102, 150, 10, 90), 1.0f);
  EXPECT_FLOAT_EQ(run(image, step, 0, 98, 10, 90), 1.0f);
  EXPECT_NEAR(run(fixed, step, 99, 101, 10, 90), 1.0 - v_edge / 127.5, 1e-6);
  EXPECT_NEAR(run(fixed, step, 98, 99, 10, 90), 1.0 - 80.0 / 127.5, 1e-6);
  // Unlike Cheng & Sun's, columns 98 and 101 (spread, no gradient) are below 1: over the four
  // columns the mean is lower than 1 − E·V's 0.5 with the image's maxima.
  EXPECT_NEAR(run(image, step, 98, 102, 10, 90), (1.0 - 80.0 / v_edge) / 2, 1e-6);
  // 3 × 3: p = 1/3, 2/3 at columns 99 and 100 (200·√2/3), nothing at 98 and 101.
  EXPECT_NEAR(run("{definition: local_std, window: 3}", step, 99, 101, 10, 90),
              1.0 - 200 * std::sqrt(2.0) / 3 / 127.5, 1e-6);
  EXPECT_FLOAT_EQ(run("{definition: local_std, window: 3}", step, 101, 102, 10, 90), 1.0f);
}

TEST(HomogeneityLocalStd, FlatImageIsOneAndContrastInvariantPerImage) {
  for (int g : {0, 137, 255}) {
    auto flat = [g](int, int, uint8_t* p) { grey(p, g); };
    EXPECT_FLOAT_EQ(run("{definition: local_std, normalise: image}", flat, 0, 200, 0, 100), 1.0f)
        << g;
    EXPECT_FLOAT_EQ(run("{definition: local_std}", flat, 0, 200, 0, 100), 1.0f) << g;
  }
  auto board = [](int amp) {
    return [amp](int u, int v, uint8_t* p) {
      grey(p, u < 100 ? 100 + (((u / 4) + (v / 4)) % 2 ? amp : -amp) : 100);
    };
  };
  const char* const image = "{definition: local_std, normalise: image}";
  const float h = run(image, board(40), 20, 80, 20, 80);
  EXPECT_LT(h, 0.8f);
  EXPECT_NEAR(run(image, board(10), 20, 80, 20, 80), h, 1e-6);
  EXPECT_GT(run("{definition: local_std}", board(10), 20, 80, 20, 80),
            run("{definition: local_std}", board(40), 20, 80, 20, 80));
}

TEST(HomogeneityChengSun, FlatImageIsOne) {
  // No gradient and no spread anywhere: the image maxima are 0, and H is 1, not 0/0. Bright
  // grey checks that the standard deviation of a flat window is exactly 0.
  for (int g : {0, 137, 255}) {
    auto flat = [g](int, int, uint8_t* p) { grey(p, g); };
    EXPECT_FLOAT_EQ(run(kImage, flat, 0, 200, 0, 100), 1.0f) << g;
    EXPECT_FLOAT_EQ(run("{normalise: fixed}", flat, 0, 200, 0, 100), 1.0f) << g;
  }
}

TEST(HomogeneityChengSun, CheckerboardBelowFlatAndContrastInvariantPerImage) {
  // 4-pixel checks: texture everywhere, so H is well below 1 over a patch of it; beside it the
  // image is flat (H = 1 two pixels from the pattern).
  auto board = [](int amp) {
    return [amp](int u, int v, uint8_t* p) {
      grey(p, u < 100 ? 100 + (((u / 4) + (v / 4)) % 2 ? amp : -amp) : 100);
    };
  };
  const float h = run(kImage, board(40), 20, 80, 20, 80);
  EXPECT_LT(h, 0.8f);
  EXPECT_GE(h, 0.0f);
  EXPECT_FLOAT_EQ(run(kImage, board(40), 110, 200, 0, 100), 1.0f);
  // Scaling the contrast scales v and e and their image maxima alike: H is unchanged with
  // normalise: image, and higher for the weaker pattern with normalise: fixed.
  EXPECT_NEAR(run(kImage, board(10), 20, 80, 20, 80), h, 1e-6);
  const float hf40 = run("{normalise: fixed}", board(40), 20, 80, 20, 80);
  const float hf10 = run("{normalise: fixed}", board(10), 20, 80, 20, 80);
  EXPECT_GT(hf10, hf40);
  EXPECT_GT(hf40, h);
}

TEST(HomogeneityChengSun, MatchesDefinitionOnNoise) {
  // Brute force of the definition (reflect-101 border) on a random image, single pixels as
  // cells, for the default 5 × 5 window and the largest, 15 × 15 (sums near the int32 range),
  // with both normalisations.
  std::mt19937 rng(7);
  std::vector<uint8_t> img(200 * 100);
  for (auto& x : img) x = uint8_t(std::uniform_int_distribution<int>(0, 255)(rng));
  auto at = [&](int u, int v) {
    auto reflect = [](int i, int n) { return i < 0 ? -i : i >= n ? 2 * n - 2 - i : i; };
    return double(img[reflect(v, 100) * 200 + reflect(u, 200)]);
  };
  auto fill = [&](int u, int v, uint8_t* p) { grey(p, img[v * 200 + u]); };
  for (int r : {2, 7}) {
    std::vector<double> V(200 * 100), E(200 * 100);
    double vmax = 0, emax = 0;
    const double n = (2 * r + 1) * (2 * r + 1);
    for (int v = 0; v < 100; ++v)
      for (int u = 0; u < 200; ++u) {
        double s = 0, q = 0;
        for (int dv = -r; dv <= r; ++dv)
          for (int du = -r; du <= r; ++du) {
            const double x = at(u + du, v + dv);
            s += x, q += x * x;
          }
        V[v * 200 + u] = std::sqrt(std::max(0.0, q / n - (s / n) * (s / n)));
        const double gx = at(u + 1, v - 1) + 2 * at(u + 1, v) + at(u + 1, v + 1) -
                          at(u - 1, v - 1) - 2 * at(u - 1, v) - at(u - 1, v + 1);
        const double gy = at(u - 1, v + 1) + 2 * at(u, v + 1) + at(u + 1, v + 1) -
                          at(u - 1, v - 1) - 2 * at(u, v - 1) - at(u + 1, v - 1);
        E[v * 200 + u] = std::hypot(gx, gy);
        vmax = std::max(vmax, V[v * 200 + u]);
        emax = std::max(emax, E[v * 200 + u]);
      }
    const std::string w = "window: " + std::to_string(2 * r + 1);
    for (int u : {0, 1, 57, 198, 199})
      for (int v : {0, 50, 99}) {
        const double ev = E[v * 200 + u] * V[v * 200 + u];
        EXPECT_NEAR(run("{" + w + ", normalise: image}", fill, u, u + 1, v, v + 1),
                    1 - ev / (emax * vmax), 1e-5)
            << w << " at " << u << "," << v;
        EXPECT_NEAR(run("{" + w + ", normalise: fixed}", fill, u, u + 1, v, v + 1),
                    1 - ev / (1020 * std::sqrt(2.0) * 127.5), 1e-5)
            << w << " at " << u << "," << v;
        // local_std, the spread alone.
        EXPECT_NEAR(
            run("{definition: local_std, " + w + ", normalise: image}", fill, u, u + 1, v, v + 1),
            1 - V[v * 200 + u] / vmax, 1e-5)
            << w << " at " << u << "," << v;
        EXPECT_NEAR(run("{definition: local_std, " + w + "}", fill, u, u + 1, v, v + 1),
                    1 - V[v * 200 + u] / 127.5, 1e-5)
            << w << " at " << u << "," << v;
      }
  }
}

// With fixed bounds H is computed by a plain and, where the CPU has it, an AVX2 loop: the same
// bits at every pixel, inside and at the border, for the smallest and largest windows.
TEST(HomogeneityChengSun, SameBitsOnEveryInstructionSet) {
  std::mt19937 rng(11);
  std::vector<uint8_t> img(200 * 100);
  for (auto& x : img) x = uint8_t(std::uniform_int_distribution<int>(0, 255)(rng));
  auto fill = [&](int u, int v, uint8_t* p) { grey(p, img[v * 200 + u]); };
  test::widePathRuns();
  for (const char* w : {"{window: 3}", "{window: 15}"})
    for (int u : {0, 3, 57, 120, 199})
      for (int v : {0, 1, 50, 98, 99}) {
        const float wide = run(w, fill, u, u + 1, v, v + 1);
        test::ScopedEnv sse2("TERRAMRF_SIMD", "sse2");
        EXPECT_EQ(run(w, fill, u, u + 1, v, v + 1), wide) << w << " at " << u << "," << v;
      }
}

TEST(HomogeneityBadInput, EvenWindow) {
  StageRunner r;
  try {
    r.add("homogeneity", "{window: 4}");
    Frame f = groundFrame(forwardCamera(), step);
    r.prepare(f);
    FAIL() << "expected an error for an even window";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("window"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("odd"), std::string::npos) << e.what();
  }
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
