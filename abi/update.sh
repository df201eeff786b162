#!/bin/sh
# abi/update.sh [LIBRARY]
#
# Regenerates abi/libphks.abi, the ABI baseline that abi/check.sh (the
# 'abi' test) compares the built library with. Run it, and commit the
# result, whenever the ABI changes on purpose:
#   - a new PHKS_ABI_VERSION (an incompatible release), or
#   - a compatible change the check cannot tell from a break, such as a
#     field of phks_options carved out of `reserved` (say so in the commit).
# Additions (new functions) pass the check without a new baseline, but
# regenerating then too keeps the baseline complete.
#
# LIBRARY is a libphks.so.* built with debug information (-Ddebug=true, as
# in the debug and debugoptimized build types). Without it, the library is
# built here in a temporary directory. Needs abidw (Debian: abigail-tools),
# meson and ninja.
set -eu
src=$(cd "$(dirname "$0")/.." && pwd)
if ! command -v abidw >/dev/null 2>&1; then
    echo "abidw not found (Debian: apt-get install abigail-tools)" >&2
    exit 1
fi
tmp=$(mktemp -d "${TMPDIR:-/tmp}/phks-abi.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
trap 'exit 1' HUP INT TERM

if [ $# -ge 1 ]; then
    lib=$1
else
    echo "building the shared library with debug information in $tmp"
    meson setup "$tmp/build" "$src" -Dbuildtype=debug -Dtests=false \
        -Dbench=false >"$tmp/setup.log" 2>&1 ||
        { cat "$tmp/setup.log" >&2; exit 1; }
    meson compile -C "$tmp/build" lib/phks:shared_library >"$tmp/build.log" 2>&1 ||
        { cat "$tmp/build.log" >&2; exit 1; }
    lib=$(find "$tmp/build/lib" -maxdepth 1 -type f -name 'libphks.so.*' | head -n 1)
fi
[ -f "$lib" ] || { echo "$lib: no such library" >&2; exit 1; }

# Only what the public header declares, without the paths of this machine.
# Source locations stay (file names only): abidiff needs them to know a
# type as public, and without them it filters every change to one out.
abidw --headers-dir "$src/include" --short-locs --no-corpus-path \
    --no-comp-dir-path --drop-undefined-syms \
    --out-file "$src/abi/libphks.abi" "$lib"
soname=$(sed -n "s/.*soname='\([^']*\)'.*/\1/p" "$src/abi/libphks.abi" | head -n 1)
echo "abi/libphks.abi written from $lib ($soname)"
