#!/usr/bin/env bash
# Runs the tests labelled gpu from an archive made by scripts/gpu-bundle.sh, on a machine with a
# GPU (see that script):
#   bash run_bundle.sh LOG_DIR
# Each executable runs whole through run_on_gpu.sh (sylva_gpu_probe first: exit 77 when there is
# no GPU), with the bundle's data/ as SYLVA_TEST_DATA_DIR when it has one; LOG_DIR gets one log
# per executable and summary.txt. Exit status: 0 when all passed, 77 when there is no GPU, else 1.
set -uo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
logs=${1:?usage: run_bundle.sh LOG_DIR}
mkdir -p "$logs"
export LD_LIBRARY_PATH="$here/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
[[ -d $here/data ]] && export SYLVA_TEST_DATA_DIR="$here/data"
"$here/bin/sylva_gpu_probe" | tee "$logs/summary.txt"
probe=${PIPESTATUS[0]}
((probe == 0)) || exit "$probe"
status=0
for exe in "$here"/bin/*; do
  name=$(basename "$exe")
  [[ $name == sylva_gpu_probe || $name == sylva-render ]] && continue
  start=$SECONDS
  bash "$here/run_on_gpu.sh" "$here/bin/sylva_gpu_probe" "$exe" >"$logs/$name.log" 2>&1
  rc=$?
  ((rc == 0)) || status=1
  echo "$name: exit $rc, $((SECONDS - start)) s: $(grep -E '^(All tests passed|test cases:|assertions:)' "$logs/$name.log" | tr '\n' ' ')" |
    tee -a "$logs/summary.txt"
done
exit $status
