#include <gtest/gtest.h>

#include <cmath>

#include "plugin_harness.hpp"

namespace terramrf {

TEST(Intensity, MeanAndStdOfEachCellAndEmptyCellsNaN) {
  test::StageHarness h;
  // Asphalt-like cell (0.1, 0.3: mean 0.2, std 0.1), a paint-like cell of one bright return.
  h.frame.points.push_back(1.1f, 1.1f, -1.7f, 0.1f);
  h.frame.points.push_back(1.2f, 1.2f, -1.7f, 0.3f);
  h.frame.points.push_back(3.1f, 3.1f, -1.7f, 0.9f);
  h.bin();
  h.make("intensity", "{std_layer: intensity_std}")->process(h.ctx);
  EXPECT_NEAR(h.at("intensity", 1.1, 1.1), 0.2f, 1e-6);
  EXPECT_NEAR(h.at("intensity_std", 1.1, 1.1), 0.1f, 1e-6);
  EXPECT_FLOAT_EQ(h.at("intensity", 3.1, 3.1), 0.9f);
  EXPECT_FLOAT_EQ(h.at("intensity_std", 3.1, 3.1), 0.f);
  EXPECT_TRUE(std::isnan(h.at("intensity", -5, -5)));
  EXPECT_EQ(h.ctx.metrics.at("intensity.recorded"), 1.0);
}

TEST(Intensity, AllZeroIntensityIsNotRecordedAndLeavesNaN) {
  // The Open3D-ML SemanticKITTI scans store no intensity; their converted .bin files hold zeros.
  test::StageHarness h;
  h.frame.points.push_back(1.1f, 1.1f, -1.7f, 0.f);
  h.frame.points.push_back(1.2f, 1.2f, -1.7f, 0.f);
  h.bin();
  h.make("intensity", "{std_layer: isd}")->process(h.ctx);
  EXPECT_TRUE(std::isnan(h.at("intensity", 1.1, 1.1)));
  EXPECT_TRUE(std::isnan(h.at("isd", 1.1, 1.1)));
  EXPECT_EQ(h.ctx.metrics.at("intensity.recorded"), 0.0);
}

TEST(Intensity, MinPointsAndNoStdLayerUnlessAsked) {
  test::StageHarness h;
  h.frame.points.push_back(1.1f, 1.1f, -1.7f, 0.4f);
  h.frame.points.push_back(1.2f, 1.2f, -1.7f, 0.6f);
  h.frame.points.push_back(3.1f, 3.1f, -1.7f, 0.9f);
  h.bin();
  h.make("intensity", "{min_points: 2, layer: refl}")->process(h.ctx);
  EXPECT_FLOAT_EQ(h.at("refl", 1.1, 1.1), 0.5f);
  EXPECT_TRUE(std::isnan(h.at("refl", 3.1, 3.1)));
  EXPECT_FALSE(h.ctx.grid->has("intensity_std"));
}

TEST(Intensity, StdLayerNamedLikeTheMeanIsRejected) {
  test::StageHarness h;
  try {
    h.make("intensity", "{std_layer: intensity}");
    FAIL() << "expected a ParamError";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("std_layer"), std::string::npos) << e.what();
  }
}

}  // namespace terramrf
