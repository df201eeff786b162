#!/bin/sh
# test_render.sh PHKS - the pictures of the `phks` tool (`render`, `db query
# --png`) on small meshes made here: valid PNGs of the asked size that
# decode (with /usr/bin/python3 and zlib) to pictures showing the region
# colours and the feature markers, a wider picture for two meshes, a
# contact sheet of k + 1 tiles, the same bytes on every run, and the usage
# errors. Skipped (exit 77) when the tool was built without libspng.
set -u
phks=$1
case $phks in /*) ;; *) phks=$(pwd)/$phks ;; esac
py=/usr/bin/python3
helpers=$(cd "$(dirname "$0")" && pwd)/cli_helpers.sh
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cd "$tmp" || exit 1

. "$helpers"

blob 24 12 1.0 1.0 0.5 0.35 3 > a.off
blob 24 12 1.0 0.9 0.5 0.30 3 > b.off
blob 24 12 1.2 0.4 0.3 0.05 2 > c.off
printf 'not a mesh\n' > bad.off

run "$phks" render a.off -o probe.png --size 64x48
if [ "$rc" = 1 ] && grep -q "built without PNG support" err; then
    echo "SKIP: phks was built without libspng (no PNG support)"
    exit 77
fi
expect_rc 0 "render probe"
[ -x "$py" ] || { echo "SKIP: no $py to decode the PNGs"; exit 77; }

# png FILE W H CHECKS...: decodes FILE and checks it (exit 1 with a
# message when it is wrong): its size, that it is not blank, and
#   regions R N   at least N of the first R region colours (10 pixels each)
#   markers M     at least M pixels of the feature markers' black
#   tiles N T C   tiles of T x T, C to a row: the first N drawn, others empty
#   colour R,G,B  at least 10 pixels of that colour
png() {
    "$py" - "$@" <<'EOF'
import struct, sys, zlib
args = sys.argv[1:]
path, want_w, want_h = args[0], int(args[1]), int(args[2])
def die(msg):
    sys.exit("%s: %s" % (path, msg))
data = open(path, 'rb').read()
if data[:8] != b'\x89PNG\r\n\x1a\n':
    die("no PNG signature")
pos, idat, ihdr, chunks = 8, b'', None, []
while pos < len(data):
    n, kind = struct.unpack('>I4s', data[pos:pos + 8])
    body = data[pos + 8:pos + 8 + n]
    crc, = struct.unpack('>I', data[pos + 8 + n:pos + 12 + n])
    if zlib.crc32(kind + body) != crc:
        die("bad CRC in %r" % kind)
    chunks.append(kind)
    if kind == b'IHDR':
        ihdr = struct.unpack('>IIBBBBB', body)
    elif kind == b'IDAT':
        idat += body
    pos += 12 + n
if chunks[0] != b'IHDR' or chunks[-1] != b'IEND':
    die("chunks %r" % chunks)
w, h, depth, colour = ihdr[:4]
if (w, h) != (want_w, want_h):
    die("IHDR says %dx%d, expected %dx%d" % (w, h, want_w, want_h))
if depth != 8 or colour != 2:
    die("not 8-bit RGB")
raw, stride, prev, rows = zlib.decompress(idat), 3 * w, bytearray(3 * w), []
if len(raw) != h * (stride + 1):
    die("IDAT holds %d bytes, expected %d" % (len(raw), h * (stride + 1)))
for y in range(h):
    f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
    for i in range(stride):
        a = line[i - 3] if i >= 3 else 0
        b, c = prev[i], prev[i - 3] if i >= 3 else 0
        if f == 1: line[i] = (line[i] + a) & 255
        elif f == 2: line[i] = (line[i] + b) & 255
        elif f == 3: line[i] = (line[i] + (a + b) // 2) & 255
        elif f == 4:
            p = a + b - c
            pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
            pr = a if pa <= pb and pa <= pc else b if pb <= pc else c
            line[i] = (line[i] + pr) & 255
        elif f != 0: die("filter %d" % f)
    rows.append(bytes(line))
    prev = line
px = lambda x, y: tuple(rows[y][3 * x:3 * x + 3])
counts = {}
for y in range(h):
    for x in range(w):
        counts[px(x, y)] = counts.get(px(x, y), 0) + 1
if len(counts) < 2:
    die("blank picture")
i = 3
while i < len(args):
    if args[i] == 'regions':
        # The first colours of the palette (cli_view.c), shaded: a pixel
        # belongs to a colour when its chromaticity is the palette's.
        kelly = [(243, 195, 0), (135, 86, 146), (243, 132, 0), (161, 202, 241),
                 (190, 0, 50), (194, 178, 128), (0, 136, 86), (230, 143, 172)]
        first, want = int(args[i + 1]), int(args[i + 2])
        seen = 0
        for k in kelly[:first]:
            s = float(sum(k))
            hits = sum(n for rgb, n in counts.items() if sum(rgb) > 60 and
                       all(abs(rgb[j] / float(sum(rgb)) - k[j] / s) < 0.02
                           for j in range(3)))
            seen += hits >= 10
        if seen < want:
            die("%d of the first %d region colours" % (seen, first))
        i += 3
    elif args[i] == 'markers':
        n = counts.get((0, 0, 0), 0)
        if n < int(args[i + 1]):
            die("%d marker pixels" % n)
        i += 2
    elif args[i] == 'tiles':
        n, tile, columns = int(args[i + 1]), int(args[i + 2]), int(args[i + 3])
        for t in range((w // tile) * (h // tile)):
            x0, y0 = t % columns * tile, t // columns * tile
            ink = sum(px(x, y) != (255, 255, 255) for y in range(y0, y0 + tile, 2)
                      for x in range(x0, x0 + tile, 2))
            if (ink > 0) != (t < n):
                die("tile %d is %s" % (t, "drawn" if ink else "empty"))
        i += 4
    elif args[i] == 'colour':
        rgb = tuple(int(v) for v in args[i + 1].split(','))
        if counts.get(rgb, 0) < 10:
            die("colour %r missing" % (rgb,))
        i += 2
    else:
        die("bad check " + args[i])
EOF
    [ $? = 0 ] || fail "png $*"
}

# ---- one mesh ---------------------------------------------------------------
run "$phks" render a.off -o one.png --size 200x150 --regions 6
expect_rc 0 "render"
expect_out "a.off: 6 regions of HKS at t = 5 tau"; expect_out "wrote one.png (200x150)"
png one.png 200 150 regions 6 3 markers 20
run "$phks" render a.off --regions 6 -o again.png --size 200x150
expect_rc 0 "render again"
cmp -s one.png again.png || fail "two renders of a.off differ"
run "$phks" render a.off -o big.png --time 20; expect_rc 0 "render 480x360"
png big.png 480 360 regions 6 3 markers 40

# ---- two meshes -------------------------------------------------------------
run "$phks" render a.off b.off -o two.png --size 200x150
expect_rc 0 "render two"; expect_out "^score "; expect_out "(400x150)"
png two.png 400 150 regions 6 3 markers 40
run "$phks" render a.off b.off -o two-again.png --size 200x150
cmp -s two.png two-again.png || fail "two renders of a.off b.off differ"

# ---- contact sheet ----------------------------------------------------------
cp c.off gone.off
# gone.off is a copy of c.off: added anyway, so that its tile has no mesh
run "$phks" db add t.db a.off b.off c.off gone.off -j 1 --allow-duplicates; expect_rc 0 "db add"
rm gone.off
run "$phks" db query t.db a.off -k 2 --png sheet.png
expect_rc 0 "query --png"; expect_out "a.off"; expect_err "wrote sheet.png (720x240, 3 tiles)"
png sheet.png 720 240 tiles 3 240 3 markers 20
# Five tiles: four in the first row, one in the second; gone.off is a
# placeholder.
run "$phks" db query t.db a.off -k 4 --png sheet5.png; expect_rc 0 "query -k 4"
png sheet5.png 960 480 tiles 5 240 4 colour 235,235,235
run "$phks" db query t.db a.off -k 4 --png sheet5-again.png
cmp -s sheet5.png sheet5-again.png || fail "two contact sheets differ"
run "$phks" db query t.db a.off -k 2 --json --png j.png
expect_rc 0 "query --json --png"; expect_out '"rank": 1'
[ -s j.png ] || fail "no j.png"

# ---- errors -----------------------------------------------------------------
# Each usage error says what is wrong, then the usage.
run "$phks" render a.off; expect_rc 2 "render without -o"
expect_err "^phks: render: no output: -o OUT.png names the picture$"
expect_err "usage: phks render"
run "$phks" render -o x.png; expect_rc 2 "render without a mesh"
expect_err "^phks: render: no mesh to draw$"
run "$phks" render a.off -o x.png --size 10x10; expect_rc 2 "tiny size"
expect_err "^phks: --size: 10x10: each side must be 16 to 4096 pixels (below 16 the feature markers would cover the shape; a 4096x4096 tile already takes 235 MB to draw)$"
expect_err "usage: phks render"
run "$phks" render a.off -o x.png --size 5000x20; expect_rc 2 "huge size"
expect_err "^phks: --size: 5000x20: each side must be 16 to 4096 pixels"
run "$phks" render a.off -o x.png --size 200; expect_rc 2 "bad size"
expect_err "^phks: --size: '200' is not WIDTHxHEIGHT in pixels (as 480x360)$"
run "$phks" render a.off -o x.png --regions 0; expect_rc 2 "zero regions"
expect_err "^phks: --regions: '0' is not a whole number of regions from 1 to 100000$"
run "$phks" render a.off -o x.png --time -1; expect_rc 2 "negative time"
expect_err "^phks: --time: '-1' is not a time from 0 to 1e9 (in units of tau)$"
run "$phks" render a.off b.off c.off -o x.png; expect_rc 2 "three meshes"
expect_err "^phks: render: more than two meshes: render draws one, or two side by side$"
# PNG only, under a name that says so.
run "$phks" render a.off -o x.jpg; expect_rc 1 "render -o x.jpg"
expect_err "^phks: x.jpg: render writes PNG only: name the output OUT.png$"
[ ! -e x.jpg ] || fail "render wrote x.jpg"
run "$phks" db query t.db a.off --png sheet.jpg; expect_rc 1 "query --png sheet.jpg"
expect_err "^phks: sheet.jpg: --png writes PNG only: name the contact sheet OUT.png$"
[ ! -e sheet.jpg ] || fail "db query wrote sheet.jpg"
run "$phks" render a.off -o UPPER.PNG --size 64x48; expect_rc 0 "render -o UPPER.PNG"
run "$phks" signature a.off -o a.sig; expect_rc 0 "signature"
run "$phks" render a.sig -o x.png; expect_rc 1 "render of a blob"
expect_err "^phks: a.sig: a signature blob"
run "$phks" render bad.off -o x.png; expect_rc 1 "bad mesh"
expect_err "^phks: bad.off: "
[ ! -e x.png ] || fail "x.png written on failure"
run "$phks" render a.off -o nodir/x.png; expect_rc 1 "unwritable output"
expect_err "^phks: nodir/x.png: "
echo "render: all passed"
