#!/usr/bin/env bash
# Runs one Vulkan test executable on a GPU (the tests labelled gpu): PROBE (sylva_gpu_probe)
# says whether there is one; without one the test is skipped (exit 77, ctest's SKIP_RETURN_CODE),
# with one the executable runs with SYLVA_VULKAN_DEVICE=gpu and compares within the limits of
# tests/device_tolerance.hpp.
#   run_on_gpu.sh PROBE EXE [ARGS...]
set -uo pipefail
probe=$1
shift
"$probe" || exit $?
SYLVA_VULKAN_DEVICE=gpu exec "$@"
