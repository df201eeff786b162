#!/bin/sh
# test_exports.sh HEADER SHARED_LIBRARY
#
# Checks the ABI surface of the shared library against the public header:
#   - it exports exactly the functions declared PHKS_API in phks.h
#     (names missing from the library and extra names are listed),
#   - it exports nothing else: no data, no symbol without the phks_ prefix,
#   - its SONAME is libphks.so.<PHKS_ABI_VERSION>.
# Exit status: 0 passed, 1 failed, 77 skipped (no nm, readelf or cc).
set -eu

if [ $# -ne 2 ]; then
    echo "usage: $0 HEADER SHARED_LIBRARY" >&2
    exit 1
fi
header=$1
lib=$2
cc=${CC:-cc}
for tool in nm readelf "$cc"; do
    if ! command -v "$tool" >/dev/null 2>&1; then
        echo "SKIP: $tool not found"
        exit 77
    fi
done

tmp=$(mktemp -d "${TMPDIR:-/tmp}/phks-exports.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
trap 'exit 1' HUP INT TERM
status=0

# Declared: the preprocessor removes comments and turns PHKS_API into the
# visibility attribute; then each declaration (up to its ';') that carries
# the attribute names its function just before the first '('.
"$cc" -E -P -x c "$header" >"$tmp/header.i"
tr '\n' ' ' <"$tmp/header.i" | tr ';' '\n' |
    grep 'visibility *( *"default" *)' |
    sed 's/.*visibility *( *"default" *) *) *) *//; s/(.*//' |
    awk '{ print $NF }' | tr -d '*' | sort -u >"$tmp/declared"
if [ ! -s "$tmp/declared" ]; then
    echo "FAIL: no PHKS_API declaration found in $header"
    exit 1
fi

# Exported: dynamic symbols defined by the library, without the version
# suffix (@@PHKS_1). Type A entries are version nodes, not symbols.
nm -D --defined-only "$lib" | awk '$2 != "A" { sub(/@.*/, "", $3); print $2, $3 }' |
    sort -k2 >"$tmp/exported_all"
awk '$1 ~ /^[TtWi]$/ { print $2 }' "$tmp/exported_all" | sort -u >"$tmp/exported"
awk '$1 !~ /^[TtWi]$/ { print $1, $2 }' "$tmp/exported_all" >"$tmp/data"

comm -23 "$tmp/declared" "$tmp/exported" >"$tmp/missing"
comm -13 "$tmp/declared" "$tmp/exported" >"$tmp/extra"
grep -v '^phks_' "$tmp/exported" >"$tmp/foreign" || true

echo "declared PHKS_API functions: $(wc -l <"$tmp/declared")," \
     "exported functions: $(wc -l <"$tmp/exported")"
if [ -s "$tmp/missing" ]; then
    echo "FAIL: declared in phks.h but not exported ($(wc -l <"$tmp/missing")):"
    sed 's/^/  /' "$tmp/missing"
    status=1
fi
if [ -s "$tmp/extra" ]; then
    echo "FAIL: exported but not declared PHKS_API in phks.h ($(wc -l <"$tmp/extra")):"
    sed 's/^/  /' "$tmp/extra"
    status=1
fi
if [ -s "$tmp/foreign" ]; then
    echo "FAIL: exported symbols without the phks_ prefix:"
    sed 's/^/  /' "$tmp/foreign"
    status=1
fi
if [ -s "$tmp/data" ]; then
    echo "FAIL: exported data symbols (type and name):"
    sed 's/^/  /' "$tmp/data"
    status=1
fi

abi=$(sed -n 's/^#define PHKS_ABI_VERSION \([0-9][0-9]*\).*/\1/p' "$header")
soname=$(readelf -d "$lib" | sed -n 's/.*(SONAME).*\[\(.*\)\].*/\1/p')
if [ "$soname" != "libphks.so.$abi" ]; then
    echo "FAIL: SONAME is '$soname', expected libphks.so.$abi"
    status=1
else
    echo "SONAME $soname"
fi

[ $status -eq 0 ] && echo "PASS"
exit $status
