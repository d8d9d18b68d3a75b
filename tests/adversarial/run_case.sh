#!/usr/bin/env bash
# One adversarial-size case of sylva-render (issue: hardening, item 5): absurd or huge sizes
# must end in a clear error and a non-zero exit, never a crash, a hang or a wrong image.
#   run_case.sh CASE SYLVA_RENDER WORKDIR
# Huge inputs are sparse files (truncate): they take no disk space, and reading them is what the
# renderer would do with a real file of that size. Allocation failure is provoked with
# `ulimit -v` (address space), so the test does not depend on the machine's memory.
set -uo pipefail
case_name=$1 render=$2 work=$3
mkdir -p "$work" && cd "$work" || exit 1
out=$work/$case_name.png
rm -f "$out"

# expect RC REGEX -- COMMAND...: runs COMMAND, checks its exit status and that stderr matches.
expect() {
  local want_rc=$1 regex=$2
  shift 3
  local err rc
  err=$("$@" 2>&1 >/dev/null)
  rc=$?
  printf '%s\n' "$err"
  if ((rc != want_rc)); then
    echo "FAIL: exit status $rc, expected $want_rc"
    exit 1
  fi
  if ! grep -Eq -- "$regex" <<<"$err"; then
    echo "FAIL: stderr does not match '$regex'"
    exit 1
  fi
  if [[ -e $out ]]; then
    echo "FAIL: an image was written despite the error"
    exit 1
  fi
  echo "PASS"
}

limited() {  # runs "$@" with at most $LIMIT_KB of address space
  (ulimit -v "$LIMIT_KB" && exec "$@")
}

case $case_name in
  raw_dims_overflow_64bit)  # 4294967295^3 voxels: the product overflows 64 bits
    truncate -s 100 a_4294967295x4294967295x4294967295_uint8.raw
    expect 1 "4294967295x4294967295x4294967295 overflow the addressable size" -- \
      "$render" --volume a_4294967295x4294967295x4294967295_uint8.raw -o "$out" ;;
  raw_voxels_past_32bit_oom)  # 2048x2048x1025 = 4.3e9 voxels (past 2^32), a real-size sparse file
    truncate -s 4299161600 big_2048x2048x1025_uint8.raw
    LIMIT_KB=3000000 expect 1 "out of memory \(std::bad_alloc\)" -- \
      limited "$render" --volume big_2048x2048x1025_uint8.raw --size 32x32 -o "$out" ;;
  raw_voxels_past_32bit_short)  # the name asks for 4.3e9 voxels, the file holds 100 bytes
    truncate -s 100 short_2048x2048x1025_uint8.raw
    expect 1 "100 bytes, but 2048x2048x1025 uint8 voxels need 4299161600 bytes" -- \
      "$render" --volume short_2048x2048x1025_uint8.raw -o "$out" ;;
  nrrd_sizes_past_48bit)  # 65536^3 voxels announced, no data
    printf 'NRRD0004\ntype: uint8\ndimension: 3\nsizes: 65536 65536 65536\nencoding: raw\n\n' > n.nrrd
    expect 1 "asks for 281474976710656 \(truncated\)" -- "$render" --volume n.nrrd -o "$out" ;;
  octree_extent_past_2_24)  # 2^24 voxels along x: past what the octree's float voxel space holds
    truncate -s 16777216 line_16777216x1x1_uint8.raw
    expect 1 "extents above 2\^24 - 1 are not supported" -- \
      "$render" --volume line_16777216x1x1_uint8.raw --index octree --range 0,255 --size 32x32 -o "$out" ;;
  kd_extent_past_16bit)
    truncate -s 16777216 line_16777216x1x1_uint8.raw
    expect 1 "grid dimension 16777216 is outside 1 .. 65535" -- \
      "$render" --volume line_16777216x1x1_uint8.raw --index kd-binned --range 0,255 --size 32x32 -o "$out" ;;
  particles_name_past_2_29)  # the name says 6e8 points (past 2^29), the file holds 10
    truncate -s 120 p_600000000x3_float32.raw
    expect 1 "holds 10 points but its name says 600000000" -- \
      "$render" --particles p_600000000x3_float32.raw -o "$out" ;;
  particles_count_past_limit)
    expect 2 "--count: '600000000' is not a number in" -- "$render" --count 600000000 -o "$out" ;;
  particles_oom)  # 1e8 procedural particles in 1.5 GB of address space
    LIMIT_KB=1500000 expect 1 "out of memory \(std::bad_alloc\)" -- \
      limited "$render" --count 100000000 --size 32x32 -o "$out" ;;
  *)
    echo "unknown case $case_name"
    exit 2 ;;
esac
