#!/bin/sh
# test_determinism.sh PHKS - a signature's blob and the scores between
# signatures are the same bytes whatever the BLAS's thread count
# (OPENBLAS_NUM_THREADS 1, 2, 4) and the tool's own (--threads 1, 2, 4), on
# shared meshes that take each default eigen path: a PSB model (block
# Lanczos), a scan above the HKS-simp switch (Lanczos on the samples), a
# CAD soup under 1000 vertices (the dense solver) and one above (Lanczos
# with the null space of its many shells deflated). Needs the meshes at
# $PHKS_SHARED_MESHES; exits 77 (skipped) without them. POSIX sh.
set -u
phks=$1
case $phks in /*) ;; *) phks=$(pwd)/$phks ;; esac
meshes=${PHKS_SHARED_MESHES:-}
set -- psb/1.off.gz scans/bunny-36k.ply cad/Bookset_D01042.off.gz \
       cad/Bicycle_D00016.off.gz
for mesh in "$@"; do
    if [ -z "$meshes" ] || [ ! -f "$meshes/$mesh" ]; then
        echo "SKIP: shared mesh $mesh not found (PHKS_SHARED_MESHES=$meshes)"
        exit 77
    fi
done
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

fail() {
    echo "FAIL: $*" >&2
    exit 1
}

# The thread counts as "BLAS-tool": the BLAS's varied under the tool's
# 2, the tool's varied under the BLAS's 2; 1-1 is the reference.
settings="1-1 1-2 2-2 4-2 2-1 2-4"

# Each setting's blobs in a folder of its own, under the same names, so
# that the scores' output (which names its files) compares as it is.
# signature MESH SETTING: the blob into SETTING/NAME.sig
signature() {
    blas=${2%-*} tool=${2#*-}
    OPENBLAS_NUM_THREADS=$blas "$phks" --threads "$tool" signature \
        "$meshes/$1" -o "$2/$(basename "$1").sig" >/dev/null 2>err ||
        fail "$1 under OPENBLAS_NUM_THREADS=$blas --threads $tool: $(cat err)"
}

cd "$tmp" || exit 1
for s in $settings; do
    mkdir "$s"
done
for mesh in "$@"; do
    sig=$(basename "$mesh").sig
    for s in $settings; do
        signature "$mesh" "$s"
        cmp -s "1-1/$sig" "$s/$sig" ||
            fail "$mesh: the blob under threads $s (BLAS-tool) differs from" \
                 "1-1 at byte $(cmp "1-1/$sig" "$s/$sig" | awk '{print $5}')"
    done
done

# Every pair's score, from the blobs of each setting, under that setting.
for s in $settings; do
    for a in "$@"; do
        for b in "$@"; do
            (cd "$s" && OPENBLAS_NUM_THREADS=${s%-*} "$phks" --threads \
                "${s#*-}" match "$(basename "$a").sig" "$(basename "$b").sig" \
                --json) >>"scores.$s" 2>err ||
                fail "match $a $b under threads $s: $(cat err)"
        done
    done
    cmp -s scores.1-1 "scores.$s" ||
        fail "the scores under threads $s (BLAS-tool) differ from 1-1"
done
echo "same bytes under every thread setting: $*"
