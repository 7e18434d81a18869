// OcclusionBuffer, camera_fusion's sparse z-buffer, against a brute-force one: at every pixel the
// nearest point within the splat's square (Chebyshev distance ≤ r) and its cell, for splats
// whose size is compiled in (r = 1, 2, 3) and read at run time, points at the image border
// included, with and without AVX2.
#include "occlusion_buffer.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <random>
#include <vector>

#include "test_support.hpp"

namespace terramrf {
namespace {

TEST(OcclusionBuffer, NearestPointOfEverySplatSquare) {
  const int width = 37, height = 23;
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> pixel(-1, width * height - 1), cell(-1, 40);
  std::uniform_real_distribution<float> depth(0.5f, 80.f);
  std::vector<int32_t> pix(300), cells(300);
  std::vector<float> z(300);
  for (std::size_t i = 0; i < pix.size(); ++i) pix[i] = pixel(rng), z[i] = depth(rng);
  for (std::size_t i = 0; i < pix.size(); ++i) cells[i] = cell(rng);
  // Corners and edges of the image, and two points at one pixel (the nearer must win).
  for (int p : {0, width - 1, (height - 1) * width, width * height - 1, 5, 3 * width})
    pix.push_back(p), z.push_back(depth(rng)), cells.push_back(cell(rng));
  pix.push_back(200), z.push_back(3.f), cells.push_back(7);
  pix.push_back(200), z.push_back(2.f), cells.push_back(8);
  for (const bool plain : {false, true})
    for (int r : {0, 1, 2, 3, 4, 6}) {
      test::ScopedEnv simd("TERRAMRF_SIMD", plain ? "sse2" : "auto");
      OcclusionBuffer buf;
      buf.build(width, height, r, pix, z, cells);
      for (int v = 0; v < height; ++v)
        for (int u = 0; u < width; ++u) {
          int best = -1;
          for (std::size_t i = 0; i < pix.size(); ++i) {
            if (pix[i] < 0) continue;
            if (std::abs(pix[i] % width - u) > r || std::abs(pix[i] / width - v) > r) continue;
            if (best < 0 || z[i] < z[best] ||
                (z[i] == z[best] && uint32_t(cells[i]) < uint32_t(cells[best])))
              best = int(i);
          }
          const uint32_t p = uint32_t(v * width + u);
          float d = -1;
          const std::string at = "r " + std::to_string(r) + " at " + std::to_string(u) + "," +
                                 std::to_string(v) + (plain ? " sse2" : "");
          if (best < 0) {
            EXPECT_FALSE(buf.occluder(p, -2, &d)) << at;
            continue;
          }
          ASSERT_TRUE(buf.occluder(p, -2, &d)) << at;
          EXPECT_EQ(d, z[best]) << at;
          EXPECT_FALSE(buf.occluder(p, cells[best], &d)) << at;  // the cell itself is nearest
        }
    }
}

}  // namespace
}  // namespace terramrf
