#!/bin/sh
# test_db_full.sh PHKS - `phks db add` on a full disk: a 4 MiB tmpfs in a
# mount namespace of its own, filled but for 0, 64 KiB (less than a commit
# of 64 KiB pages takes) and 2 MiB. An add that does not fit exits 1 and
# says why ("disk is full", or the system's "No space left on device" when
# the open cannot even map the WAL's shared memory); once there is space,
# the entries before are all there and a query answers as before. Needs
# root (mount); skips (77) without it. POSIX sh; needs python3.
set -u
phks=$1
case $phks in /*) ;; *) phks=$(pwd)/$phks ;; esac
helpers=$(cd "$(dirname "$0")" && pwd)/cli_helpers.sh
py=/usr/bin/python3

# Inside the namespace: the tmpfs, then the checks.
if [ "${2:-}" = --inside ]; then
    cd "$3" || exit 1
    . "$helpers"
    phks=$(at_vertices "$phks")
    mkdir disk && mount -t tmpfs -o size=4M tmpfs disk ||
        { echo "SKIP: cannot mount a tmpfs"; exit 77; }
    run "$phks" db add disk/t.db m0.off m1.off -j 2; expect_rc 0 "db add"
    for room in 0 64 2048; do
        "$phks" db list disk/t.db --json > before.json || fail "db list"
        "$phks" db query disk/t.db m0.off -k 3 > query.txt || fail "db query"
        dd if=/dev/zero of=disk/fill bs=4k 2>/dev/null
        truncate -s "-${room}K" disk/fill
        run "$phks" db add disk/t.db m2.off m3.off m4.off -j 2
        rm disk/fill
        case $room in
        2048) expect_rc 0 "db add with 2 MiB free" ;;
        *) expect_rc 1 "db add with $room KiB free"
           grep -q "disk is full\|No space left on device" err ||
               fail "db add with $room KiB free: no clear message"
           expect_out "^disk/t.db: 0 added, 3 failed$" ;;
        esac
        "$phks" db list disk/t.db --json > after.json || fail "db list after"
        $py -c 'import json,sys
before, after = (json.load(open(f)) for f in sys.argv[1:])
assert after[:len(before)] == before, (before, after)' before.json after.json ||
            fail "$room KiB free: entries before the full disk changed"
        run "$phks" db query disk/t.db m0.off -k 3; expect_rc 0 "db query after"
        [ "$room" = 2048 ] || cmp -s out query.txt ||
            fail "$room KiB free: the query answers otherwise"
    done
    exit 0
fi

[ "$(id -u)" = 0 ] || { echo "SKIP: a tmpfs needs root"; exit 77; }
command -v unshare >/dev/null || { echo "SKIP: no unshare"; exit 77; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
(
    cd "$tmp" || exit 1
    . "$helpers"
    for i in 0 1 2 3 4; do
        blob 24 12 1.$i 1.0 0.5 0.3$i 3 > "m$i.off"
    done
)
unshare -m true 2>/dev/null || { echo "SKIP: no mount namespace"; exit 77; }
unshare -m sh "$0" "$phks" --inside "$tmp"
