#!/usr/bin/env bash
# Quick start: build sylva-render (Release) and render the embedded procedural defaults.
#   scripts/render.sh [sylva-render options...]
# With no options: the procedural galaxy (BIH over 1M particles) to out/render.png,
# out/heatmap.png (traversal cost) and out/stats.json, then the procedural sparse volume (BIH over
# its voxels, default LoD, single-sample BIH-DVR) to out/volume.png, out/volume_heatmap.png and
# out/volume_stats.json. With options: one run, out/render.png etc., the options appended.
# Relative paths in the options stay relative to the directory you called this from (no cd).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

bash "$root/scripts/deps.sh"
# Same build/ as scripts/test.sh, so switching between the two does not rebuild from scratch.
cmake -S "$root" -B "$root/build" -DCMAKE_BUILD_TYPE=Release
cmake --build "$root/build" --target sylva-render -j"$(nproc)"

mkdir -p "$root/out"
render="$root/build/examples/sylva-render"
if [[ $# -gt 0 ]]; then
  exec "$render" -o "$root/out/render.png" --heatmap "$root/out/heatmap.png" --stats-json "$root/out/stats.json" "$@"
fi
"$render" -o "$root/out/render.png" --heatmap "$root/out/heatmap.png" --stats-json "$root/out/stats.json"
"$render" --volume procedural --shading -o "$root/out/volume.png" --heatmap "$root/out/volume_heatmap.png" \
  --stats-json "$root/out/volume_stats.json"
