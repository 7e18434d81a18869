// naturalLess: the frame order of every reader (kitti.cpp, rellis.cpp, pointcloud_file).
#include "terramrf/io/natural_order.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>
#include <vector>

namespace terramrf {
namespace {

TEST(NaturalOrder, DigitRunsCompareAsNumbersTheRestAsText) {
  std::vector<std::string> v{"10",     "9",     "100",      "1",         "000011", "0",
                             "scan10", "scan9", "frame9-2", "frame10-1", "a",      "b2c10",
                             "b2c9",   "b10c1", "007",      "7",         "",       "x.bin"};
  sortNatural(v);
  EXPECT_EQ(v, (std::vector<std::string>{"", "0", "1", "007", "7", "9", "10", "000011", "100", "a",
                                         "b2c9", "b2c10", "b10c1", "frame9-2", "frame10-1", "scan9",
                                         "scan10", "x.bin"}));
  // Runs longer than any integer type still compare by value.
  EXPECT_TRUE(naturalLess("99999999999999999999999", "100000000000000000000000"));
  EXPECT_FALSE(naturalLess("100000000000000000000000", "99999999999999999999999"));
  // A digit against another character compares as text ('.' < '0' < 'a').
  EXPECT_TRUE(naturalLess("a.b", "a0b"));
  EXPECT_TRUE(naturalLess("a9", "aa"));
}

// std::sort needs a strict weak order: irreflexive, asymmetric and transitive, and equal only
// for equal names (so a folder's order does not depend on how the directory lists it).
TEST(NaturalOrder, IsAStrictTotalOrder) {
  const std::vector<std::string> pool{"",    "0",     "00",     "1",    "01",  "9",    "10",
                                      "a",   "a0",    "a00",    "a1",   "a01", "a10",  "a.1",
                                      "a-1", "1a",    "01a",    "10a",  "a1b", "a1b1", "a01b2",
                                      "b",   "0.bin", "00.bin", "9.bin"};
  for (const auto& a : pool) {
    EXPECT_FALSE(naturalLess(a, a)) << a;
    for (const auto& b : pool) {
      if (a != b) EXPECT_NE(naturalLess(a, b), naturalLess(b, a)) << a << " / " << b;
      for (const auto& c : pool)
        if (naturalLess(a, b) && naturalLess(b, c)) EXPECT_TRUE(naturalLess(a, c)) << a << b << c;
    }
  }
  std::vector<std::string> shuffled = pool, sorted = pool;
  sortNatural(sorted);
  std::mt19937 rng(7);
  for (int k = 0; k < 20; ++k) {
    std::shuffle(shuffled.begin(), shuffled.end(), rng);
    sortNatural(shuffled);
    EXPECT_EQ(shuffled, sorted);
  }
}

}  // namespace
}  // namespace terramrf
