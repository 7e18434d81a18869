#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Patchwork++ against TerraMRF on the three reference scans (tools/patchwork/README.md).
#
#   tools/patchwork/compare.sh [--build DIR] [--pairs N] [--bench BIN]
#
# Builds terramrf_patchwork_compare in DIR (default build-patchwork/; Patchwork++ from
# $PATCHWORK_SOURCE_DIR when set, else fetched at the pinned commit) and prints its accuracy table
# and timing on one core (taskset -c 0). With --pairs N it then alternates N times Patchwork++'s
# timing on seq 00 frame 0 with TerraMRF's BIN (terramrf_bench_slice of a normal Release build,
# default build/bin/terramrf_bench_slice: BM_LG_Icm against estimateGround, and
# BM_FileToLabels_LG_Icm against reading the .bin + estimateGround) and prints each pair's ratio
# and their median: this class of host switches between fast and slow phases, so
# only a pair's two halves compare.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
build="$here/build-patchwork"
pairs=0
bench="$here/build/bin/terramrf_bench_slice"
while [ $# -gt 0 ]; do
  case "$1" in
    --build) build="$2"; shift 2 ;;
    --pairs) pairs="$2"; shift 2 ;;
    --bench) bench="$2"; shift 2 ;;
    -h|--help) sed -n '3,13p' "$0"; exit 0 ;;
    *) echo "compare.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
case "$pairs" in ''|*[!0-9]*) echo "compare.sh: --pairs '$pairs' is not a count" >&2; exit 2 ;; esac

# The sweeps name the scans relative to configs/sweeps (../../../shared/data/...).
data="$here/../shared/data"
for d in semantickitti_seq00_000000-000005 semantickitti_o3dml_demo/converted_semantickitti \
         rellis3d_example_000104; do
  [ -d "$data/$d" ] || { echo "compare.sh: $data/$d not found (the sweeps' data)" >&2; exit 1; }
done

if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S "$here" -B "$build" -DCMAKE_BUILD_TYPE=Release -DTERRAMRF_BUILD_TESTS=OFF \
    -DTERRAMRF_BUILD_BENCHMARKS=OFF -DTERRAMRF_PATCHWORK=ON \
    ${PATCHWORK_SOURCE_DIR:+-DPATCHWORK_SOURCE_DIR="$PATCHWORK_SOURCE_DIR"} >/dev/null
fi
cmake --build "$build" --target terramrf_patchwork_compare -j"${JOBS:-2}" >/dev/null
driver="$build/bin/terramrf_patchwork_compare"

sweeps="$here/configs/sweeps"
seq00="$sweeps/semantickitti.yaml:seq00:000000"
scans=("$seq00" "$sweeps/semantickitti_o3dml.yaml:o3dml:000750" "$sweeps/rellis3d.yaml:rellis:000104")

echo "load: $(cut -d' ' -f1-3 /proc/loadavg)"
taskset -c 0 "$driver" --calls 30 --csv "$build/patchwork_compare.csv" "${scans[@]}"
echo "(CSV: $build/patchwork_compare.csv)"
[ "$pairs" -gt 0 ] || exit 0

[ -x "$bench" ] || { echo "compare.sh: $bench not found (--bench: terramrf_bench_slice)" >&2; exit 1; }
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
median() { sort -g | awk '{v[NR]=$1} END {print (NR%2 ? v[(NR+1)/2] : (v[NR/2]+v[NR/2+1])/2)}'; }
echo
echo "alternated pairs on seq 00 frame 0, taskset -c 0 (Patchwork++: median of 29 calls;"
echo "TerraMRF: median of its 10 repetitions) [ms]; load before: $(cut -d' ' -f1-3 /proc/loadavg)"
printf '%4s %10s %10s %8s %10s %14s %8s\n' pair Patchwork++ BM_LG_Icm ratio 'PW++ +read' \
  BM_FileToLabels ratio
for i in $(seq 1 "$pairs"); do
  taskset -c 0 "$driver" --calls 30 --csv "$tmp/pw.csv" "$seq00" >/dev/null
  pw=$(awk -F, 'NR==2 {print $17}' "$tmp/pw.csv")    # estimateGround
  pwr=$(awk -F, 'NR==2 {print $20}' "$tmp/pw.csv")   # reading the .bin + estimateGround
  # Names carry "/repeats:10" with some versions of Google Benchmark, so `BM_LG_Icm$` alone
  # would match nothing.
  taskset -c 0 "$bench" --benchmark_filter='^(BM_LG_Icm|BM_FileToLabels_LG_Icm)(/|$)' \
    --benchmark_format=csv 2>"$tmp/bench.err" >"$tmp/bench.csv"
  # real_time of the *_median rows; the unit is ms (TERRAMRF_BENCH sets it).
  lg=$(awk -F, '$1 ~ /^"BM_LG_Icm(\/[^"]*)?_median"$/ {print $3}' "$tmp/bench.csv")
  ftl=$(awk -F, '$1 ~ /^"BM_FileToLabels_LG_Icm(\/[^"]*)?_median"$/ {print $3}' "$tmp/bench.csv")
  if [ -z "$lg" ] || [ -z "$ftl" ] || [ -z "$pw" ] || [ -z "$pwr" ]; then
    echo "compare.sh: pair $i: no median from $bench or the driver:" >&2
    cat "$tmp/bench.err" >&2
    exit 1
  fi
  r1=$(awk -v a="$lg" -v b="$pw" 'BEGIN {printf "%.3f", a / b}')
  r2=$(awk -v a="$ftl" -v b="$pwr" 'BEGIN {printf "%.3f", a / b}')
  printf '%4d %10.2f %10.2f %8s %10.2f %14.2f %8s\n' "$i" "$pw" "$lg" "$r1" "$pwr" "$ftl" "$r2"
  echo "$r1" >>"$tmp/r1"
  echo "$r2" >>"$tmp/r2"
done
echo "median ratio: BM_LG_Icm / estimateGround $(median <"$tmp/r1"), BM_FileToLabels_LG_Icm /" \
  "(read + estimateGround) $(median <"$tmp/r2"); load after: $(cut -d' ' -f1-3 /proc/loadavg)"
