#!/bin/sh
# time_builds.sh - signature time of two builds of `phks`, alternating, on
# a shared machine: the median wall time of RUNS runs (5) of `phks
# signature MESH` under each OPENBLAS_NUM_THREADS of BLAS_THREADS ("1 2"),
# one line a mesh and thread count with the ratio new / old.
#
#   bench/time_builds.sh OLD/phks NEW/phks MESH...
#
# POSIX sh; needs awk and date +%s%N (GNU).
set -eu
[ $# -ge 3 ] || { echo "usage: $0 OLD_PHKS NEW_PHKS MESH..." >&2; exit 2; }
old=$(realpath "$1") new=$(realpath "$2")
shift 2
runs=${RUNS:-5}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# seconds PHKS MESH BLAS: the wall time of one signature
seconds() {
    start=$(date +%s%N)
    OPENBLAS_NUM_THREADS=$3 "$1" signature "$2" -o "$tmp/out.sig" >/dev/null
    end=$(date +%s%N)
    awk -v s="$start" -v e="$end" 'BEGIN { printf "%.3f\n", (e - s) / 1e9 }'
}

median() {
    sort -n "$1" | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'
}

for mesh in "$@"; do
    for blas in ${BLAS_THREADS:-1 2}; do
        : >"$tmp/old"
        : >"$tmp/new"
        i=0
        while [ $i -lt "$runs" ]; do
            seconds "$old" "$mesh" "$blas" >>"$tmp/old"
            seconds "$new" "$mesh" "$blas" >>"$tmp/new"
            i=$((i + 1))
        done
        a=$(median "$tmp/old") b=$(median "$tmp/new")
        echo "$mesh OPENBLAS_NUM_THREADS=$blas old $a s new $b s" \
             "ratio $(awk -v a="$a" -v b="$b" 'BEGIN { printf "%.2f", b / a }')"
    done
done
