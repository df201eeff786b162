#!/bin/sh
# docs/pictures/make.sh [PHKS [MESHES [OUT]]] - makes the pictures of
# docs/pictures.md with `phks render` and `phks db query --png` from the
# shared meshes (read in place; the meshes themselves are not
# redistributable, the pictures are our renderings of them). Rerun it
# after a change of the tool's pictures; the output is deterministic, so
# `git status` shows which pictures changed (the `pictures` test checks
# that the committed ones are what it makes).
#
#   PHKS    the tool (default build/tools/phks/phks)
#   MESHES  the shared meshes (default $PHKS_SHARED_MESHES, else
#           /work/shared/data/meshes)
#   OUT     where the pictures go (default this folder)
set -eu
here=$(cd "$(dirname "$0")" && pwd)
phks=${1:-$here/../../build/tools/phks/phks}
case $phks in /*) ;; *) phks=$(pwd)/$phks ;; esac
meshes=${2:-${PHKS_SHARED_MESHES:-/work/shared/data/meshes}}
out=${3:-$here}
mkdir -p "$out"
out=$(cd "$out" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# Database names are the paths as given: relative to the meshes' folder,
# so that the contact sheet finds the meshes and prints short names.
cd "$meshes"

# A PSB human's 15 HKS regions at t = 5 tau and its feature points.
"$phks" render psb/1.off.gz -o "$out/human-regions.png" --size 480x360
# The same model's coarser regions at t = 100 tau: fewer maxima survive.
"$phks" render psb/1.off.gz -o "$out/human-regions-100.png" --size 480x360 \
    --time 100
# Two poses of a human: the verified pairs of phks_match, and all of A's
# rows, the unverified faint.
"$phks" render psb/1.off.gz psb/3.off.gz -o "$out/match-poses.png" \
    --size 480x360
"$phks" render psb/1.off.gz psb/3.off.gz -o "$out/match-poses-all.png" \
    --size 480x360 --pairs all
# The Stanford bunny in its file's axes (y up), from below: the holes of
# the scan, their boundary edges drawn dark; and in its default view,
# which turns them away.
"$phks" render scans/bunny-36k.ply -o "$out/bunny-below.png" --size 480x360 \
    --up y --view 30,-45
"$phks" render scans/bunny-36k.ply -o "$out/bunny-default.png" \
    --size 480x360
# An octopus: one region per arm.
"$phks" render psb/121.off.gz -o "$out/octopus-regions.png" --size 480x360
# A contact sheet: a human queried against a small mixed database.
add() { "$phks" db add "$tmp/shapes.db" -j 2 --label "$@" >/dev/null; }
add Human psb/2.off.gz psb/4.off.gz psb/9.off.gz
add Ant psb/84.off.gz
add Teddy psb/161.off.gz
add Hand psb/181.off.gz
add Octopus psb/121.off.gz
add Armadillo psb/281.off.gz
"$phks" db query "$tmp/shapes.db" psb/3.off.gz -k 7 \
    --png "$out/query-sheet.png"
ls -l "$out"/*.png
