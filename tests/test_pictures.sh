#!/bin/sh
# test_pictures.sh PHKS SOURCE - docs/pictures/make.sh, run with this
# build's tool into a scratch folder, makes exactly the pictures committed
# in docs/pictures/, byte for byte: a change of the tool's pictures must
# come with the pictures it makes (rerun make.sh and commit them). Needs
# the shared meshes at $PHKS_SHARED_MESHES and a tool with PNG support;
# exits 77 (skipped) without them. POSIX sh.
set -u
phks=$1
source=$2
case $phks in /*) ;; *) phks=$(pwd)/$phks ;; esac
meshes=${PHKS_SHARED_MESHES:-}
if [ -z "$meshes" ] || [ ! -d "$meshes/psb" ] || [ ! -d "$meshes/scans" ]; then
    echo "SKIP: no shared meshes (PHKS_SHARED_MESHES=$meshes)"
    exit 77
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

fail() {
    echo "FAIL: $*" >&2
    exit 1
}

if ! "$phks" render "$meshes/psb/1.off.gz" -o "$tmp/probe.png" \
        >/dev/null 2>"$tmp/err"; then
    grep -q "built without PNG support" "$tmp/err" &&
        { echo "SKIP: phks was built without libspng"; exit 77; }
    fail "render: $(cat "$tmp/err")"
fi
rm "$tmp/probe.png"

sh "$source/docs/pictures/make.sh" "$phks" "$meshes" "$tmp/made" \
    >"$tmp/out" 2>&1 || { cat "$tmp/out" >&2; fail "make.sh"; }
committed=$(cd "$source/docs/pictures" && ls *.png)
made=$(cd "$tmp/made" && ls *.png)
[ "$made" = "$committed" ] ||
    fail "make.sh makes $(echo $made), docs/pictures/ holds $(echo $committed)"
for picture in $made; do
    cmp -s "$tmp/made/$picture" "$source/docs/pictures/$picture" ||
        fail "$picture differs from docs/pictures/$picture (rerun make.sh)"
done
echo "pictures: $(echo "$made" | wc -l) pictures as committed"
