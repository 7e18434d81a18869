#include <gtest/gtest.h>

#include <cmath>

#include "plugin_harness.hpp"

namespace terramrf {

TEST(LogTransform, KnownValuesNaNAndNegativeInputs) {
  test::StageHarness h;
  h.bin();
  Layer& in = h.grid.add("roughness");
  in[0] = 0.f;     // log(offset)
  in[1] = 0.009f;  // log(0.01)
  in[2] = -0.5f;   // below zero counts as zero
  in[3] = 1.999f;  // log(2)
  h.make("log_transform", "{input: roughness, offset: 0.001}")->process(h.ctx);
  const Layer& out = h.grid.layer("log_roughness");
  EXPECT_FLOAT_EQ(out[0], std::log(0.001f));
  EXPECT_NEAR(out[1], std::log(0.01), 1e-6);
  EXPECT_FLOAT_EQ(out[2], std::log(0.001f));
  EXPECT_NEAR(out[3], std::log(2.0), 1e-6);
  EXPECT_TRUE(std::isnan(out[4]));  // no data stays no data
  EXPECT_EQ(h.grid.cells(), out.size());
}

TEST(LogTransform, LayerNameAndDeclaredReadsWrites) {
  test::StageHarness h;
  h.bin();
  h.grid.add("height_diff")[7] = std::exp(1.f) - 0.5f;
  auto s = h.make("log_transform", "{input: height_diff, layer: lhd, offset: 0.5}");
  EXPECT_EQ(s->reads(), std::vector<std::string>{"height_diff"});
  EXPECT_EQ(s->writes(), std::vector<std::string>{"lhd"});
  s->process(h.ctx);
  EXPECT_NEAR(h.grid.layer("lhd")[7], 1.0, 1e-6);
  EXPECT_FALSE(h.grid.has("log_height_diff"));
}

TEST(LogTransform, RejectsRewritingItsInputAndANonPositiveOffset) {
  test::StageHarness h;
  for (const char* params :
       {"{input: roughness, layer: roughness}", "{input: roughness, offset: 0}"}) {
    try {
      h.make("log_transform", params);
      ADD_FAILURE() << "accepted " << params;
    } catch (const std::exception& e) {
      const std::string what = e.what();
      EXPECT_TRUE(what.find("layer") != std::string::npos ||
                  what.find("offset") != std::string::npos)
          << what;
    }
  }
}

}  // namespace terramrf
