#!/usr/bin/env bash
# Fresh machine → whole test suite: installs, builds, runs every test through CTest.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$here/scripts/setup.sh"
ctest --test-dir "${TERRAMRF_BUILD_DIR:-$here/build}" --output-on-failure -j"${TERRAMRF_JOBS:-$(nproc)}" "$@"
