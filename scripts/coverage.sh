#!/usr/bin/env bash
# Line coverage of the whole test suite, in its own build folder (build-cov): which lines of
# framework/, plugins/, meshing/, apps/ and messages/ no test runs. Its use is finding bad-input
# paths without a test (every error a user can meet should have one): the listing puts the
# uncovered lines that raise or report an error first. Not part of CI (the instrumented build
# takes ~10 min on two cores, the suite ~2 min). Arguments go to ctest (e.g. -R Sweep).
# Output: build-cov/coverage/summary.txt, uncovered.txt (every uncovered line, by file) and
# uncovered_errors.txt (the uncovered throw / error lines).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export TERRAMRF_BUILD_DIR="${TERRAMRF_BUILD_DIR:-$here/build-cov}"
export TERRAMRF_COVERAGE=ON TERRAMRF_BUILD_TYPE=RelWithDebInfo
build="$TERRAMRF_BUILD_DIR"
if ! command -v lcov >/dev/null; then
  sudo_cmd=""
  [ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
  $sudo_cmd apt-get install -y -qq --no-install-recommends lcov >/dev/null
fi
"$here/scripts/setup.sh"
# Counters of an earlier run would add to this one's.
find "$build" -name '*.gcda' -delete
ctest --test-dir "$build" -j"${TERRAMRF_JOBS:-$(nproc)}" "$@" || echo "coverage: some tests failed; counting what ran" >&2
out="$build/coverage"
mkdir -p "$out"
lcov --quiet --capture --directory "$build" --output-file "$out/all.info" \
  --ignore-errors gcov,source,graph 2>/dev/null
lcov --quiet --extract "$out/all.info" "$here/framework/*" "$here/plugins/*" "$here/meshing/*" \
  "$here/apps/*" "$here/messages/*" --output-file "$out/project.info"
lcov --summary "$out/project.info" 2>&1 | grep -E "lines|functions" | tee "$out/summary.txt"
python3 "$here/tools/coverage/uncovered.py" "$out/project.info" --root "$here" --out "$out"
