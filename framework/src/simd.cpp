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

bool useAvx() {
#if defined(__x86_64__) && defined(__GNUC__)
  static const bool cpu = __builtin_cpu_supports("avx");
  return cpu && !sse2Only();
#else
  return false;
#endif
}

bool useAvx2() {
#if defined(__x86_64__) && defined(__GNUC__)
  static const bool cpu = __builtin_cpu_supports("avx2");
  return cpu && !sse2Only();
#else
  return false;
#endif
}

}  // namespace terramrf
