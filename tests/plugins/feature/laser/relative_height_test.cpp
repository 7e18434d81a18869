#include <gtest/gtest.h>

#include <cmath>

#include "plugin_harness.hpp"

namespace terramrf {

TEST(RelativeHeight, DitchFloorIsBelowItsSurroundings) {
  test::StageHarness h;
  // Flat ground at −1.7 m with a 1 m deep, one-cell-wide trench along x at y ∈ [2, 2.5).
  for (double x = -5; x < 5; x += 0.1)
    for (double y = -5; y < 5; y += 0.1) {
      const bool trench = y >= 2.0 && y < 2.5;
      h.frame.points.push_back(float(x + 0.05), float(y + 0.05), trench ? -2.7f : -1.7f, 0);
    }
  h.bin();
  h.make("relative_height", "{radius_cells: 2}")->process(h.ctx);
  EXPECT_NEAR(h.at("relative_height", 0.2, 2.2), -1.0, 1e-5);
  EXPECT_NEAR(h.at("relative_height", 0.2, -2.2), 0.0, 1e-5);
  // Next to the trench most neighbours are ground: the median stays at ground level.
  EXPECT_NEAR(h.at("relative_height", 0.2, 1.7), 0.0, 1e-5);
}

}  // namespace terramrf
