#pragma once
// Which vector instruction sets the per-point loops may use. The build targets plain x86-64
// (SSE2); loops that gain from wider vectors also have an AVX or AVX2 version, chosen at run time.
// Every such version performs the same IEEE operations in the same order as the SSE2 one (no FMA),
// so results are the same bits either way.
//
// A file with such a loop writes it inside `#if defined(TERRAMRF_SIMD_DISPATCH)`, marks its
// functions TERRAMRF_TARGET_AVX / TERRAMRF_TARGET_AVX2 (lambdas do not inherit the target, so
// helpers are functions), and calls them when useAvx() / useAvx2().

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define TERRAMRF_SIMD_DISPATCH 1
#define TERRAMRF_TARGET_AVX __attribute__((target("avx")))
#define TERRAMRF_TARGET_AVX2 __attribute__((target("avx2")))
#endif

namespace terramrf {

/// The CPU has AVX and the environment variable TERRAMRF_SIMD is not "sse2".
bool useAvx();
/// The CPU has AVX2 and the environment variable TERRAMRF_SIMD is not "sse2".
bool useAvx2();

}  // namespace terramrf
