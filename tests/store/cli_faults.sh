#!/usr/bin/env bash
# store.cli_*: sylva-store's command line under faults.
#   cli_faults.sh SYLVA_STORE kill     kill -9 the builder at once and at random points (5 runs): verify then
#                                      says complete (0) or incomplete (1), never crashes; build
#                                      --resume finishes it to the content of an uninterrupted build
#   cli_faults.sh SYLVA_STORE full     a map too small for the store (a full disk): exit 3 with the
#                                      space needed; verify: incomplete; --resume finishes it
#   cli_faults.sh SYLVA_STORE input    bad inputs: a clear message, exit 1, no store left behind
#   cli_faults.sh SYLVA_STORE corrupt  verify lists a damaged brick's key and exits 1
#   cli_faults.sh SYLVA_STORE format   --brick-format: auto gives unorm16 for a uint16 file and float32
#                                      for Marschner-Lobb, half the raw brick bytes; an explicit format
#                                      is kept; --resume refuses an interrupted store of another format
set -uo pipefail
tool=$1
mode=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

digest() { "$tool" info "$1" | sed -n 's/^content_digest: //p'; }
# A build that takes a while: small committed batches (each an fsync).
args=(build procedural:ml:64x56x48 --brick 8 --border 2 --compress zstd --commit-bricks 3 --quiet)

case $mode in
kill)
  "$tool" "${args[@]}" -o "$work/ref" || fail "reference build"
  want=$(digest "$work/ref")
  [[ -n $want ]] || fail "no digest"
  seen_incomplete=0
  # Kill points (printed, so a failure can be replayed): at once (before the store exists, which
  # under a sanitizer 0.03 s can be too), one early, three at random.
  delays="0 0.03 $(for i in 1 2 3; do awk -v r=$RANDOM 'BEGIN { printf "%.2f ", 0.05 + (r % 600) / 1000 }'; done)"
  for delay in $delays; do
    s="$work/s-$delay"
    "$tool" "${args[@]}" -o "$s" &
    pid=$!
    sleep "$delay"
    kill -9 "$pid" 2>/dev/null
    wait "$pid" 2>/dev/null
    "$tool" verify "$s" >"$work/verify.txt" 2>&1
    rc=$?
    if ((rc == 1)); then
      seen_incomplete=1
      grep -q "INCOMPLETE\|no such store\|not a sylva brick store" "$work/verify.txt" || { cat "$work/verify.txt"; fail "verify exit 1 without saying incomplete (delay $delay)"; }
      grep -q "CORRUPT" "$work/verify.txt" && { cat "$work/verify.txt"; fail "a killed build left a corrupt brick"; }
      if [[ ! -e $s ]]; then
        # Killed before it made the directory: nothing to resume (--resume refuses a missing
        # store), so the build runs again from the start.
        grep -q "no such store" "$work/verify.txt" || { cat "$work/verify.txt"; fail "no store, but verify did not say so"; }
        "$tool" "${args[@]}" -o "$s" || fail "build again after kill at $delay s"
      else
        "$tool" "${args[@]}" -o "$s" --resume || fail "resume after kill at $delay s"
      fi
    elif ((rc != 0)); then
      cat "$work/verify.txt"; fail "verify exit $rc after kill at $delay s"
    fi
    "$tool" verify "$s" >/dev/null || fail "verify after resume (delay $delay)"
    [[ $(digest "$s") == "$want" ]] || fail "resumed store differs from the uninterrupted one (delay $delay)"
    echo "killed at ${delay}s: verify exit $rc, resumed store equal"
  done
  ((seen_incomplete)) || echo "note: every kill came after completion (a fast machine); nothing was resumed" >&2
  ;;
full)
  small=(build procedural:ml:40 --brick 8 --compress none --commit-bricks 4 --quiet)
  "$tool" "${small[@]}" -o "$work/ref" || fail "reference build"
  "$tool" "${small[@]}" -o "$work/s" --map-size 1M 2>"$work/err.txt"
  rc=$?
  ((rc == 3)) || { cat "$work/err.txt"; fail "a full map must exit 3, got $rc"; }
  grep -q "more are needed" "$work/err.txt" || { cat "$work/err.txt"; fail "no space needed in the message"; }
  "$tool" verify "$work/s" >"$work/v.txt"; rc=$?
  ((rc == 1)) && grep -q INCOMPLETE "$work/v.txt" || { cat "$work/v.txt"; fail "verify must say incomplete"; }
  "$tool" "${small[@]}" -o "$work/s" --resume || fail "resume"
  "$tool" verify "$work/s" >/dev/null || fail "verify after resume"
  [[ $(digest "$work/s") == $(digest "$work/ref") ]] || fail "resumed store differs"
  ;;
input)
  expect_error() {  # expect_error PATTERN ARGS...: exit 1 or 2, PATTERN in stderr, no store made
    local pattern=$1; shift
    "$tool" "$@" -o "$work/bad" --quiet 2>"$work/err.txt" && fail "accepted: $*"
    grep -q -- "$pattern" "$work/err.txt" || { cat "$work/err.txt"; fail "no '$pattern' for: $*"; }
    [[ ! -e $work/bad ]] || fail "a store was left behind by: $*"
  }
  head -c 999 /dev/zero >"$work/v_10x10x10_uint8.raw"
  expect_error "truncated" build "$work/v_10x10x10_uint8.raw"
  printf '\x00\x00\xc0\x7f' >"$work/n_1x1x1_float32.raw"
  expect_error "voxel 0 is NaN" build "$work/n_1x1x1_float32.raw"
  : >"$work/z_0x4x4_uint8.raw"
  expect_error "zero extent" build "$work/z_0x4x4_uint8.raw"
  expect_error "2^24 - 1" build procedural:ml:20000000x2x2
  expect_error "more than --memory" build procedural:ml:4096 --memory 64M
  expect_error "no such file" build "$work/missing_4x4x4_uint8.raw"
  expect_error "unknown procedural" build procedural:foo
  "$tool" verify "$work/nothing" >/dev/null 2>&1 && fail "verify of a missing store passed"
  ;;
corrupt)
  "$tool" build procedural:ml:30 --brick 8 --compress none --quiet -o "$work/s" || fail "build"
  # The first brick's samples are float densities in [0, 1]; overwrite a run of them in data.mdb
  # with 0xFF bytes (NaN patterns): LMDB stays valid, the brick's checksum does not.
  python3 - "$work/s/data.mdb" <<'PY' || fail "could not damage the file"
import struct, sys
p = sys.argv[1]
b = bytearray(open(p, 'rb').read())
# find a header: codec 0, filter 0, reserved 0, size 8000 * 4 bytes
h = bytes([0, 0, 0, 0]) + struct.pack('<I', 12 * 12 * 12 * 4)
i = b.find(h)
assert i > 0
b[i + 16 + 100:i + 16 + 140] = b'\xff' * 40
open(p, 'wb').write(b)
PY
  "$tool" verify "$work/s" >"$work/v.txt"; rc=$?
  ((rc == 1)) || { cat "$work/v.txt"; fail "verify passed a damaged brick"; }
  grep -q "CORRUPT: 1 bricks" "$work/v.txt" || { cat "$work/v.txt"; fail "the damaged brick is not listed"; }
  ;;
format)
  python3 - "$work/v_24x20x18_uint16.raw" <<'PY' || fail "could not write the volume"
import struct, sys
n = 24 * 20 * 18
open(sys.argv[1], 'wb').write(struct.pack('<%dH' % n, *[(i * 2654435761) % 60000 for i in range(n)]))
PY
  field() { "$tool" info "$1" | sed -n "s/^$2: //p;s/^$2=//p" | head -n 1; }
  "$tool" build "$work/v_24x20x18_uint16.raw" --brick 8 --quiet -o "$work/u16" || fail "build uint16"
  "$tool" build "$work/v_24x20x18_uint16.raw" --brick 8 --brick-format float32 --quiet -o "$work/f32" || fail "build float32"
  "$tool" build "$work/v_24x20x18_uint16.raw" --brick 8 --brick-format unorm8 --quiet -o "$work/u8" || fail "build unorm8"
  "$tool" build procedural:ml:20 --brick 8 --quiet -o "$work/ml" || fail "build ml"
  [[ $(field "$work/u16" brick_format) == unorm16 ]] || { "$tool" info "$work/u16"; fail "auto is not unorm16 for uint16"; }
  [[ $(field "$work/f32" brick_format) == float32 ]] || fail "--brick-format float32 not kept"
  [[ $(field "$work/u8" brick_format) == unorm8 ]] || fail "--brick-format unorm8 not kept"
  [[ $(field "$work/ml" brick_format) == float32 ]] || fail "auto is not float32 for Marschner-Lobb"
  w16=$(field "$work/u16" brick_words) w32=$(field "$work/f32" brick_words) w8=$(field "$work/u8" brick_words)
  ((w16 * 2 == w32 && w8 * 4 == w32)) || fail "brick words $w32 / $w16 / $w8 are not 1 : 1/2 : 1/4"
  for s in u16 f32 u8 ml; do "$tool" verify "$work/$s" >/dev/null || fail "verify $s"; done
  # An interrupted store (a full map) of float32 bricks is not finished as unorm16.
  small=(build procedural:ml:40 --brick 8 --compress none --commit-bricks 4 --quiet)
  "$tool" "${small[@]}" -o "$work/part" --map-size 1M 2>/dev/null; rc=$?
  ((rc == 3)) || fail "the small map did not fill (exit $rc)"
  "$tool" "${small[@]}" -o "$work/part" --resume --brick-format unorm16 2>"$work/err.txt" && fail "resume accepted another brick format"
  grep -q "other settings" "$work/err.txt" || { cat "$work/err.txt"; fail "no message for resume with another format"; }
  "$tool" "${small[@]}" -o "$work/part" --resume || fail "resume with the same format"
  ;;
*) fail "unknown mode $mode" ;;
esac
echo "ok: $mode"
