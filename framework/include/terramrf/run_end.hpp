#pragma once
// Runs of equal ids in an array (ring indices of a cloud stored ring after ring, run ids of ring
// recovery): where the run that starts at i ends, eight or four ids per test.
#include <cstddef>
#include <cstdint>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace terramrf {

/// End of the run of ids equal to id[i], taken modulo 2^16, that starts at i (Id: uint16_t, as
/// ring indices are, or int).
template <typename Id>
std::size_t runEnd(const Id* id, std::size_t i, std::size_t n) {
  static_assert(sizeof(Id) == 2 || sizeof(Id) == 4, "16- or 32-bit ids");
  const uint16_t r = static_cast<uint16_t>(id[i]);
  std::size_t j = i + 1;
#if defined(__SSE2__)
  if constexpr (sizeof(Id) == 2) {
    const __m128i rv = _mm_set1_epi16(static_cast<short>(r));
    for (; j + 8 <= n; j += 8) {
      const int eq = _mm_movemask_epi8(
          _mm_cmpeq_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(id + j)), rv));
      if (eq != 0xFFFF) return j + __builtin_ctz(~unsigned(eq)) / 2;
    }
  } else {
    // Equal modulo 2^16: compare the low halves only.
    const __m128i rv = _mm_set1_epi32(r), low = _mm_set1_epi32(0xFFFF);
    for (; j + 4 <= n; j += 4) {
      const __m128i v =
          _mm_and_si128(_mm_loadu_si128(reinterpret_cast<const __m128i*>(id + j)), low);
      const int eq = _mm_movemask_epi8(_mm_cmpeq_epi32(v, rv));
      if (eq != 0xFFFF) return j + __builtin_ctz(~unsigned(eq)) / 4;
    }
  }
#endif
  while (j < n && static_cast<uint16_t>(id[j]) == r) ++j;
  return j;
}

}  // namespace terramrf
