#!/usr/bin/env bash
# Proves the README's two commands on a fresh Debian 12: builds a minimal Debian 12 root
# (debootstrap --variant=minbase: apt, dpkg and the Essential packages, no compiler, no cmake),
# clones this repository's HEAD into it, and runs `bash scripts/render.sh` and
# `bash scripts/test.sh` there as root, with ../shared beside the clone (read-only) when it exists.
# Anything the two commands need that scripts/deps.sh does not install fails here, whatever this
# machine has installed. Run it before every release, and after changing scripts/deps.sh:
#   sudo bash scripts/fresh-check.sh [--ci] [WORKDIR]  (default /var/tmp/sylva-fresh; ~45 min, ~3 GB)
# --ci runs CI's whole job (.ci/run: fuzz, TSan, ASan+UBSan, then the test command) instead of
# the test command alone, and prints each command's time: CI's time on a new machine (no
# compiler cache, no mesa shader cache), which must stay under CI's 90 minutes (~8 GB).
# Needs root (chroot, mounts) and the Debian mirror. Commit first: it checks HEAD, not the work
# tree. Logs: WORKDIR/render.log, WORKDIR/test.log (with --ci: WORKDIR/run.log);
# WORKDIR/installed.txt lists what deps.sh installed on top of minbase. Exit status: 0 when both
# commands succeed.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
commands=(scripts/render.sh scripts/test.sh)
if [[ ${1:-} == --ci ]]; then
  commands=(scripts/render.sh .ci/run)
  shift
fi
work=${1:-/var/tmp/sylva-fresh}
chroot_dir="$work/debian12"
mirror=${SYLVA_DEBIAN_MIRROR:-http://deb.debian.org/debian}

if ((EUID != 0)); then
  echo "fresh-check.sh: needs root (debootstrap, chroot, mounts): sudo bash $0 $*" >&2
  exit 1
fi
if ! command -v debootstrap >/dev/null; then
  apt-get update
  DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends debootstrap
fi

mounts=()
cleanup() {
  for ((i = ${#mounts[@]} - 1; i >= 0; i--)); do umount -R "${mounts[i]}" 2>/dev/null || umount -l "${mounts[i]}" || true; done
}
trap cleanup EXIT
mount_into() {  # mount_into SOURCE TARGET [OPTIONS...]
  local src=$1 dst=$2
  shift 2
  mkdir -p "$dst"
  mount "$@" "$src" "$dst"
  mounts+=("$dst")
}

rm -rf "$chroot_dir"
mkdir -p "$work"
echo "fresh-check: debootstrap --variant=minbase bookworm into $chroot_dir" >&2
debootstrap --variant=minbase bookworm "$chroot_dir" "$mirror" >"$work/debootstrap.log" 2>&1 ||
  { tail -20 "$work/debootstrap.log" >&2; exit 1; }
# The same package sources as a Debian 12 machine (updates and security too), and DNS.
if [[ -f /etc/apt/sources.list.d/debian.sources ]]; then
  cp /etc/apt/sources.list.d/debian.sources "$chroot_dir/etc/apt/sources.list.d/"
  rm -f "$chroot_dir/etc/apt/sources.list"
fi
cp /etc/resolv.conf "$chroot_dir/etc/resolv.conf"
chroot "$chroot_dir" dpkg-query -W -f='${Package}\n' | sort >"$work/minbase.txt"

mount_into proc "$chroot_dir/proc" -t proc
mount_into /dev "$chroot_dir/dev" --rbind
mount_into /sys "$chroot_dir/sys" --rbind
if [[ -d "$root/../shared" ]]; then
  mount_into "$(cd "$root/../shared" && pwd)" "$chroot_dir/work/shared" --bind -o ro
fi
git clone -q "$root" "$chroot_dir/work/sylva"
echo "fresh-check: $(git -C "$root" log -1 --format='%h %s' | cut -c1-80)" >&2

status=0
for cmd in "${commands[@]}"; do
  log="$work/$(basename "$cmd" .sh).log"
  echo "fresh-check: bash $cmd (log: $log)" >&2
  start=$SECONDS
  if chroot "$chroot_dir" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin HOME=/root CI=true \
    bash -c "cd /work/sylva && bash $cmd" </dev/null >"$log" 2>&1; then
    echo "fresh-check: $cmd succeeded in $((SECONDS - start)) s" >&2
  else
    echo "fresh-check: $cmd FAILED after $((SECONDS - start)) s; its last lines:" >&2
    tail -25 "$log" >&2
    status=1
  fi
done
grep -hE '^[0-9]+% tests passed|tests failed out of|^ci: ----.* took' "$work/test.log" "$work/run.log" 2>/dev/null >&2 || true
chroot "$chroot_dir" dpkg-query -W -f='${Package}\n' | sort | comm -13 "$work/minbase.txt" - >"$work/installed.txt"
echo "fresh-check: $(wc -l <"$work/installed.txt") packages installed on top of minbase ($work/installed.txt)" >&2
exit $status
