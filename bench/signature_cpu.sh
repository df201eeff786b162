#!/bin/sh
# signature_cpu.sh - the processor time (user + system) of `phks --threads 1
# signature` of two builds, model by model, alternating, on every PSB model
# of the shared manifest: one line a model, then the sums and their ratio
# new / old.
#
#   bench/signature_cpu.sh OLD/phks NEW/phks [MANIFEST]
#
# MANIFEST defaults to ../shared/data/meshes/MANIFEST.tsv beside the
# repository. POSIX sh; needs GNU time (/usr/bin/time) and awk.
set -eu
[ $# -ge 2 ] || { echo "usage: $0 OLD_PHKS NEW_PHKS [MANIFEST]" >&2; exit 2; }
old=$(realpath "$1") new=$(realpath "$2")
here=$(cd "$(dirname "$0")" && pwd)
manifest=$(realpath "${3:-$here/../../shared/data/meshes/MANIFEST.tsv}")
meshes=$(dirname "$manifest")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# cpu PHKS MESH: user + system seconds of one signature
cpu() {
    OPENBLAS_NUM_THREADS=1 /usr/bin/time -o "$tmp/time" -f "%U %S" \
        "$1" --threads 1 signature "$2" -o "$tmp/out.sig" >/dev/null 2>&1 ||
        { echo "$0: $1 failed on $2" >&2; exit 1; }
    awk '{ printf "%.2f\n", $1 + $2 }' "$tmp/time"
}

for f in $(awk -F'\t' 'NR > 1 && $1 ~ /^psb\// { print $1 }' "$manifest"); do
    echo "$f $(cpu "$old" "$meshes/$f") $(cpu "$new" "$meshes/$f")"
done | awk '{ print; o += $2; n += $3 }
            END { printf "sum %.1f %.1f ratio %.3f\n", o, n, n / o }'
