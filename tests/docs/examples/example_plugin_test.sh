#!/usr/bin/env bash
# Installs TerraMRF into a temporary prefix, builds the out-of-tree example plugin against the
# installed package, and checks that adding it to a config changes the output.
set -euo pipefail
src="$1"; build="$2"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
cmake --install "$build" --prefix "$tmp/prefix" >/dev/null
cmake -S "$src/docs/examples/point_density" -B "$tmp/pd" -DCMAKE_PREFIX_PATH="$tmp/prefix" \
  -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$tmp/pd" >/dev/null
test -f "$tmp/pd/terramrf_point_density.so"
tm="$tmp/prefix/bin/terramrf"
TERRAMRF_PLUGIN_PATH="$tmp/pd" "$tm" describe point_density | grep -q "points/m"

base_cfg() {
cat <<YAML
version: 1
$1
grid: {size_m: 40, cell_m: 0.5}
source: {type: simulator, params: {frames: 1, enable_camera: false}}
stages:
$2  - {name: hdiff, type: height_difference}
  - {name: mrf, type: potts_gaussian, params: {model: $tmp/prefix/share/terramrf/configs/models/laser_simulator.yaml, features: [height_diff]}}
  - {name: solve, type: icm}
outputs:
  - {type: grid_csv}
YAML
}
base_cfg "" "" > "$tmp/without.yaml"
base_cfg "plugin_path: [$tmp/pd]" "  - {name: density, type: point_density}
" > "$tmp/with.yaml"
"$tm" run "$tmp/without.yaml" --out "$tmp/out_without" --no-progress >/dev/null
"$tm" run "$tmp/with.yaml" --out "$tmp/out_with" --no-progress >/dev/null
if head -1 "$tmp"/out_without/grid_csv/*.csv | grep -q point_density; then
  echo "FAIL: point_density column present without the plugin"; exit 1
fi
head -1 "$tmp"/out_with/grid_csv/*.csv | grep -q point_density || {
  echo "FAIL: the example plugin did not add its layer"; exit 1; }
echo "example plugin built out of tree and changed the output"
