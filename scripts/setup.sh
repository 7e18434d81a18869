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
  liblcm-dev liblcm-bin libglib2.0-dev libtbb-dev libboost-graph-dev libtinygltf-dev
  libgtest-dev libgmock-dev libbenchmark-dev
)
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

data_dir="${TERRAMRF_DATA_DIR:-$here/../shared/data}"
cmake -S "$here" -B "$build" -DCMAKE_BUILD_TYPE=Release -DTERRAMRF_DATA_DIR="$data_dir" >/dev/null
cmake --build "$build" -j"$jobs"
