#include <gtest/gtest.h>

#include <cmath>

#include "plugin_harness.hpp"

namespace terramrf {

TEST(HeightDifference, StepGivesItsHeightAndEmptyCellsNaN) {
  test::StageHarness h;
  // A 0.3 m step inside one cell, flat points in another.
  h.frame.points.push_back(1.1f, 1.1f, -1.7f, 0);
  h.frame.points.push_back(1.2f, 1.2f, -1.4f, 0);
  h.frame.points.push_back(1.3f, 1.1f, -1.55f, 0);
  h.frame.points.push_back(3.1f, 3.1f, -1.7f, 0);
  h.frame.points.push_back(3.2f, 3.3f, -1.7f, 0);
  h.bin();
  h.make("height_difference")->process(h.ctx);
  EXPECT_FLOAT_EQ(h.at("height_diff", 1.1, 1.1), 0.3f);
  EXPECT_FLOAT_EQ(h.at("height_diff", 3.1, 3.1), 0.f);
  EXPECT_TRUE(std::isnan(h.at("height_diff", -5, -5)));
}

TEST(HeightDifference, MinPointsAndLayerName) {
  test::StageHarness h;
  h.frame.points.push_back(1.1f, 1.1f, -1.7f, 0);
  h.frame.points.push_back(1.2f, 1.2f, -1.0f, 0);
  h.bin();
  h.make("height_difference", "{min_points: 3, layer: hd}")->process(h.ctx);
  EXPECT_TRUE(std::isnan(h.at("hd", 1.1, 1.1)));
}

}  // namespace terramrf
