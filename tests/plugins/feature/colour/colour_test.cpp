// colour: mean colour per cell in RGB, HSV (circular hue) and CIE Lab, against known values.
#include <gtest/gtest.h>

#include <cmath>

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
