#!/usr/bin/env bash
# Builds everything with the tests and runs them; the output ends with ctest's summary and the
# exit status is ctest's.
#   scripts/test.sh                      Release build in build/
#   scripts/test.sh --sanitize           ASan+UBSan (RelWithDebInfo) build in build-asan/
#   scripts/test.sh [--sanitize] ARGS... extra ARGS go to ctest (e.g. -R bih)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

build=build
config=(-DCMAKE_BUILD_TYPE=Release -DSYLVA_SANITIZE=OFF)
if [[ ${1:-} == --sanitize ]]; then
  shift
  # A separate tree: sanitizer flags change every object, and build/ stays usable meanwhile.
  build="build-asan"
  config=(-DCMAKE_BUILD_TYPE=RelWithDebInfo -DSYLVA_SANITIZE=ON)
  # Show where undefined behaviour happened, not only that it did.
  export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1}
fi

bash scripts/deps.sh
cmake -S . -B "$build" "${config[@]}" -DSYLVA_BUILD_TESTS=ON
cmake --build "$build" -j"$(nproc)"
if [[ $build == build-asan ]]; then
  # LeakSanitizer reports allocations of the Vulkan driver and of OpenImageIO's plugins, which
  # are unloaded before the report ("<unknown module>", so no suppression can name them). Our
  # own tests run with leak detection; those that load drivers or plugins run without it.
  ctest --test-dir "$build" --output-on-failure -j2 -LE 'vulkan|plugins' "$@"
  ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0} exec ctest --test-dir "$build" --output-on-failure -j2 -L 'vulkan|plugins' "$@"
fi
exec ctest --test-dir "$build" --output-on-failure -j2 "$@"
