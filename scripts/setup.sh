#!/usr/bin/env bash
# Installs the Debian 12 packages TerraMRF needs (only those missing), then configures and builds
# in Release. Safe to run repeatedly: an up-to-date build does nothing.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${TERRAMRF_BUILD_DIR:-$here/build}"
jobs="${TERRAMRF_JOBS:-$(nproc)}"

packages=(
  build-essential cmake pkg-config git
  libeigen3-dev libyaml-cpp-dev libopencv-dev libpcl-dev libcgal-dev libmrpt-poses-dev
  liblcm-dev liblcm-bin libglib2.0-dev libtbb-dev libboost-graph-dev libmaxflow-dev libtinygltf-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  python3  # tools/fuzz/fuzz_inputs.py, run by CTest with fixed seeds
)
# Node.js runs the Khronos glTF validator test (tests/meshing/gltf_validator) and the browser viewer
# (tools/gltf_view). Debian's nodejs + npm only when node/npm are absent: NodeSource's nodejs bundles
# npm and conflicts with Debian's npm package.
{ command -v node && command -v npm; } >/dev/null 2>&1 || packages+=(nodejs npm)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}" >&2
  sudo_cmd=""
  [ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# Pinned npm packages in the build folder (never in the source tree); skipped when installed.
node_tools="$build/node_tools"
node_pins=(gltf-validator@2.0.0-dev.3.10 three@0.187.0)
node_need=()
for pin in "${node_pins[@]}"; do
  have="$(node -p "require('$node_tools/node_modules/${pin%@*}/package.json').version" 2>/dev/null || true)"
  [ "$have" = "${pin##*@}" ] || node_need+=("$pin")
done
if [ ${#node_need[@]} -gt 0 ]; then
  echo "setup: npm installing ${node_need[*]} into $node_tools" >&2
  mkdir -p "$node_tools"
  npm install --prefix "$node_tools" --save-exact --no-audit --no-fund --loglevel=error \
    "${node_pins[@]}" >/dev/null
fi

data_dir="${TERRAMRF_DATA_DIR:-$here/../shared/data}"
# TERRAMRF_BUILD_TYPE, TERRAMRF_SANITIZE and TERRAMRF_COVERAGE are for scripts/sanitize.sh and
# scripts/coverage.sh; the default is Release.
cmake -S "$here" -B "$build" -DCMAKE_BUILD_TYPE="${TERRAMRF_BUILD_TYPE:-Release}" \
  -DTERRAMRF_SANITIZE="${TERRAMRF_SANITIZE:-OFF}" -DTERRAMRF_COVERAGE="${TERRAMRF_COVERAGE:-OFF}" \
  -DTERRAMRF_DATA_DIR="$data_dir" >/dev/null
cmake --build "$build" -j"$jobs"
