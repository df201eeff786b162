#!/bin/sh
# fuzz/run.sh BUILD_DIR TARGET [LIBFUZZER_OPTION...]
#
# Fuzzes TARGET (fuzz_off, fuzz_obj, fuzz_ply, fuzz_stl, fuzz_load,
# fuzz_gzip, fuzz_signature, fuzz_db) as built in BUILD_DIR (configured with
# CC=clang and -Dfuzzing=true), with the dictionary and input size that
# suit it. New inputs go to a work corpus, never to the committed seeds:
#   $PHKS_FUZZ_WORK/TARGET            (default /tmp/phks-fuzz)
#   $PHKS_FUZZ_WORK/TARGET-artifacts  crashes, leaks, timeouts
# Extra options go to libFuzzer, e.g. -runs=10000000 or -max_total_time=600.
set -eu
if [ $# -lt 2 ]; then
    echo "usage: $0 BUILD_DIR TARGET [LIBFUZZER_OPTION...]" >&2
    exit 1
fi
build=$1
target=$2
shift 2
here=$(cd "$(dirname "$0")" && pwd)
work=${PHKS_FUZZ_WORK:-/tmp/phks-fuzz}
exe=$build/fuzz/$target
[ -x "$exe" ] || { echo "$exe: not built (ninja -C $build fuzz/$target)" >&2; exit 1; }
mkdir -p "$work/$target" "$work/$target-artifacts"

max_len=4096
case $target in
fuzz_off) cat "$here/dict/off.dict" >"$work/$target.dict" ;;
fuzz_obj) cat "$here/dict/obj.dict" >"$work/$target.dict" ;;
fuzz_ply) cat "$here/dict/ply.dict" >"$work/$target.dict" ;;
fuzz_stl) cat "$here/dict/stl.dict" >"$work/$target.dict" ;;
fuzz_load) cat "$here"/dict/*.dict >"$work/$target.dict" ;;
fuzz_gzip) cat "$here"/dict/*.dict >"$work/$target.dict"; max_len=65536 ;;
fuzz_db) : >"$work/$target.dict"; max_len=16384 ;;
*) : >"$work/$target.dict" ;;
esac
dict=
[ -s "$work/$target.dict" ] && dict=-dict=$work/$target.dict

# -timeout: any input taking over 10 s is a bug; -rss_limit_mb bounds what a
# hostile input may make the loader allocate (the gzip cap is 2 GiB).
exec "$exe" $dict -max_len=$max_len -timeout=10 -rss_limit_mb=3072 \
    -print_final_stats=1 -artifact_prefix="$work/$target-artifacts/" \
    "$@" "$work/$target" "$here/corpus/$target"
