#include <gtest/gtest.h>

#include <cmath>

#include "plugin_harness.hpp"

namespace terramrf {

namespace {
// Ground at z = −1.7 + slope·x on a 0.1 m lattice over the 20 m grid, with a box raised by
// `box_h` over x ∈ [bx0, bx1), y ∈ [by0, by1) (a hedge: a flat top, no points under it).
void scene(test::StageHarness& h, double slope, double box_h, double bx0, double bx1, double by0,
           double by1) {
  for (double x = -10; x < 10; x += 0.1)
    for (double y = -10; y < 10; y += 0.1) {
      const double cx = x + 0.05, cy = y + 0.05;
      const bool box = cx >= bx0 && cx < bx1 && cy >= by0 && cy < by1;
      h.frame.points.push_back(float(cx), float(cy), float(-1.7 + slope * cx + (box ? box_h : 0.0)), 0);
    }
  h.bin();
}
}  // namespace

TEST(HeightAboveGround, HedgeTopIsItsHeightWhereNeighbourCellsCannotTell) {
  test::StageHarness h;
  // A 2 m wide, 0.3 m high hedge along x: inside it every neighbour of a cell is hedge too, so
  // comparing with neighbours (relative_height) sees nothing; the ground filter does.
  scene(h, 0.0, 0.3, -10, 10, 2.0, 4.0);
  h.make("height_above_ground", "{ground_layer: ground_z}")->process(h.ctx);
  h.make("relative_height", "{}")->process(h.ctx);
  EXPECT_NEAR(h.at("height_above_ground", 0.2, 3.2), 0.3, 1e-4);
  EXPECT_NEAR(h.at("relative_height", 0.2, 3.2), 0.0, 1e-4);
  EXPECT_NEAR(h.at("height_above_ground", 0.2, -3.2), 0.0, 1e-4);
  EXPECT_NEAR(h.at("ground_z", 0.2, 3.2), -1.7, 1e-4);
}

TEST(HeightAboveGround, SlopeWithinToleranceStaysGround) {
  test::StageHarness h;
  // 4 % ramp (under the 5 % default): every cell is ground; a cell's top is at most one cell's
  // rise (0.02 m) above the mean of its neighbours' lowest points.
  scene(h, 0.04, 0.0, 0, 0, 0, 0);
  auto stage = h.make("height_above_ground", "{}");
  stage->process(h.ctx);
  for (double x : {-8.2, -3.3, 0.2, 4.7, 8.8})
    for (double y : {-7.1, 0.3, 6.6}) {
      const float v = h.at("height_above_ground", x, y);
      EXPECT_GE(v, -1e-4) << x << "," << y;
      EXPECT_LE(v, 0.05) << x << "," << y;
    }
  // The same ramp with a tolerance of 0 reads the slope as obstacles on the uphill side.
  auto strict = h.make("height_above_ground", "{slope: 0.0, initial_threshold_m: 0.0}");
  strict->process(h.ctx);
  EXPECT_GT(h.at("height_above_ground", 8.8, 0.3), 0.1);
}

TEST(HeightAboveGround, ObjectWiderThanTheLargestWindowIsGround) {
  test::StageHarness h;
  // A 0.5 m plateau 10 m wide: wider than a 4 m window, so it is terrain to the filter.
  scene(h, 0.0, 0.5, -5, 5, -10, 10);
  h.make("height_above_ground", "{max_window_m: 4}")->process(h.ctx);
  EXPECT_NEAR(h.at("height_above_ground", 0.2, 0.2), 0.0, 1e-4);
  h.make("height_above_ground", "{max_window_m: 16}")->process(h.ctx);
  EXPECT_NEAR(h.at("height_above_ground", 0.2, 0.2), 0.5, 1e-4);
}

TEST(HeightAboveGround, EmptyCellsNaNAndBadThresholdsRejected) {
  test::StageHarness h;
  h.frame.points.push_back(1.2f, 1.2f, -1.7f, 0);
  h.bin();
  h.make("height_above_ground", "{}")->process(h.ctx);
  EXPECT_NEAR(h.at("height_above_ground", 1.2, 1.2), 0.0, 1e-6);
  EXPECT_TRUE(std::isnan(h.at("height_above_ground", -3.0, 4.0)));
  try {
    h.make("height_above_ground", "{initial_threshold_m: 0.5, max_threshold_m: 0.2}");
    FAIL() << "expected an error naming the parameter";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("max_threshold_m"), std::string::npos) << e.what();
  }
}

}  // namespace terramrf
