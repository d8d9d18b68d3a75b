#!/usr/bin/env bash
# Checks that a fresh machine would have everything the build in BUILD used from the system:
# every such file must belong to a Debian package that scripts/deps.sh installs, to a package
# those depend on (transitively), or to an Essential package. A file that only happened to be
# on this machine (installed by hand or by earlier work) fails the check with its package named.
# This is the failure CI once missed: OpenImageIO's CMake package needs /usr/bin/iconvert from
# openimageio-tools, which deps.sh did not install but the CI machine had.
#   scripts/check-deps.sh BUILD_DIR     exit 0: all declared; 1: something is not; 77: not Debian
#
# Files checked: the CMake package configs the build loaded (CMakeCache *_DIR) and every file
# they reference through ${_IMPORT_PREFIX}; the tools in the cache (compiler, glslangValidator,
# spirv-val; not CTest's dashboard tools); every system header the compiler read
# (the compilers' .o.d files); every system library linked (link.txt); lavapipe's ICD manifest.
set -euo pipefail
build=${1:?usage: check-deps.sh BUILD_DIR}
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cache="$build/CMakeCache.txt"
if ! command -v dpkg-query >/dev/null || ! command -v dpkg >/dev/null; then
  echo "SKIP: no dpkg: this check needs Debian's package database"
  exit 77
fi
[[ -f $cache ]] || { echo "check-deps: no $cache: configure and build first" >&2; exit 1; }

# ---- the files the build used ------------------------------------------------------------
files=$(mktemp)
missing=$(mktemp)
trap '[[ -n ${KEEP:-} ]] || rm -f "$files" "$missing" "$files".*' EXIT
# Package config folders and every file in them.
while IFS= read -r dir; do
  [[ -d $dir && $dir != "$root"* && $dir != "$build"* ]] || continue
  compgen -G "$dir/*[Cc]onfig.cmake" >/dev/null || continue  # an include folder, not a package config
  find "$dir" -maxdepth 1 -type f -name '*.cmake' >>"$files"
  # Files the exported targets name: ${_IMPORT_PREFIX}/bin/iconvert and the like. The prefix is
  # the config folder's path up to its lib/ or share/ folder (/usr for Debian's packages).
  prefix=$(sed -E 's#/(lib|share)/.*##' <<<"$dir")
  { grep -ho '\${_IMPORT_PREFIX}/[^";) ]*' "$dir"/*.cmake || true; } | sort -u |
    while IFS= read -r ref; do
      path="${prefix}${ref#\$\{_IMPORT_PREFIX\}}"
      [[ $path == *'$'* ]] && continue  # generator expressions or other variables: not a file
      if [[ -e $path ]]; then
        echo "$path" >>"$files"
      elif grep -q 'FATAL_ERROR "The imported target' "$dir"/*.cmake; then  # older exports refuse to load
        echo "$path (named by $dir)" >>"$missing"
      fi  # newer exports only print a STATUS line (Imath's Python module): CMake goes on
    done
done < <(sed -nE 's/^[A-Za-z0-9_]+_DIR:PATH=(\/.+)$/\1/p' "$cache")
# Tools and libraries the cache found (CTest's dashboard tools are never run by the suite).
sed -nE 's/^([A-Za-z0-9_]+):FILEPATH=(\/.+)$/\1 \2/p' "$cache" |
  grep -vE '^(GITCOMMAND|MEMORYCHECK_COMMAND|COVERAGE_COMMAND|CMAKE_ADDR2LINE|CMAKE_OBJDUMP|CMAKE_READELF) ' |
  cut -d' ' -f2- | while IFS= read -r f; do [[ -e $f ]] && echo "$f"; done >>"$files"
# System headers the compiler read, and system libraries linked.
find "$build" -name '*.o.d' -exec grep -ho '/usr/[^ :\\]*' {} + 2>/dev/null >>"$files" || true
find "$build" -name link.txt -exec grep -ho '/usr/[^ ]*\.so[.0-9]*' {} + 2>/dev/null >>"$files" || true
[[ -e /usr/share/vulkan/icd.d/lvp_icd.x86_64.json ]] && echo /usr/share/vulkan/icd.d/lvp_icd.x86_64.json >>"$files"
# Regular files only: a folder belongs to many packages and says nothing.
sort -u "$files" | while IFS= read -r f; do [[ -f $f ]] && echo "$f"; done >"$files.regular" || true
mv "$files.regular" "$files"

# ---- which package owns each -------------------------------------------------------------
# dpkg knows merged-/usr files by their packaged path (/bin/x may be /usr/bin/x and the other
# way round) and alternatives by their target, so each file is tried as given, with /usr
# added or removed, and resolved.
candidates() {
  local f=$1
  echo "$f"
  case $f in /usr/*) echo "${f#/usr}" ;; *) echo "/usr$f" ;; esac
  local r
  r=$(readlink -f "$f" 2>/dev/null || true)
  [[ -n $r && $r != "$f" ]] && { echo "$r"; case $r in /usr/*) echo "${r#/usr}" ;; esac; }
  true
}
owners="$files.owners"
unowned="$files.unowned"
: >"$owners"
: >"$unowned"
# One dpkg -S over every candidate path (one call reads the database once).
xargs -a "$files" -d '\n' -I{} bash -c "$(declare -f candidates); candidates '{}'" | sort -u >"$files.cand"
xargs -a "$files.cand" -d '\n' dpkg -S 2>/dev/null | grep -v '^diversion by' >"$files.dpkg" || true
while IFS= read -r f; do
  owner=""
  while IFS= read -r c; do
    owner=$(awk -v p="$c" 'index($0, ": " p) && substr($0, length($0) - length(p) + 1) == p { sub(/: .*/, ""); print; exit }' "$files.dpkg")
    [[ -n $owner ]] && break
  done < <(candidates "$f")
  if [[ -z $owner ]]; then echo "$f" >>"$unowned"; else tr -d ' ' <<<"$owner" | tr ',' '\n' | sed -E "s#:[a-z0-9]+\$##; s#\$# $f#" >>"$owners"; fi
done <"$files"

# ---- what a fresh machine has: deps.sh's packages, what they depend on, Essential ----------
# From dpkg's own database (no package lists needed): Depends and Pre-Depends of installed
# packages, every alternative of an "a | b" taken, virtual packages through Provides.
closure=$(
  {
    bash "$root/scripts/deps.sh" --list | sed 's/^/ROOT\t/'
    dpkg-query -W -f='${db:Status-Abbrev}\t${Package}\t${Essential}\t${Provides}\t${Depends}, ${Pre-Depends}\n' |
      awk -F'\t' '$1 ~ /^ii/ { print "PKG\t" $2 "\t" $3 "\t" $4 "\t" $5 }'
  } | awk -F'\t' '
    function names(s, out,   n, parts, i, w) {
      gsub(/\([^)]*\)/, "", s); gsub(/:[a-z0-9]+/, "", s); gsub(/[|,]/, " ", s)
      n = split(s, parts, " ")
      for (i = 1; i <= n; i++) if (parts[i] != "") out[parts[i]] = 1
    }
    $1 == "ROOT" { queue[++qn] = $2; next }
    {
      pkg = $2; installed[pkg] = 1
      if ($3 == "yes") queue[++qn] = pkg
      delete prov; names($4, prov); for (v in prov) providers[v] = providers[v] " " pkg
      deps[pkg] = $5
    }
    END {
      for (qi = 1; qi <= qn; qi++) {
        p = queue[qi]
        if (p in seen) continue
        seen[p] = 1
        if (p in installed) { print p; delete d; names(deps[p], d); for (x in d) queue[++qn] = x }
        if (p in providers) { m = split(providers[p], ps, " "); for (i = 1; i <= m; i++) queue[++qn] = ps[i] }
      }
    }' | sort -u
)

# ---- verdict -----------------------------------------------------------------------------
bad=$(awk 'NR == FNR { ok[$1] = 1; next } !($1 in ok)' <(echo "$closure") "$owners" | sort -u)
checked=$(wc -l <"$files")
status=0
if [[ -s $missing ]]; then
  echo "check-deps: files named by CMake package configs do not exist:"
  sed 's/^/  /' "$missing"
  status=1
fi
if [[ -n $bad ]]; then
  echo "check-deps: the build used files of packages that scripts/deps.sh does not install (nor anything it pulls in):"
  awk '{ files[$1] = files[$1] (files[$1] ? ", " : "") $2; n[$1]++ }
       END { for (p in files) printf "  %s: %s%s\n", p, substr(files[p], 1, 200), (n[p] > 3 ? " ..." : "") }' <<<"$bad" | sort
  echo "A fresh machine lacks them: add them to scripts/deps.sh (or stop using them)."
  status=1
fi
if [[ -s $unowned ]]; then
  echo "check-deps: $(wc -l <"$unowned") file(s) belong to no package (made at install time); not checked:"
  head -5 "$unowned" | sed 's/^/  /'
fi
echo "check-deps: $checked system files checked, owned by $(cut -d' ' -f1 "$owners" | sort -u | wc -l) packages;" \
  "$(wc -l <<<"$closure") packages come with scripts/deps.sh on a fresh machine"
exit $status
