#!/usr/bin/env bash
# Packs the tests labelled gpu into one archive for a machine that has a GPU and its Vulkan
# driver but none of the build's packages (a rented GPU box, a CI runner with a GPU):
#   scripts/gpu-bundle.sh OUT.tar.xz [DATA_DIR]
# builds (Release, in build-bundle/) the 16 Vulkan test executables, sylva_gpu_probe and
# sylva-render without OpenImageIO (PPM output; its other packages' libraries are copied), and
# packs them with tests/gpu/run_bundle.sh; DATA_DIR (e.g. ../shared/data) goes in too, for the
# tests that read real data. On the GPU machine (x86-64 Linux with libvulkan.so.1 and glibc
# >= this machine's):
#   mkdir b && tar xJf OUT.tar.xz -C b && bash b/run_bundle.sh LOG_DIR
# runs every executable on the GPU (skipped, exit 77, where there is none), writes one log per
# executable and a summary, and exits non-zero when any failed.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
out=${1:?usage: scripts/gpu-bundle.sh OUT.tar.xz [DATA_DIR]}
data=${2:-}
[[ $out == /* ]] || out=$PWD/$out
tests=(sylva_vulkan_tests sylva_parity_tests sylva_dvr_parity_tests test_conformance_vulkan test_elements_gpu_vulkan
       test_grid_vulkan test_ikd_parity test_iso_parity test_kd_parity test_kd_gpu test_kd_ess_gpu test_kd_dvr_parity
       test_kd_elements_parity test_octree_parity test_octree_vulkan test_octree_elements_parity test_residency_vulkan)

bash scripts/deps.sh
config=(-DCMAKE_BUILD_TYPE=Release -DSYLVA_BUILD_TESTS=ON -DSYLVA_BUILD_BENCHMARKS=OFF
        -DCMAKE_DISABLE_FIND_PACKAGE_OpenImageIO=ON -DCMAKE_DISABLE_FIND_PACKAGE_embree=ON)
if command -v ccache >/dev/null; then
  config+=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$PWD} CCACHE_NOHASHDIR=${CCACHE_NOHASHDIR:-1}
fi
cmake -S . -B build-bundle "${config[@]}" >/dev/null
cmake --build build-bundle -j"$(nproc)" --target "${tests[@]}" sylva_gpu_probe sylva-render

stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
mkdir -p "$stage/bin" "$stage/lib"
for t in "${tests[@]}" sylva_gpu_probe sylva-render; do
  cp "$(find build-bundle -name "$t" -type f -executable | head -1)" "$stage/bin/"
done
strip "$stage"/bin/*
# Libraries beyond the C/C++ runtime and the Vulkan loader (the GPU machine brings its own).
ldd "$stage"/bin/* | awk '$3 ~ /^\// {print $3}' | sort -u |
  grep -Ev '/(libc|libm|libstdc\+\+|libgcc_s|libpthread|libdl|librt|ld-linux[^/]*|libvulkan)\.so' |
  while read -r lib; do cp -L "$lib" "$stage/lib/"; done
cp tests/gpu/run_on_gpu.sh tests/gpu/run_bundle.sh "$stage/"
if [[ -n $data ]]; then
  mkdir -p "$stage/data"
  cp -L "$data"/*.raw "$stage/data/"
fi
tar cf - -C "$stage" . | xz -6 -T0 >"$out"
echo "gpu-bundle: $out ($(du -h "$out" | cut -f1)): ${#tests[@]} test executables, sylva_gpu_probe, sylva-render"
