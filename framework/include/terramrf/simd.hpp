#pragma once
// Which vector instruction sets the per-point loops may use. The build targets plain x86-64
// (SSE2); loops that gain from wider vectors also have an AVX or AVX2 version, chosen at run time.
// Every such version performs the same IEEE operations in the same order as the SSE2 one (no FMA),
// so results are the same bits either way.

namespace terramrf {

/// The CPU has AVX and the environment variable TERRAMRF_SIMD is not "sse2".
bool useAvx();
/// The CPU has AVX2 and the environment variable TERRAMRF_SIMD is not "sse2".
bool useAvx2();

}  // namespace terramrf
