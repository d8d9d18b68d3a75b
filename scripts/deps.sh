#!/usr/bin/env bash
# Makes sure the Debian 12 packages sylva needs to build and test are installed.
# Quiet when all are there. Otherwise: as root, installs the missing ones (fresh CI machines and
# containers); as anyone else, prints the command to run and fails, rather than prompting for sudo.
#   scripts/deps.sh          check and install
#   scripts/deps.sh --list   print the package names, one a line (scripts/check-deps.sh reads them)
# The list is complete for a minimal Debian 12 (debootstrap --variant=minbase): scripts/fresh-check.sh
# proves it by running the README's two commands there. The test suite's deps.declared test checks
# that every file the build used from the system belongs to one of these packages or what they
# pull in, so a package that only happened to be on a machine is caught.
set -euo pipefail

packages=(
  build-essential cmake pkg-config   # compiler and build tools
  ccache                             # scripts/test.sh compiles through it: a second build recompiles only what changed
  libglm-dev                         # math on the host (GLSL names and semantics)
  catch2                             # unit tests (Catch2 v2)
  libopenimageio-dev                 # images written by sylva-render
  openimageio-tools                  # Debian 12's OpenImageIO CMake package checks that its tools exist
  libvulkan-dev mesa-vulkan-drivers  # Vulkan loader + lavapipe, so GPU tests run without a GPU
  glslang-tools glslang-dev spirv-tools  # shaders -> SPIR-V at build time, validation
  libtbb-dev libembree-dev           # benchmark peers
  libnanovdb-dev                     # sylva-iso-bench's NanoVDB HDDA peer (headers only; optional at configure time)
  zlib1g-dev                         # gzip-encoded NRRD volumes (optional)
  nlohmann-json3-dev                 # transfer functions in JSON (optional: found with __has_include)
  libcli11-dev                       # command lines of sylva-store and the benchmarks, parsed by CLI11
  clang libclang-rt-dev libfuzzer-14-dev  # fuzz targets (scripts/fuzz.sh): clang, its sanitizer runtimes, libFuzzer
  liblmdb-dev libzstd-dev liblz4-dev libxxhash-dev  # the out-of-core brick store (sylva::store, sylva-store)
  libhdf5-dev                        # sylva-store-bench: HDF5 chunked datasets, the peer of the LMDB store (optional)
)

if [[ ${1:-} == --list ]]; then
  printf '%s\n' "${packages[@]}"
  exit 0
fi

if ! command -v dpkg-query >/dev/null; then
  # Not Debian: we cannot check, so let CMake report what it cannot find.
  echo "deps.sh: no dpkg-query; make sure the equivalents of these are installed: ${packages[*]}" >&2
  exit 0
fi

missing=()
for pkg in "${packages[@]}"; do
  # "ii" = installed and configured; anything else (absent, removed, half-installed) is missing.
  status=$(dpkg-query -W -f='${db:Status-Abbrev}\n' "$pkg" 2>/dev/null || true)
  grep -q '^ii' <<<"$status" || missing+=("$pkg")
done

# SYLVA_LAVAPIPE=backports: lavapipe from Debian 12's own backports (bookworm-backports:
# mesa-vulkan-drivers 25.0, built against the same LLVM 15) instead of bookworm's 22.3. It runs
# the same SPIR-V 1.8-4.3x faster with the same images bit for bit, and every test passes on
# both, but it compiles pipelines more slowly: on a new machine scripts/test.sh took 2,329 s
# instead of 1,163 s (README, "lavapipe from bookworm-backports"), so the default, and CI, stay
# on 22.3. Backports are pinned below the release (priority 100), so only this
# package and what it needs come from there (libdrm, mesa-libgallium, and the Mesa libraries
# already installed, which apt keeps at one version). A failure to get it is a warning (the
# source this script added is taken out again). The source names the machine's Debian mirror,
# or SYLVA_BACKPORTS_MIRROR.
lavapipe_min=25
lavapipe_wanted() {  # true when backports' lavapipe is asked for, on Debian 12, and not there yet
  [[ ${SYLVA_LAVAPIPE:-debian} == backports ]] || return 1
  [[ -r /etc/os-release ]] && grep -qx 'VERSION_CODENAME=bookworm' /etc/os-release || return 1
  local v
  v=$(dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null || true)
  [[ -z $v ]] || dpkg --compare-versions "$v" lt "$lavapipe_min~"
}
install_lavapipe() {  # never fatal: where backports cannot be had, bookworm's lavapipe stays
  local added=""
  if ! grep -rqs 'bookworm-backports' /etc/apt/sources.list /etc/apt/sources.list.d/; then
    local mirror=${SYLVA_BACKPORTS_MIRROR:-}
    if [[ -z $mirror && -f /etc/apt/sources.list.d/debian.sources ]]; then  # the machine's mirror
      mirror=$(awk '/^URIs:/ && $2 !~ /security/ {print $2; exit}' /etc/apt/sources.list.d/debian.sources)
    fi
    mirror=${mirror:-http://deb.debian.org/debian}
    added=/etc/apt/sources.list.d/sylva-bookworm-backports.sources
    printf 'Types: deb\nURIs: %s\nSuites: bookworm-backports\nComponents: main\nSigned-By: /usr/share/keyrings/debian-archive-keyring.gpg\n' \
      "$mirror" >"$added"
  fi
  if apt-get update &&
    DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends -t bookworm-backports mesa-vulkan-drivers; then
    return 0
  fi
  echo "deps.sh: warning: could not install lavapipe from bookworm-backports; keeping" \
    "mesa-vulkan-drivers $(dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null || echo '(none)')" >&2
  if [[ -n $added ]]; then  # a source that cannot be reached would break later updates
    rm -f "$added"
    apt-get update || true
  fi
  return 0
}

lavapipe=0
lavapipe_wanted && lavapipe=1
if ((${#missing[@]} == 0 && lavapipe == 0)); then
  exit 0
fi

if ((EUID != 0)); then
  if ((lavapipe)); then  # not fatal: bookworm's lavapipe runs every test, only slower
    echo "deps.sh: note: SYLVA_LAVAPIPE=backports: lavapipe from bookworm-backports (mesa-vulkan-drivers" >&2
    echo "  >= $lavapipe_min) is installed only as root; going on with the installed one." >&2
  fi
  ((${#missing[@]} == 0)) && exit 0
  echo "deps.sh: missing Debian packages: ${missing[*]}" >&2
  echo "Install them with:" >&2
  echo "  sudo apt-get install -y --no-install-recommends ${missing[*]}" >&2
  exit 1
fi

if ((${#missing[@]} > 0)); then
  echo "deps.sh: installing ${missing[*]}" >&2
  # Fresh images ship without package lists, so update first; noninteractive because CI has no stdin.
  apt-get update
  DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "${missing[@]}"
fi
if ((lavapipe)); then
  echo "deps.sh: installing lavapipe (mesa-vulkan-drivers) from bookworm-backports" >&2
  install_lavapipe
fi
