#!/usr/bin/env bash
# Fresh machine → classified simulator scans: installs, builds, runs configs/demo.yaml.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$here/scripts/setup.sh"
out="${1:-$here/out/demo}"
"${TERRAMRF_BUILD_DIR:-$here/build}/bin/terramrf" run "$here/configs/demo.yaml" --out "$out"
echo "demo outputs: $out (grid PNGs and camera images in $out/grid, evaluation in $out/evaluation)"
