#!/usr/bin/env bash
# The README's BIH-DVR figures: builds sylva-volume-bench (Release, when needed) and runs it on
# engine, aneurism and lobster at resampling factors 1, 1.5, 2 on the host and the Vulkan device,
# at 320x240 (also over 12-byte float-plane nodes, --float-nodes, to isolate the error of the
# 16-bit planes), then copies a few informative images into docs/images/ as
# volume_<case>_<renderer>_x<factor>.png (renderer: reference, single, multi, heat).
#   scripts/volume_figures.sh [JSON_OUT]       (default /tmp/volume_bench.json)
# Environment: SYLVA_BUILD_DIR (default build, as scripts/test.sh), SYLVA_DATA (default ../shared/data beside the
# checkout), SYLVA_VOLUME_BACKEND (default both), SYLVA_VOLUME_RUNS (default 3).
# The full tables go to stdout and to JSON_OUT.log beside the JSON.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
json=${1:-/tmp/volume_bench.json}
build=${SYLVA_BUILD_DIR:-$root/build}
data=${SYLVA_DATA:-$root/../shared/data}
backend=${SYLVA_VOLUME_BACKEND:-both}
runs=${SYLVA_VOLUME_RUNS:-3}
out=$root/docs/images

# The images the README shows (at most a dozen: they live in the repository). The engine and the
# aneurism are the paper's Figures 5-8; the heat map is the single-sample iterator's node visits.
keep=(
  engine_reference_x1 engine_single_x1 engine_single_x1.5 engine_single_x2 engine_multi_x1 engine_heat_x1
  aneurism_reference_x1 aneurism_single_x1 aneurism_single_x1.5 aneurism_single_x2 aneurism_multi_x1
)

if [[ ! -f $build/CMakeCache.txt ]]; then
  cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release
fi
cmake --build "$build" -j2 --target sylva-volume-bench

images=$(mktemp -d)
trap 'rm -rf "$images"' EXIT
mkdir -p "$(dirname "$json")" "$out"
"$build/benchmarks/sylva-volume-bench" --data "$data" --case all --backend "$backend" --runs "$runs" \
  --size 320x240 --factors 1,1.5,2 --float-nodes --images "$images" --json "$json" | tee "$json.log"

for name in "${keep[@]}"; do
  cp "$images/volume_$name.png" "$out/volume_$name.png"
done
echo "volume_figures.sh: ${#keep[@]} images in $out, records in $json, tables in $json.log"
