#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "plugin_harness.hpp"

namespace terramrf {

namespace {
// One ring on flat ground around the sensor: points at range r with per-point range offsets.
void addRing(PointCloud& pc, uint16_t ring, double r, int n, const std::vector<double>& dr) {
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    const double rr = r + dr[i % dr.size()];
    pc.push_back(float(rr * std::cos(a)), float(rr * std::sin(a)), -1.7f, 0, ring);
  }
}
}  // namespace

TEST(Roughness, SmoothRingIsZeroAndAlternatingRingKnown) {
  test::StageHarness h;
  addRing(h.frame.points, 10, 5.0, 2000, {0.0});
  // Alternating ±2 cm along the ring: with window 1 the residual is ±(2 − (−2)) = ±4 cm.
  addRing(h.frame.points, 20, 8.0, 2000, {0.02, -0.02});
  h.bin();
  h.make("roughness", "{window: 1}")->process(h.ctx);
  EXPECT_LT(h.at("roughness", 4.9, 0.05), 1e-4);
  EXPECT_NEAR(h.at("roughness", 7.9, 0.05), 0.04, 1e-3);
  EXPECT_TRUE(std::isnan(h.at("roughness", 2.0, 2.0)));
}

TEST(Roughness, EdgesAreNotRoughness) {
  test::StageHarness h;
  // A range jump of 3 m (an object edge) inside a ring: beyond max_jump_m, so ignored.
  std::vector<double> dr(2000, 0.0);
  for (int i = 0; i < 1000; ++i) dr[i] = 3.0;
  addRing(h.frame.points, 5, 6.0, 2000, dr);
  h.bin();
  h.make("roughness", "{window: 2, max_jump_m: 0.5}")->process(h.ctx);
  const auto& l = h.grid.layer("roughness");
  for (float v : l)
    if (!std::isnan(v)) EXPECT_LT(v, 1e-4);
}

TEST(Roughness, WithoutRingsIsAnInputError) {
  test::StageHarness h;
  h.frame.source_path = "scan.bin";
  h.frame.points.x = {1.f};
  h.frame.points.y = {1.f};
  h.frame.points.z = {1.f};
  h.frame.points.intensity = {0.f};
  h.bin();
  try {
    h.make("roughness")->process(h.ctx);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("scan.bin"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("ring"), std::string::npos);
  }
}

}  // namespace terramrf
