#!/bin/sh
# compare_builds.sh - do two builds give the same bits? A one-off check for
# changes that must not move any result (a refactor, a build option). With
# both builds' `phks`, on one BLAS thread:
#   - the signature blob of each mesh under a few option sets (cmp);
#   - `phks match A B --json` of every ordered pair of the meshes'
#     default signatures (scores and correspondences);
#   - `phks db query DB SIG -k 10 --json` of each of them against a
#     database of all of them, filled by that build.
#
#   bench/compare_builds.sh OLD/phks NEW/phks [MESH...]
#
# KEEP=1 keeps the working folder (printed by mktemp) to look at a
# difference.
# Without meshes it takes a set from ../shared/data/meshes spanning the PSB
# sizes, an open scan and one mesh above the HKS-simp switch. Prints one
# line a mesh and option set, one for the matches and one for the queries;
# exits 1 when any pair differs.
set -eu
[ $# -ge 2 ] || { echo "usage: $0 OLD_PHKS NEW_PHKS [MESH...]" >&2; exit 2; }
old=$(realpath "$1") new=$(realpath "$2")
# The tool of build `old` or `new`.
phks_of() {
    if [ "$1" = old ]; then echo "$old"; else echo "$new"; fi
}
shift 2
if [ $# -eq 0 ]; then
    d=$(dirname "$0")/../../shared/data/meshes
    set -- "$d/psb/125.off.gz" "$d/psb/1.off.gz" "$d/psb/77.off.gz" \
           "$d/psb/188.off.gz" "$d/psb/183.off.gz" "$d/psb/322.off.gz" \
           "$d/psb/286.off.gz" "$d/scans/bunny-36k.ply" \
           "$d/scans/hand-closed-8k.obj"
fi
export OPENBLAS_NUM_THREADS=1
tmp=$(mktemp -d)
trap '[ -n "${KEEP:-}" ] && echo "kept $tmp" || rm -rf "$tmp"' EXIT
mkdir "$tmp/old" "$tmp/new"
status=0

# "same N bytes", "both fail" or DIFFERENT (and status 1) for two files, an
# empty file standing for a failed run.
verdict() {
    if [ ! -s "$1" ] && [ ! -s "$2" ]; then
        echo "both fail"
    elif cmp -s "$1" "$2"; then
        echo "same $(wc -c <"$2") bytes"
    else
        echo DIFFERENT
        return 1
    fi
}

n=0
for mesh in "$@"; do
    n=$((n + 1))
    for opts in "" "--operator literal --boundary-margin 0 --hks-scaling none" \
                "--threads 1"; do
        for build in old new; do
            phks=$(phks_of "$build")
            # shellcheck disable=SC2086  # the option set splits into words
            "$phks" $opts signature "$mesh" -o "$tmp/$build/s.sig" \
                >/dev/null 2>&1 || : >"$tmp/$build/s.sig"
        done
        result=$(verdict "$tmp/old/s.sig" "$tmp/new/s.sig") || status=1
        printf '%-40s %-60s %s\n' "$(basename "$mesh")" "${opts:-defaults}" \
            "$result"
        # The default signatures, named by their place in the list, are
        # those the matches and queries below compare.
        if [ -z "$opts" ]; then
            for build in old new; do
                mv "$tmp/$build/s.sig" "$tmp/$build/$n.sig"
            done
        fi
    done
done

# Relative names, so that the JSON of the two builds (which names its
# inputs) can be compared byte for byte.
for build in old new; do
    (
        cd "$tmp/$build"
        phks=$(phks_of "$build")
        : >match.json
        : >query.json
        for a in $(seq "$n"); do
            for b in $(seq "$n"); do
                if [ ! -s "$a.sig" ] || [ ! -s "$b.sig" ]; then
                    continue
                fi
                "$phks" match "$a.sig" "$b.sig" --json >>match.json 2>&1 ||
                    echo "match $a $b failed" >>match.json
            done
        done
        sigs=$(for i in $(seq "$n"); do [ -s "$i.sig" ] && echo "$i.sig"; done)
        # One worker: several add in the order they finish, and ids (the
        # queries' tie-break) would follow it.
        # shellcheck disable=SC2086  # one argument per signature
        "$phks" db add all.db -j 1 $sigs >/dev/null 2>&1 ||
            echo "db add failed" >>query.json
        for s in $sigs; do
            "$phks" db query all.db "$s" -k 10 --json >>query.json 2>&1 ||
                echo "query $s failed" >>query.json
        done
    )
done
pairs=$(grep -c '"score"' "$tmp/new/match.json" || :)
result=$(verdict "$tmp/old/match.json" "$tmp/new/match.json") || status=1
printf '%-40s %-60s %s\n' "match --json" "$pairs ordered pairs" "$result"
result=$(verdict "$tmp/old/query.json" "$tmp/new/query.json") || status=1
printf '%-40s %-60s %s\n' "db query -k 10 --json" "$n queries" "$result"
exit $status
