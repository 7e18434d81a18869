// ChengSunMap, the one-pass kernel of the homogeneity feature: its integers must be exactly the
// ones OpenCV's box filters and 3 × 3 Sobel give with BORDER_REFLECT_101 (which the feature was
// first built on), on every window, on images smaller than the window, on both instruction sets;
// and the running column sums of a band of rows must give what each row computed alone gives.
#include "cheng_sun_map.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>
#include <stdexcept>

#include "terramrf/simd.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {

cv::Mat randomGrey(int rows, int cols, unsigned seed) {
  std::mt19937 rng(seed);
  cv::Mat m(rows, cols, CV_8U);
  std::uniform_int_distribution<int> grey(0, 255), coin(0, 3);
  for (int v = 0; v < rows; ++v)
    for (int u = 0; u < cols; ++u)  // some flat runs and extremes, not only noise
      m.at<uint8_t>(v, u) = uint8_t(coin(rng) == 0 ? (u / 3) % 2 * 255 : grey(rng));
  return m;
}

void expectSameAsOpenCv(int rows, int cols, int window, unsigned seed) {
  const cv::Mat img = randomGrey(rows, cols, seed);
  cv::Mat sum, sqsum, gx, gy;
  const cv::Size win(window, window);
  cv::boxFilter(img, sum, CV_32S, win, cv::Point(-1, -1), false, cv::BORDER_REFLECT_101);
  cv::sqrBoxFilter(img, sqsum, CV_32S, win, cv::Point(-1, -1), false, cv::BORDER_REFLECT_101);
  cv::Sobel(img, gx, CV_16S, 1, 0, 3, 1, 0, cv::BORDER_REFLECT_101);
  cv::Sobel(img, gy, CV_16S, 0, 1, 3, 1, 0, cv::BORDER_REFLECT_101);
  // spatialGradient (the feature's filter before this kernel) is the same 3 × 3 Sobel.
  cv::Mat sx, sy;
  cv::spatialGradient(img, sx, sy, 3, cv::BORDER_REFLECT_101);
  EXPECT_EQ(cv::countNonZero(sx != gx), 0) << rows << "x" << cols;
  EXPECT_EQ(cv::countNonZero(sy != gy), 0) << rows << "x" << cols;
  const uint32_t area = uint32_t(window * window);
  ChengSunMap map;
  for (int v = 0; v < rows; ++v) {
    const uint32_t *e2, *v2;
    map.rowProducts(img.ptr<uint8_t>(0), rows, cols, window, v, &e2, &v2);
    for (int u = 0; u < cols; ++u) {
      const uint32_t s1 = uint32_t(sum.at<int32_t>(v, u)), s2 = uint32_t(sqsum.at<int32_t>(v, u));
      const int32_t x = gx.at<int16_t>(v, u), y = gy.at<int16_t>(v, u);
      ASSERT_EQ(v2[u], area * s2 - s1 * s1)
          << rows << "x" << cols << " window " << window << " at " << u << "," << v;
      ASSERT_EQ(e2[u], uint32_t(x * x + y * y))
          << rows << "x" << cols << " window " << window << " at " << u << "," << v;
    }
  }
}

TEST(ChengSunMap, SameIntegersAsOpenCvFilters) {
  const int sizes[][2] = {{1, 1}, {1, 9}, {9, 1}, {2, 3}, {4, 2}, {5, 5}, {16, 17}, {23, 70}};
  for (const bool plain : {false, true}) {
    test::ScopedEnv simd("TERRAMRF_SIMD", plain ? "sse2" : "auto");
    unsigned seed = 1;
    for (const auto& s : sizes)
      for (int window = 3; window <= 15; window += 2) {
        SCOPED_TRACE(plain ? "sse2" : "best instruction set");
        expectSameAsOpenCv(s[0], s[1], window, seed++);
      }
  }
}

// The running column sums (one row in, one out) against each row summed afresh, over a band that
// starts inside the image and over one that starts at its top edge, for H with fixed bounds and
// with the image's maxima; and the same bits with and without AVX2.
TEST(ChengSunMap, BandOfRowsMatchesRowsAlone) {
  const int rows = 40, cols = 53;
  const cv::Mat img = randomGrey(rows, cols, 99);
  const uint8_t* grey = img.ptr<uint8_t>(0);
  for (const int window : {3, 5, 15})
    for (const auto [r0, r1] : {std::pair{0, rows}, std::pair{7, 31}, std::pair{38, 40}}) {
      const float k = 1e-6f;
      std::vector<float> fixed(std::size_t(r1 - r0) * cols), image(fixed.size());
      ChengSunMap map;
      map.fixed(grey, rows, cols, window, r0, r1, k, fixed.data());
      uint32_t e2_max = 0, v2_max = 0;
      map.maxima(grey, rows, cols, window, r0, r1, &e2_max, &v2_max);
      const float ev_max = std::sqrt(float(e2_max) * float(v2_max));
      map.image(grey, rows, cols, window, r0, r1, ev_max, image.data());
      uint32_t e_seen = 0, v_seen = 0;
      ChengSunMap alone;
      for (int r = r0; r < r1; ++r) {
        const uint32_t *e2, *v2;
        alone.rowProducts(grey, rows, cols, window, r, &e2, &v2);
        for (int u = 0; u < cols; ++u) {
          const float p = float(e2[u]) * float(v2[u]);
          const std::size_t i = std::size_t(r - r0) * cols + u;
          ASSERT_EQ(fixed[i], 1.0f - std::sqrt(p) * k) << window << " at " << u << "," << r;
          ASSERT_EQ(image[i], 1.0f - std::sqrt(p) / ev_max) << window << " at " << u << "," << r;
          e_seen = std::max(e_seen, e2[u]), v_seen = std::max(v_seen, v2[u]);
        }
      }
      EXPECT_EQ(e2_max, e_seen);
      EXPECT_EQ(v2_max, v_seen);
      test::ScopedEnv sse2("TERRAMRF_SIMD", "sse2");
      std::vector<float> plain(fixed.size());
      ChengSunMap().fixed(grey, rows, cols, window, r0, r1, k, plain.data());
      EXPECT_EQ(plain, fixed) << window;
    }
}

TEST(ChengSunMap, RejectsWindowsOutsideItsRange) {
  const uint8_t px[4] = {};
  float h[4];
  for (const int window : {1, 4, 17})
    EXPECT_THROW(ChengSunMap().fixed(px, 2, 2, window, 0, 2, 1.0f, h), std::invalid_argument)
        << window;
}

}  // namespace
}  // namespace terramrf
