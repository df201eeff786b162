#!/bin/sh
# compare_builds.sh - are two builds' signatures the same bytes? A one-off
# check for changes that must not move any result (a refactor, a build
# option): encodes the signature of each mesh with both builds' `phks`, under
# a few option sets, and compares the blobs with cmp.
#
#   bench/compare_builds.sh OLD/phks NEW/phks [MESH...]
#
# Without meshes it takes a set from ../shared/data/meshes spanning the PSB
# sizes, an open scan and one mesh above the HKS-simp switch. Prints one
# line a mesh and option set; exits 1 when any pair differs.
set -eu
[ $# -ge 2 ] || { echo "usage: $0 OLD_PHKS NEW_PHKS [MESH...]" >&2; exit 2; }
old=$1 new=$2
shift 2
if [ $# -eq 0 ]; then
    d=$(dirname "$0")/../../shared/data/meshes
    set -- "$d/psb/125.off.gz" "$d/psb/1.off.gz" "$d/psb/77.off.gz" \
           "$d/psb/188.off.gz" "$d/psb/183.off.gz" "$d/psb/322.off.gz" \
           "$d/psb/286.off.gz" "$d/scans/bunny-36k.ply" \
           "$d/scans/hand-closed-8k.obj"
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
status=0
for mesh in "$@"; do
    for opts in "" "--operator literal --boundary-margin 0 --hks-scaling none" \
                "--threads 1"; do
        # shellcheck disable=SC2086  # the option set splits into words
        "$old" $opts signature "$mesh" -o "$tmp/old.sig" >/dev/null 2>&1 || : >"$tmp/old.sig"
        # shellcheck disable=SC2086
        "$new" $opts signature "$mesh" -o "$tmp/new.sig" >/dev/null 2>&1 || : >"$tmp/new.sig"
        if [ ! -s "$tmp/old.sig" ] && [ ! -s "$tmp/new.sig" ]; then
            result="both fail"
        elif cmp -s "$tmp/old.sig" "$tmp/new.sig"; then
            result="same $(wc -c <"$tmp/new.sig") bytes"
        else
            result=DIFFERENT
            status=1
        fi
        printf '%-40s %-60s %s\n' "$(basename "$mesh")" "${opts:-defaults}" "$result"
    done
done
exit $status
