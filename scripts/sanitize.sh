#!/usr/bin/env bash
# The whole test suite built with AddressSanitizer + UndefinedBehaviorSanitizer, in its own build
# folder (build-asan): an out-of-bounds access, a use after free or scope, or undefined
# behaviour fails the test that triggers it. Slow — the instrumented build takes ~25 min on two
# cores, the suite ~5 min — so CI does not run it; run it after changing code that handles memory
# by hand, and before a release. Arguments go to ctest (e.g. -R Sweep).
# Leak checking is off by default: GCC 12's LeakSanitizer crashes scanning the dynamic TLS of a
# dlopen'd library in one test (EvaluationOutputTest.WritesPerFrameAndSummaryFilesAndPrintsTheTable,
# "Tracer caught signal 11"). With ASAN_OPTIONS=detect_leaks=1 the other 407 tests report no leak.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export TERRAMRF_BUILD_DIR="${TERRAMRF_BUILD_DIR:-$here/build-asan}"
export TERRAMRF_SANITIZE=ON TERRAMRF_BUILD_TYPE=RelWithDebInfo
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=0}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1}"
exec "$here/scripts/test.sh" "$@"
