#!/bin/sh
# abi/check.sh SOURCE_DIR LIBRARY [SANITIZE]
#
# Compares LIBRARY (a libphks.so.* with debug information) with the
# committed baseline abi/libphks.abi (abidiff, public header only):
#   - passes when nothing changed, or when functions were only added;
#   - fails when a function or type of the baseline was removed or changed,
#     unless PHKS_ABI_VERSION in include/phks.h differs from the baseline's
#     SONAME version (an announced incompatible release: then regenerate
#     the baseline with abi/update.sh).
# A deliberate compatible change that still fails (a field carved out of
# phks_options' reserved space changes a member's type) is accepted by
# regenerating the baseline with abi/update.sh in the same commit.
# SANITIZE is the build's b_sanitize: sanitized builds are skipped.
# Exit status: 0 passed, 1 failed, 77 skipped (no abidiff, sanitized).
set -eu
if [ $# -lt 2 ]; then
    echo "usage: $0 SOURCE_DIR LIBRARY [SANITIZE]" >&2
    exit 1
fi
src=$1
lib=$2
sanitize=${3:-none}
baseline=$src/abi/libphks.abi
header=$src/include/phks.h

if [ "$sanitize" != none ]; then
    echo "SKIP: sanitized build (b_sanitize=$sanitize)"
    exit 77
fi
if ! command -v abidiff >/dev/null 2>&1; then
    echo "SKIP: abidiff not found (Debian: apt-get install abigail-tools)"
    exit 77
fi
if [ ! -f "$baseline" ]; then
    echo "FAIL: no baseline $baseline: run abi/update.sh"
    exit 1
fi

abi=$(sed -n 's/^#define PHKS_ABI_VERSION \([0-9][0-9]*\).*/\1/p' "$header")
soname=$(sed -n "s/.*soname='\([^']*\)'.*/\1/p" "$baseline" | head -n 1)
base_abi=${soname##*.so.}
if [ -z "$abi" ] || [ -z "$base_abi" ]; then
    echo "FAIL: cannot read PHKS_ABI_VERSION ($abi) or the baseline SONAME ($soname)"
    exit 1
fi
if [ "$abi" != "$base_abi" ]; then
    echo "PASS: PHKS_ABI_VERSION is $abi, the baseline's $base_abi: an"
    echo "incompatible release; regenerate the baseline with abi/update.sh"
    exit 0
fi

tmp=$(mktemp -d "${TMPDIR:-/tmp}/phks-abi.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
trap 'exit 1' HUP INT TERM
status=0
abidiff --headers-dir2 "$src/include" "$baseline" "$lib" >"$tmp/report" 2>&1 ||
    status=$?
cat "$tmp/report"
# abidiff's status is a bit set: 1 error, 2 usage, 4 change, 8 break.
if [ $((status & 3)) -ne 0 ]; then
    echo "FAIL: abidiff could not compare (status $status)"
    exit 1
fi
if [ $((status & 8)) -ne 0 ]; then
    echo "FAIL: incompatible ABI change with PHKS_ABI_VERSION still $abi"
    exit 1
fi
# A change that abidiff does not call incompatible is still refused when
# it removes or changes anything; additions are fine.
if grep -E '[1-9][0-9]* (Removed|Changed)' "$tmp/report" >/dev/null; then
    echo "FAIL: functions, variables or types of the baseline changed with"
    echo "PHKS_ABI_VERSION still $abi (if compatible on purpose: abi/update.sh)"
    exit 1
fi
echo "PASS: compatible with the baseline ($soname)"
exit 0
