// colour: mean colour per cell in RGB, HSV (circular hue) and CIE Lab, against known values.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/imgproc.hpp>
#include <random>

#include "hsv.hpp"
#include "plugins/feature/camera_fusion/fusion_test_frame.hpp"

namespace terramrf {
namespace {

using test::forwardCamera;
using test::groundFrame;
using test::setCellRect;
using test::StageRunner;

struct Mean {
  float c[3];
};

template <class Fill>
Mean run(const std::string& space, Fill fill, int u0, int u1, int v0, int v1) {
  Frame f = groundFrame(forwardCamera(), fill);
  StageRunner r;
  r.add("colour", "{space: " + space + "}");
  r.prepare(f);
  setCellRect(r.grid, 200, 100, 0, u0, u1, v0, v1);
  r.process();
  Mean m;
  for (int i = 0; i < 3; ++i) {
    const std::string name =
        std::string("colour_") + (space == "lab" ? "lab_" : "") + std::string(1, space[i]);
    const Layer& l = r.grid.layer(name);
    m.c[i] = l[0];
    for (std::size_t c = 1; c < r.grid.cells(); ++c) EXPECT_TRUE(std::isnan(l[c])) << name;
  }
  return m;
}

void rgb(uint8_t* p, int r, int g, int b) {
  p[0] = uint8_t(r), p[1] = uint8_t(g), p[2] = uint8_t(b);
}
auto flat = [](int, int, uint8_t* p) { rgb(p, 200, 100, 50); };

TEST(Colour, FlatRgbIsExact) {
  const Mean m = run("rgb", flat, 0, 200, 0, 100);
  EXPECT_EQ(m.c[0], 200.0f);
  EXPECT_EQ(m.c[1], 100.0f);
  EXPECT_EQ(m.c[2], 50.0f);
}

TEST(Colour, FlatHsvByHand) {
  // max = R = 200, min = 50: V = 200/255, S = 150/200, H = 60° · (G − B)/(max − min) = 20°.
  const Mean m = run("hsv", flat, 10, 20, 10, 20);
  EXPECT_NEAR(m.c[0], 20.0, 1e-3);
  EXPECT_NEAR(m.c[1], 0.75, 1e-6);
  EXPECT_NEAR(m.c[2], 200.0 / 255, 1e-6);
}

TEST(Colour, FlatLabMatchesCie) {
  // sRGB → XYZ (D65) → L*a*b*: (200, 100, 50) = (53.63, 36.31, 45.38); (255, 0, 0) =
  // (53.24, 80.09, 67.20). OpenCV's float conversion interpolates in a 3-D table, which is
  // good to ~0.1 (measured 53.52 for the first L*).
  const Mean m = run("lab", flat, 10, 20, 10, 20);
  EXPECT_NEAR(m.c[0], 53.63, 0.25);
  EXPECT_NEAR(m.c[1], 36.31, 0.25);
  EXPECT_NEAR(m.c[2], 45.38, 0.25);
  const Mean red = run(
      "lab", [](int, int, uint8_t* p) { rgb(p, 255, 0, 0); }, 10, 20, 10, 20);
  EXPECT_NEAR(red.c[0], 53.24, 0.1);
  EXPECT_NEAR(red.c[1], 80.09, 0.1);
  EXPECT_NEAR(red.c[2], 67.20, 0.1);
}

TEST(Colour, MeanOfTwoColours) {
  auto halves = [](int u, int, uint8_t* p) { u < 15 ? rgb(p, 0, 0, 0) : rgb(p, 255, 255, 255); };
  const Mean m = run("rgb", halves, 10, 20, 0, 10);
  for (float c : m.c) EXPECT_FLOAT_EQ(c, 127.5f);
}

TEST(Colour, HueIsAveragedOnTheCircle) {
  // Hues 348° (255, 0, 51) and 12° (255, 51, 0), both S = V = 1: the mean is 0°, not 180°.
  auto two = [](int u, int, uint8_t* p) { u % 2 ? rgb(p, 255, 0, 51) : rgb(p, 255, 51, 0); };
  const Mean m = run("hsv", two, 10, 20, 10, 20);
  EXPECT_LT(std::min(m.c[0], 360.0f - m.c[0]), 1e-3) << m.c[0];
  EXPECT_GE(m.c[0], 0.0f);
  EXPECT_LT(m.c[0], 360.0f);
  EXPECT_NEAR(m.c[1], 1.0, 1e-6);
  EXPECT_NEAR(m.c[2], 1.0, 1e-6);
  // Grey pixels carry no hue: adding them does not move the mean hue (20°).
  auto mixed = [](int u, int, uint8_t* p) { u % 2 ? rgb(p, 200, 100, 50) : rgb(p, 90, 90, 90); };
  EXPECT_NEAR(run("hsv", mixed, 10, 20, 10, 20).c[0], 20.0, 1e-3);
}

TEST(Colour, GreyCellHasNoHue) {
  const Mean m = run(
      "hsv", [](int, int, uint8_t* p) { rgb(p, 90, 90, 90); }, 10, 20, 10, 20);
  EXPECT_TRUE(std::isnan(m.c[0]));
  EXPECT_FLOAT_EQ(m.c[1], 0.0f);
  EXPECT_NEAR(m.c[2], 90.0 / 255, 1e-6);
}

// ---- HSV of one pixel (hsv.hpp) ---------------------------------------------------------------

struct Hsv {
  float h, s, v;
};
Hsv hsvOf(float r, float g, float b) {
  Hsv o;
  colour::rgbToHsv(r, g, b, o.h, o.s, o.v);
  return o;
}

TEST(ColourHsv, KnownColours) {
  const float one = 1.f / (1.f + FLT_EPSILON);  // S of a saturated colour: d / (V + ε)
  struct Case {
    float r, g, b, h, s, v;
  } cases[] = {
      {1, 0, 0, 0, one, 1},            // red
      {0, 1, 0, 120, one, 1},          // green
      {0, 0, 1, 240, one, 1},          // blue
      {1, 1, 0, 60, one, 1},           // yellow: R = G = max counts as R
      {0, 1, 1, 180, one, 1},          // cyan
      {1, 0, 1, 300, one, 1},          // magenta: −60° wraps to 300°
      {0.5f, 0.5f, 0.5f, 0, 0, 0.5f},  // grey: no hue, no saturation
      {1, 1, 1, 0, 0, 1},              // white
      {0, 0, 0, 0, 0, 0},              // black
      {1, 0, 0.2f, 348, one, 1},       // hue −12° wraps to 348°
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(::testing::Message() << "rgb " << c.r << " " << c.g << " " << c.b);
    const Hsv o = hsvOf(c.r, c.g, c.b);
    EXPECT_NEAR(o.h, c.h, 1e-4);
    EXPECT_FLOAT_EQ(o.s, c.s);
    EXPECT_EQ(o.v, c.v);
  }
  EXPECT_FLOAT_EQ(hsvOf(200 / 255.f, 100 / 255.f, 50 / 255.f).h, 20.f);
  // A hue a hair below 0° is 360° − 6e-8, which single precision rounds to 360: that is 0°.
  const Hsv wrap = hsvOf(1, 0, 1e-9f);
  EXPECT_EQ(wrap.h, 0.f);
}

// The same definition as OpenCV's float RGB2HSV (whichever of its kernels runs): within 1e-4.
TEST(ColourHsv, AgreesWithCvtColor) {
  std::vector<float> rgb;
  for (int r = 0; r < 256; r += 5)
    for (int g = 0; g < 256; g += 5)
      for (int b = 0; b < 256; b += 5) rgb.insert(rgb.end(), {r / 255.f, g / 255.f, b / 255.f});
  std::mt19937 gen(5);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  for (int i = 0; i < 100000; ++i) rgb.insert(rgb.end(), {u(gen), u(gen), u(gen)});
  const int n = int(rgb.size() / 3);
  cv::Mat in(1, n, CV_32FC3, rgb.data()), out;
  cv::cvtColor(in, out, cv::COLOR_RGB2HSV);
  const float* cv = out.ptr<float>();
  for (int i = 0; i < n; ++i) {
    const Hsv o = hsvOf(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]);
    const double dh = std::fabs(double(o.h) - cv[3 * i]);
    ASSERT_LT(std::min(dh, 360.0 - dh), 1e-4) << i << ": " << o.h << " vs " << cv[3 * i];
    ASSERT_NEAR(o.s, cv[3 * i + 1], 1e-4) << i;
    ASSERT_NEAR(o.v, cv[3 * i + 2], 1e-4) << i;
    ASSERT_GE(o.h, 0.f);
    ASSERT_LT(o.h, 360.f);
  }
}

// cv::cvtColor chose its kernel at run time: with AVX2 (fused multiply-adds) the hue of many
// pixels differed in the last bits from the SSE kernel's, so colour_h changed with the CPU (about
// 110 cells per simulator frame). The test runs this binary twice, with OpenCV's AVX2 kernels
// allowed and disabled (OPENCV_CPU_DISABLE=AVX2), and compares the layers bit by bit.
const char* kHuesOut = "TERRAMRF_TEST_COLOUR_HUES_OUT";

void writeHsvLayers(const std::string& path) {
  // 6400 cells of 0.1 m with two pixels each, of colours from a fixed generator.
  GridGeometry geom = test::forwardGrid();
  geom.cell_m = 0.1;
  std::mt19937 gen(11);
  Frame f = groundFrame(forwardCamera(), [&](int, int, uint8_t* p) {
    for (int i = 0; i < 3; ++i) p[i] = uint8_t(gen() >> 24);
  });
  StageRunner r(geom);
  r.add("colour", "{space: hsv}");
  r.prepare(f);
  CellPixels cp;
  cp.camera = 0;
  cp.width = 200;
  cp.height = 100;
  for (std::size_t c = 0; c < r.grid.cells(); ++c) {
    cp.offsets.push_back(uint32_t(cp.pixels.size()));
    cp.pixels.push_back(uint32_t(2 * c)), cp.pixels.push_back(uint32_t(2 * c + 1));
  }
  cp.offsets.push_back(uint32_t(cp.pixels.size()));
  r.grid.cellPixels().clear();
  r.grid.cellPixels().push_back(cp);
  r.process();
  std::ofstream out(path, std::ios::binary);
  for (const char* name : {"colour_h", "colour_s", "colour_v"}) {
    const Layer& l = r.grid.layer(name);
    for (std::size_t c = 0; c < r.grid.cells(); ++c)
      out.write(reinterpret_cast<const char*>(&l[c]), sizeof(float));
  }
}

TEST(ColourHsv, TheSameBitsWithOrWithoutOpenCvsAvx2Kernels) {
  if (const char* out = std::getenv(kHuesOut)) {  // the child: write the layers
    writeHsvLayers(out);
    return;
  }
  if (!__builtin_cpu_supports("avx2"))
    GTEST_SKIP() << "this CPU has no AVX2: OpenCV's kernels cannot differ here";
  test::TempDir dir;
  const std::string self = std::filesystem::read_symlink("/proc/self/exe").string();
  auto runChild = [&](const std::string& env, const std::string& file) {
    const std::string cmd = env + " " + kHuesOut + "='" + dir.str() + "/" + file + "' '" + self +
                            "' --gtest_filter=ColourHsv.TheSameBitsWithOrWithoutOpenCvsAvx2Kernels"
                            " > /dev/null 2>&1";
    EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
    std::ifstream in(dir.str() + "/" + file, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string with = runChild("env -u OPENCV_CPU_DISABLE", "avx2.bin");
  const std::string without = runChild("env OPENCV_CPU_DISABLE=AVX2", "no_avx2.bin");
  ASSERT_EQ(with.size(), 3 * 6400 * sizeof(float));
  std::size_t differ = 0;
  for (std::size_t i = 0; i + 4 <= with.size(); i += 4)
    differ += with.compare(i, 4, without, i, 4) != 0;
  EXPECT_EQ(differ, 0u) << "cells whose h, s or v differ";
}

TEST(ColourBadInput, GreyImage) {
  Frame f = groundFrame(
      forwardCamera(), [](int, int, uint8_t* p) { p[0] = 3; }, 1);
  StageRunner r;
  r.add("colour");
  r.prepare(f);
  setCellRect(r.grid, 200, 100, 0, 0, 10, 0, 10);
  try {
    r.process();
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "/data/front/000007.png");
    EXPECT_NE(std::string(e.what()).find("3-channel"), std::string::npos) << e.what();
  }
}

TEST(ColourParams, LayerNamesFollowSpaceAndPrefix) {
  StageRunner r;
  auto& lab = r.add("colour", "{space: lab, prefix: cam}");
  EXPECT_EQ(lab.writes(), (std::vector<std::string>{"cam_lab_l", "cam_lab_a", "cam_lab_b"}));
  auto& rgb = r.add("colour", "{space: rgb}");
  EXPECT_EQ(rgb.writes(), (std::vector<std::string>{"colour_r", "colour_g", "colour_b"}));
  auto& hsv = r.add("colour", "{space: hsv}");
  EXPECT_EQ(hsv.writes(), (std::vector<std::string>{"colour_h", "colour_s", "colour_v"}));
  EXPECT_THROW(r.add("colour", "{space: yuv}"), std::runtime_error);
}

}  // namespace
}  // namespace terramrf
