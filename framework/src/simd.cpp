#include "terramrf/simd.hpp"

#include <cstdlib>
#include <cstring>

namespace terramrf {
namespace {

// Read on every call (a few per scan), so a test or a user can switch it within a process.
bool sse2Only() {
  const char* v = std::getenv("TERRAMRF_SIMD");
  return v && std::strcmp(v, "sse2") == 0;
}

}  // namespace

#if defined(TERRAMRF_SIMD_DISPATCH)
bool useAvx() {
  static const bool cpu = __builtin_cpu_supports("avx");
  return cpu && !sse2Only();
}
bool useAvx2() {
  static const bool cpu = __builtin_cpu_supports("avx2");
  return cpu && !sse2Only();
}
#else
bool useAvx() { return false; }
bool useAvx2() { return false; }
#endif

}  // namespace terramrf
