// GlcmAccumulator (plugins/feature/haralick/glcm_features.cpp) against the dense reading it
// replaced: every entry of the (L+1)² table scanned per finish. Bit for bit, at every L.
#include "glcm_features.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <random>
#include <vector>

namespace terramrf {
namespace {

/// The former GlcmAccumulator::finish over a whole table h ((L+1)², row-major), unchanged.
GlcmFeatures denseReference(const std::vector<uint32_t>& h, int L) {
  const int s = L + 1;
  uint64_t sum_p2 = 0, n = 0, sum_i = 0, sum_i2 = 0;
  std::vector<uint64_t> diag(L, 0);
  for (int i = 0; i < L; ++i) {
    uint64_t row = 0, col = 0;
    for (int j = 0; j < L; ++j) {
      const uint64_t hij = h[i * s + j], hji = h[j * s + i];
      sum_p2 += (hij + hji) * (hij + hji);
      row += hij;
      col += hji;
      diag[i > j ? i - j : j - i] += hij;
    }
    n += row;
    sum_i += uint64_t(i) * (row + col);
    sum_i2 += uint64_t(i) * i * (row + col);
  }
  double sum_idm = 0;
  for (int k = 0; k < L; ++k) sum_idm += 1.0 / (1.0 + double(k) * k) * double(diag[k]);
  GlcmFeatures f;
  f.pairs = std::size_t(n);
  if (n > 0) {
    const double r = 2.0 * double(n);
    f.asm_ = double(sum_p2) / (r * r);
    const double mu = double(sum_i) / r;
    f.variance = std::max(0.0, double(sum_i2) / r - mu * mu);
    f.idm = sum_idm / double(n);
  }
  return f;
}

bool sameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

TEST(GlcmAccumulator, SameFeaturesToTheBitAsTheDenseTableAtEveryLevelCount) {
  std::mt19937 rng(5);
  for (const int L : {2, 3, 8, 16, 37, 64, 255, 256}) {
    GlcmAccumulator acc(L);
    // Several cells in a row through one accumulator: each finish must leave it empty.
    for (int cell = 0; cell < 60; ++cell) {
      const int pairs = std::uniform_int_distribution<int>(0, cell % 3 == 0 ? 20 : 900)(rng);
      // Narrow grey ranges (a smooth patch) as well as the full range; some outside pixels.
      const int lo = std::uniform_int_distribution<int>(0, L - 1)(rng);
      const int hi =
          std::min(L - 1, lo + std::uniform_int_distribution<int>(0, L)(rng) % (L / 4 + 2));
      std::uniform_int_distribution<int> level(lo, hi), coin(0, 9);
      std::vector<uint32_t> table(std::size_t(L + 1) * (L + 1), 0);
      std::vector<uint16_t> a, b;
      for (int p = 0; p < pairs; ++p) {
        a.push_back(uint16_t(coin(rng) == 0 ? L : level(rng)));
        b.push_back(uint16_t(coin(rng) == 0 ? L : level(rng)));
        ++table[std::size_t(a.back()) * (L + 1) + b.back()];
      }
      // In rows of varying length, and a few through add().
      std::size_t at = 0;
      while (at < a.size()) {
        const int len = std::min<int>(int(a.size() - at), 1 + int(rng() % 40));
        if (len == 1)
          acc.add(a[at], b[at]);
        else
          acc.addRow(a.data() + at, b.data() + at, len);
        at += std::size_t(len);
      }
      const GlcmFeatures want = denseReference(table, L), got = acc.finish();
      ASSERT_EQ(got.pairs, want.pairs) << "L " << L << " cell " << cell;
      EXPECT_TRUE(sameBits(got.asm_, want.asm_)) << "L " << L << " cell " << cell;
      EXPECT_TRUE(sameBits(got.variance, want.variance)) << "L " << L << " cell " << cell;
      EXPECT_TRUE(sameBits(got.idm, want.idm)) << "L " << L << " cell " << cell;
    }
  }
}

TEST(GlcmAccumulator, EmptyAndOutsideOnlyGiveZeroAndLeaveNoTrace) {
  GlcmAccumulator acc(256);
  GlcmFeatures f = acc.finish();
  EXPECT_EQ(f.pairs, 0u);
  EXPECT_EQ(f.asm_, 0.0);
  acc.add(256, 3);
  acc.add(3, 256);
  acc.add(256, 256);
  f = acc.finish();
  EXPECT_EQ(f.pairs, 0u);
  EXPECT_EQ(f.idm, 0.0);
  // One pair (5, 7): P has (5, 7) and (7, 5), each ½; ASM ½, μ 6, variance 1, IDM 1/5.
  acc.add(5, 7);
  f = acc.finish();
  EXPECT_EQ(f.pairs, 1u);
  EXPECT_DOUBLE_EQ(f.asm_, 0.5);
  EXPECT_DOUBLE_EQ(f.variance, 1.0);
  EXPECT_DOUBLE_EQ(f.idm, 0.2);
  // The largest table's every entry at once, then a single pair: nothing of the first remains.
  std::vector<uint16_t> a, b;
  for (int i = 0; i <= 256; ++i)
    for (int j = 0; j <= 256; ++j) a.push_back(uint16_t(i)), b.push_back(uint16_t(j));
  acc.addRow(a.data(), b.data(), int(a.size()));
  EXPECT_EQ(acc.finish().pairs, 256u * 256u);
  acc.add(9, 9);
  f = acc.finish();
  EXPECT_EQ(f.pairs, 1u);
  EXPECT_DOUBLE_EQ(f.asm_, 1.0);
  EXPECT_DOUBLE_EQ(f.variance, 0.0);
  EXPECT_DOUBLE_EQ(f.idm, 1.0);
}

}  // namespace
}  // namespace terramrf
