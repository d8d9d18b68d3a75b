#!/usr/bin/env bash
# Quick start: build sylva-render (Release) and render the default procedural scene.
#   scripts/render.sh [sylva-render options...]
# Writes out/render.png, out/heatmap.png (traversal cost) and out/stats.json in the repository.
# Extra arguments go to sylva-render unchanged, and relative paths in them stay relative to the
# directory you called this from (so this script does not cd).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

bash "$root/scripts/deps.sh"
# Same build/ as scripts/test.sh, so switching between the two does not rebuild from scratch.
cmake -S "$root" -B "$root/build" -DCMAKE_BUILD_TYPE=Release
cmake --build "$root/build" --target sylva-render -j"$(nproc)"

mkdir -p "$root/out"
exec "$root/build/examples/sylva-render" \
  -o "$root/out/render.png" --heatmap "$root/out/heatmap.png" --stats-json "$root/out/stats.json" "$@"
