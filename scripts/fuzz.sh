#!/usr/bin/env bash
# Builds the libFuzzer targets of fuzz/ (clang, -fsanitize=fuzzer,address,undefined) in
# build-fuzz/ and runs each on its corpus; prints executions and coverage per target in a
# final table. Exit status 1 when a target crashed (or leaked, timed out, ran out of memory):
# the input that did it is left in build-fuzz/crashes/TARGET/ and its path printed.
#   scripts/fuzz.sh [--seconds N] [--runs N] [--jobs J] [TARGET...]
#     --seconds N  run each target N seconds (default 30)
#     --runs N     stop a target after N executions instead (whichever comes first with --seconds)
#     --jobs J     run J targets at a time (default 1; one libFuzzer process each)
#     TARGET       raw_name raw nrrd_attached ... (fuzz/targets.cmake); default: all
# The committed seeds in fuzz/corpus/TARGET are read only; what the fuzzer finds goes to
# build-fuzz/corpus/TARGET (kept between runs). Reproduce a crash with
#   build-fuzz/fuzz/fuzz_TARGET build-fuzz/crashes/TARGET/crash-...
# and, once fixed, commit the input under tests/fuzz_regressions/TARGET/ (replayed by ctest).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

seconds=30
runs=-1
jobs=1
targets=()
while (($#)); do
  case $1 in
    --seconds) seconds=$2; shift 2 ;;
    --runs) runs=$2; shift 2 ;;
    --jobs) jobs=$2; shift 2 ;;
    -h|--help) sed -n '2,16p' "$0"; exit 0 ;;
    -*) echo "fuzz.sh: unknown option $1" >&2; exit 2 ;;
    *) targets+=("${1#fuzz_}"); shift ;;
  esac
done
all=$(sed -n '/^set(SYLVA_FUZZ_TARGETS/,/)/p' fuzz/targets.cmake | sed 's/^set(SYLVA_FUZZ_TARGETS//' | tr -d '()' |
  tr -s ' \n' '\n' | grep -v '^$')
((${#targets[@]})) || mapfile -t targets <<<"$all"
for t in "${targets[@]}"; do
  grep -qx "$t" <<<"$all" || { echo "fuzz.sh: no target '$t' (known: $(echo $all))" >&2; exit 2; }
done

bash scripts/deps.sh
build=build-fuzz
if [[ ! -f $build/CMakeCache.txt ]]; then
  # Only the fuzz targets: no tests, examples, benchmarks or shaders in this tree. With clang,
  # CMake prefers LLVM's binutils (llvm-ar, ld.lld, ...) where they happen to be installed;
  # the build needs none of them, so it names binutils' own (build-essential) and a fresh
  # machine with scripts/deps.sh's packages configures the same tree.
  tools=()
  for v in AR:ar RANLIB:ranlib LINKER:ld NM:nm OBJCOPY:objcopy OBJDUMP:objdump STRIP:strip READELF:readelf \
           ADDR2LINE:addr2line CXX_COMPILER_AR:ar CXX_COMPILER_RANLIB:ranlib; do
    p=$(command -v "${v#*:}" || true)
    [[ -n $p ]] && tools+=("-DCMAKE_${v%%:*}=$p")
  done
  cmake -S . -B "$build" -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSYLVA_FUZZ=ON \
    -DSYLVA_BUILD_TESTS=OFF -DSYLVA_BUILD_EXAMPLES=OFF -DSYLVA_BUILD_BENCHMARKS=OFF -DSYLVA_WITH_VULKAN=OFF \
    -DCMAKE_DLLTOOL=none "${tools[@]}"  # dlltool: Windows only, never run
else
  # An existing tree: configure again (cached settings kept) so that targets added to
  # fuzz/targets.cmake since exist before they are named below.
  cmake -S . -B "$build" >/dev/null
fi
cmake --build "$build" -j"$(nproc)" --target "${targets[@]/#/fuzz_}"
# The fuzz tree uses clang and libFuzzer: both must come from scripts/deps.sh's packages.
bash scripts/check-deps.sh "$build" >/dev/null || { bash scripts/check-deps.sh "$build"; exit 1; }

logs=$build/logs
mkdir -p "$logs"
run_one() {
  local t=$1
  mkdir -p "$build/corpus/$t" "$build/crashes/$t"
  # stdin from /dev/null: a header may name /dev/stdin as its data file.
  "$build/fuzz/fuzz_$t" "$build/corpus/$t" "fuzz/corpus/$t" -max_total_time="$seconds" -runs="$runs" \
    -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$build/crashes/$t/" \
    </dev/null >"$logs/$t.log" 2>&1
  echo $? >"$logs/$t.status"
}
rm -f "$logs"/*.status
running=0
for t in "${targets[@]}"; do
  echo "fuzz.sh: fuzz_$t for ${seconds} s$( ((runs > 0)) && echo " or $runs runs") ..." >&2
  run_one "$t" &
  running=$((running + 1))
  if ((running >= jobs)); then wait -n || true; running=$((running - 1)); fi
done
wait || true

# Table: executions (libFuzzer's stat::number_of_executed_units), cov: (edges) and ft:
# (features) of the last status line, the corpus size, and the outcome.
failed=0
printf '\n%-16s %12s %8s %8s %8s %7s  %s\n' target executions cov ft corpus 'exec/s' result
for t in "${targets[@]}"; do
  log=$logs/$t.log
  status=$(cat "$logs/$t.status" 2>/dev/null || echo 1)
  execs=$(sed -nE 's/^stat::number_of_executed_units: *([0-9]+)/\1/p' "$log" | tail -1)
  rate=$(sed -nE 's/^stat::average_exec_per_sec: *([0-9]+)/\1/p' "$log" | tail -1)
  last=$(grep -E '^#[0-9]+' "$log" | grep -E 'cov: ' | tail -1 || true)
  cov=$(sed -nE 's/.* cov: ([0-9]+).*/\1/p' <<<"$last")
  ft=$(sed -nE 's/.* ft: ([0-9]+).*/\1/p' <<<"$last")
  corp=$(sed -nE 's/.* corp: ([0-9]+).*/\1/p' <<<"$last")
  result=ok
  if [[ $status != 0 ]]; then
    failed=1
    artifact=$(sed -nE 's/.*(Test unit written to|artifact_prefix.*; Test unit written to) (.*)$/\2/p' "$log" | tail -1)
    result="FAILED (exit $status): ${artifact:-see $log}"
  fi
  printf '%-16s %12s %8s %8s %8s %7s  %s\n' "$t" "${execs:-?}" "${cov:-?}" "${ft:-?}" "${corp:-?}" "${rate:-?}" "$result"
done
if ((failed)); then
  echo "fuzz.sh: a target failed; its log is in $logs/, the input in $build/crashes/" >&2
  for t in "${targets[@]}"; do
    [[ $(cat "$logs/$t.status" 2>/dev/null || echo 1) == 0 ]] || { echo "---- $t" >&2; grep -E 'ERROR|SUMMARY|check failed|Test unit written|Base64' "$logs/$t.log" | head -8 >&2; }
  done
fi
exit $failed
