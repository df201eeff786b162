#!/bin/sh
# test_render.sh PHKS - the pictures of the `phks` tool (`render`, `db query
# --png`) on small meshes made here: valid PNGs of the asked size that
# decode (with /usr/bin/python3 and zlib) to pictures showing the region
# colours and the feature markers, a wider picture for two meshes, a
# contact sheet of k + 1 tiles, the same bytes on every run, and the usage
# errors. For two meshes, measured against `phks match` and the pixels
# at the positions `render --json` gives: the verified pairs drawn, both
# dots of a pair in its colour, B's regions in colours its pairs bring,
# no line with --pairs none. The view's options and default, boundary
# edges (a bowl's rim from above, none on a closed mesh, a hole turned
# away), and captions whose glyphs grow with the picture. Skipped (exit
# 77) when the tool was built without libspng.
set -u
phks=$1
case $phks in /*) ;; *) phks=$(pwd)/$phks ;; esac
py=/usr/bin/python3
helpers=$(cd "$(dirname "$0")" && pwd)/cli_helpers.sh
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cd "$tmp" || exit 1

. "$helpers"
phks=$(at_vertices "$phks")

# bowl NU NV K F: an open hemisphere of radius 1 as OFF, its rim the
# circle of radius 1 at z = 0 and its pole at z = -1, with F bumps of
# height K around it that vanish at the rim and the pole.
bowl() {
    awk -v nu="$1" -v nv="$2" -v k="$3" -v f="$4" 'BEGIN {
        pi = atan2(0, -1)
        print "OFF"
        print 1 + nv * nu, nu + 2 * nu * (nv - 1), 0
        print 0, 0, -1
        for (i = 1; i <= nv; i++) {
            t = pi / 2 * i / nv
            for (j = 0; j < nu; j++) {
                p = 2 * pi * j / nu
                r = 1 + k * (1 + cos(f * p)) * sin(2 * t) ^ 2
                printf "%.9f %.9f %.9f\n", r * sin(t) * cos(p),
                    r * sin(t) * sin(p), -r * cos(t)
            }
        }
        for (j = 0; j < nu; j++)
            print 3, 0, 1 + (j + 1) % nu, 1 + j
        for (i = 1; i < nv; i++)
            for (j = 0; j < nu; j++) {
                p = 1 + (i - 1) * nu + j
                q = 1 + (i - 1) * nu + (j + 1) % nu
                print 3, p, q, q + nu
                print 3, p, q + nu, p + nu
            }
    }'
}

# holed X < MESH.off: MESH without the faces whose corners all lie
# beyond x = X: a hole in its side.
holed() {
    awk -v cut="$1" 'NR == 2 { n = $1 }
        NR > 2 && NR <= n + 2 { x[NR - 3] = $1; vertex[NR - 3] = $0 }
        NR > n + 2 && !(x[$2] > cut && x[$3] > cut && x[$4] > cut) {
            face[f++] = $0 }
        END { print "OFF"; print n, f, 0
              for (i = 0; i < n; i++) print vertex[i]
              for (i = 0; i < f; i++) print face[i] }'
}

blob 24 12 1.0 1.0 0.5 0.35 3 > a.off
blob 24 12 1.0 0.9 0.5 0.30 3 > b.off
blob 24 12 1.2 0.4 0.3 0.05 2 > c.off
bowl 48 12 0.15 3 > bowl.off
blob 24 16 0.6 0.5 1.5 0.1 3 | holed 0.45 > side.off
printf 'not a mesh\n' > bad.off

run "$phks" render a.off -o probe.png --size 64x48
if [ "$rc" = 1 ] && grep -q "built without PNG support" err; then
    echo "SKIP: phks was built without libspng (no PNG support)"
    exit 77
fi
expect_rc 0 "render probe"
[ -x "$py" ] || { echo "SKIP: no $py to decode the PNGs"; exit 77; }

# pictures.py: decodes the PNGs (inflate and the five filters, with zlib
# alone) and checks them; `pictures.py COMMAND PNG ...` exits 1 with a
# message when a check fails, or prints a number. Pixel positions and
# tiles come from `render --json`.
cat > pictures.py <<'EOF'
import json, math, struct, sys, zlib

def die(msg):
    sys.exit("%s: %s" % (sys.argv[2], msg))

def read(path):
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
    if depth != 8 or colour != 2:
        die("not 8-bit RGB")
    raw, stride, prev, rows = zlib.decompress(idat), 3 * w, bytearray(3 * w), []
    if len(raw) != h * (stride + 1):
        die("IDAT holds %d bytes, expected %d" % (len(raw), h * (stride + 1)))
    for y in range(h):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        if f == 2:
            line = bytearray((a + b) & 255 for a, b in zip(line, prev))
        elif f != 0:
            for i in range(stride):
                a = line[i - 3] if i >= 3 else 0
                b, c = prev[i], prev[i - 3] if i >= 3 else 0
                if f == 1: line[i] = (line[i] + a) & 255
                elif f == 3: line[i] = (line[i] + (a + b) // 2) & 255
                elif f == 4:
                    p = a + b - c
                    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                    pr = a if pa <= pb and pa <= pc else b if pb <= pc else c
                    line[i] = (line[i] + pr) & 255
                else: die("filter %d" % f)
        rows.append(bytes(line))
        prev = line
    return w, h, rows

def px(rows, x, y):
    return tuple(rows[y][3 * x:3 * x + 3])

WHITE = (255, 255, 255)
# The first colours of the palette (render/cli_regions.c).
KELLY = [(243, 195, 0), (135, 86, 146), (243, 132, 0), (161, 202, 241),
         (190, 0, 50), (194, 178, 128), (0, 136, 86), (230, 143, 172)]

def chroma_of(rgb, palette):
    """The palette colour whose chromaticity rgb has (a shaded face), or
    None."""
    s = float(sum(rgb))
    if s <= 60:
        return None
    for k in palette:
        t = float(sum(k))
        if all(abs(rgb[j] / s - k[j] / t) < 0.02 for j in range(3)):
            return k
    return None

def load(args, index):
    """The picture of args[0], and tile index of the JSON in args[1]."""
    w, h, rows = read(args[0])
    info = json.load(open(args[1]))
    return w, h, rows, info, info["meshes"][index]["tile"]

def dark_grey(rgb):
    """A boundary edge's pixel (20, 20, 20), or its blend with the white
    background: grey and dark; not the markers' pure black."""
    return rgb != (0, 0, 0) and max(rgb) <= 120 and max(rgb) - min(rgb) <= 12

def check(args):
    path, want_w, want_h = args[0], int(args[1]), int(args[2])
    w, h, rows = read(path)
    if (w, h) != (want_w, want_h):
        die("IHDR says %dx%d, expected %dx%d" % (w, h, want_w, want_h))
    counts = {}
    for y in range(h):
        for x in range(w):
            counts[px(rows, x, y)] = counts.get(px(rows, x, y), 0) + 1
    if len(counts) < 2:
        die("blank picture")
    i = 3
    while i < len(args):
        if args[i] == 'regions':
            # A pixel belongs to a colour when its chromaticity is the
            # palette's.
            first, want = int(args[i + 1]), int(args[i + 2])
            seen = sum(sum(n for rgb, n in counts.items()
                           if chroma_of(rgb, [k]) == k) >= 10
                       for k in KELLY[:first])
            if seen < want:
                die("%d of the first %d region colours" % (seen, first))
            i += 3
        elif args[i] == 'markers':
            n = counts.get((0, 0, 0), 0)
            if n < int(args[i + 1]):
                die("%d marker pixels" % n)
            i += 2
        elif args[i] == 'tiles':
            n, size, columns = int(args[i + 1]), int(args[i + 2]), int(args[i + 3])
            for t in range((w // size) * (h // size)):
                x0, y0 = t % columns * size, t // columns * size
                ink = sum(px(rows, x, y) != WHITE
                          for y in range(y0, y0 + size, 2)
                          for x in range(x0, x0 + size, 2))
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

def drawn_colour(pair):
    """As render/cli_pairs.c draws it: faint pairs halfway to white."""
    rgb = tuple(pair["rgb"])
    return rgb if pair["verified"] else tuple((c + 256) // 2 for c in rgb)

def pairs(args):
    """Both ends of every drawn pair carry its colour: within 3 pixels of
    each end, the commonest colour other than white and the rims' is the
    pair's. Pairs with an end nearer than 12 pixels to another end are
    skipped (their dots overlap). Prints how many pairs were checked."""
    w, h, rows, info, _ = load(args, 0)
    ends = [tuple(p[s]) for p in info["pairs"] for s in ("a", "b")]
    checked = 0
    for p in info["pairs"]:
        alone = all(sum(math.hypot(e[0] - q[0], e[1] - q[1]) < 12
                        for q in ends) == 1 for e in (p["a"], p["b"]))
        if not alone:
            continue
        for side in ("a", "b"):
            cx, cy = int(p[side][0]), int(p[side][1])
            counts = {}
            for y in range(cy - 3, cy + 4):
                for x in range(cx - 3, cx + 4):
                    rgb = px(rows, x, y)
                    if rgb not in (WHITE, (0, 0, 0), (110, 110, 110)):
                        counts[rgb] = counts.get(rgb, 0) + 1
            top = max(counts, key=lambda k: (counts[k], k)) if counts else None
            if top != drawn_colour(p):
                die("pair %d-%d: its %s end is %r, not %r" %
                    (p["feature_a"], p["point_b"], side, top, drawn_colour(p)))
        checked += 1
    print(checked)

def inside_face(rows, x, y):
    """Whether the pixel has its four neighbours' colour: the inside of a
    flat-shaded face, not the blend of an edge with what lies beside."""
    c = px(rows, x, y)
    return all(px(rows, x + dx, y + dy) == c
               for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)))

def b_colours(args):
    """B's faces show no palette colour that no drawn pair brought from A
    (30 pixels or more inside faces of a colour's chromaticity count), and
    at least one that a pair did."""
    w, h, rows, info, (x0, y0, tw, th) = load(args, 1)
    brought = {tuple(p["rgb"]) for p in info["pairs"]}
    counts = {}
    for y in range(y0 + 1, y0 + th - 1):
        for x in range(x0 + 1, x0 + tw - 1):
            k = inside_face(rows, x, y) and chroma_of(px(rows, x, y), KELLY)
            if k:
                counts[k] = counts.get(k, 0) + 1
    stray = [k for k, n in counts.items() if n >= 30 and k not in brought]
    if stray:
        die("B shows %r, which no pair brings" % stray)
    if brought and not any(counts.get(k, 0) >= 30 for k in brought):
        die("none of the pairs' colours %r on B" % sorted(brought))

def seam(args):
    """Pixels other than white on the two columns where the tiles meet,
    within the tiles' rows."""
    w, h, rows, info, (x0, y0, tw, th) = load(args, 1)
    print(sum(px(rows, x, y) != WHITE for y in range(y0, y0 + th)
              for x in (x0 - 1, x0)))

def drawn(rows, x0, y0, tw, th):
    return [(x, y) for y in range(y0, y0 + th) for x in range(x0, x0 + tw)
            if px(rows, x, y) != WHITE]

def bbox(args):
    """Width and height of what is drawn in the first tile."""
    w, h, rows, info, t = load(args, 0)
    ink = drawn(rows, *t)
    xs, ys = [p[0] for p in ink], [p[1] for p in ink]
    print(max(xs) - min(xs) + 1, max(ys) - min(ys) + 1)

def dark(args):
    """Boundary pixels (dark grey) in the first tile."""
    w, h, rows, info, (x0, y0, tw, th) = load(args, 0)
    print(sum(dark_grey(px(rows, x, y)) for y in range(y0, y0 + th)
              for x in range(x0, x0 + tw)))

def ring(args):
    """The boundary pixels lie on one circle, the rim of a bowl seen from
    straight above: within 4% of the radius (half their extent) of its
    centre (their extent's), and all around (in each of 36 sectors)."""
    w, h, rows, info, t = load(args, 0)
    rim = [(x, y) for x, y in drawn(rows, *t) if dark_grey(px(rows, x, y))]
    if not rim:
        die("no boundary drawn")
    lo_x, hi_x = min(p[0] for p in rim), max(p[0] for p in rim) + 1
    lo_y, hi_y = min(p[1] for p in rim), max(p[1] for p in rim) + 1
    cx, cy, r = (lo_x + hi_x) / 2.0, (lo_y + hi_y) / 2.0, (hi_x - lo_x) / 2.0
    off = sum(abs(math.hypot(x + 0.5 - cx, y + 0.5 - cy) - r) > 0.04 * r
              for x, y in rim)
    sectors = {int((math.atan2(y + 0.5 - cy, x + 0.5 - cx) + math.pi) /
                   (2 * math.pi) * 36) % 36 for x, y in rim}
    if off:
        die("%d of %d boundary pixels off the rim (radius %.1f)" %
            (off, len(rim), r))
    if len(sectors) < 36:
        die("the rim is drawn in %d of 36 sectors" % len(sectors))

def ink_rows(args):
    """Rows under the tiles (the caption band) with ink."""
    w, h, rows, info, (x0, y0, tw, th) = load(args, 0)
    print(sum(rows[y] != b'\xff' * (3 * w) for y in range(y0 + th, h)))

commands = {'check': check, 'pairs': pairs, 'b-colours': b_colours,
            'seam': seam, 'bbox': bbox, 'dark': dark, 'ring': ring,
            'ink-rows': ink_rows}
commands[sys.argv[1]](sys.argv[2:])
EOF

# png FILE W H CHECKS...: decodes FILE and checks it (exit 1 with a
# message when it is wrong): its size, that it is not blank, and
#   regions R N   at least N of the first R region colours (10 pixels each)
#   markers M     at least M pixels of the feature markers' black
#   tiles N T C   tiles of T x T, C to a row: the first N drawn, others empty
#   colour R,G,B  at least 10 pixels of that colour
png() {
    "$py" pictures.py check "$@" || fail "png $*"
}
# look COMMAND PNG JSON: what pictures.py prints, in $n.
look() {
    n=$("$py" pictures.py "$@") || fail "pictures.py $*"
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

# ---- the pairs of two meshes, as phks_match gives them -------------------------
# The library's verified pairs and score (`phks match`): A's rows ending in
# "verified".
run "$phks" match a.off b.off; expect_rc 0 "match"
score=$(sed -n 's/^score \([^ ]*\) .*/\1/p' out)
verified=$(grep -v "from B" out | grep -c " verified$")
[ "$verified" -gt 0 ] || fail "a.off and b.off: no verified pair to draw"
run "$phks" render a.off b.off -o v.png --size 600x450; expect_rc 0 "render"
features=$(sed -n 's/^a.off: .*, \([0-9]*\) features$/\1/p' out)
# The caption's text, on stdout too.
expect_out "^score $score, $verified of $features verified$"
run "$phks" render a.off b.off -o v.png --size 600x450 --json
expect_rc 0 "render --json"; cp out v.json
"$py" -c 'import json, sys
d = json.load(open("v.json")); p = d["pairs"]
assert d["pairs_shown"] == "verified" and d["verified"] == int(sys.argv[1])
assert len(p) == d["verified"] and all(x["verified"] for x in p), p' \
    "$verified" || fail "--pairs verified draws other pairs than the verified"
# A matched pair's two dots have one colour (the line's), samples of B
# included; B's regions show only colours a pair brought from A.
look pairs v.png v.json; [ "$n" -ge 2 ] || fail "only $n pairs stand apart"
look b-colours v.png v.json
# Against the holed blob, whose hole's rim draws most of A's features to
# its samples (on b.off the nearest are mostly features, which of them
# the last bits of the spectrum decide).
run "$phks" render a.off side.off -o all.png --size 600x450 --pairs all --json
expect_rc 0 "--pairs all"; cp out all.json
"$py" -c 'import json
d = json.load(open("all.json")); p = d["pairs"]
assert len(p) == d["features_a"] and any(x["b_is_sample"] for x in p), p
assert sum(x["verified"] for x in p) == d["verified"]' ||
    fail "--pairs all: not one pair per feature of A, or no sample of B"
look pairs all.png all.json; [ "$n" -ge 3 ] || fail "only $n pairs stand apart"
look b-colours all.png all.json
# Lines run from tile to tile; with --pairs none, nothing crosses.
look seam all.png all.json; [ "$n" -gt 0 ] || fail "no line between the tiles"
run "$phks" render a.off b.off -o none.png --size 600x450 --pairs none --json
expect_rc 0 "--pairs none"; cp out none.json
look seam none.png none.json; [ "$n" = 0 ] || fail "$n line pixels with --pairs none"
png none.png 1200 450 regions 6 3 markers 20

# ---- views -------------------------------------------------------------------
# c.off is long along x (2.4 x 0.8 x 0.6): upright by default, and as the
# axes say with --up.
run "$phks" render c.off -o c.png --size 300x300 --json; expect_rc 0 "c.off"
cp out c.json; look bbox c.png c.json; set -- $n
[ "$2" -gt $(($1 * 3 / 2)) ] || fail "c.off's long axis not upright: $1 x $2"
run "$phks" render c.off -o cx.png --size 300x300 --up x --view 0,0 --json
expect_rc 0 "--up x"; cp out cx.json; look bbox cx.png cx.json; set -- $n
[ "$2" -gt $(($1 * 3)) ] || fail "--up x --view 0,0: $1 x $2"
run "$phks" render c.off -o cz.png --size 300x300 --up z --view 0,0 --json
expect_rc 0 "--up z"; cp out cz.json; look bbox cz.png cz.json; set -- $n
[ "$1" -gt $(($2 * 3)) ] || fail "--up z --view 0,0: $1 x $2"
grep -q '"azimuth": 0, "elevation": 0' cz.json || fail "--view 0,0 not in the JSON"
run "$phks" render c.off -o cmx.png --size 300x300 --up -x --view 0,0
expect_rc 0 "--up -x"
run "$phks" render c.off -o cv.png --size 300x300 --view 60,-30
expect_rc 0 "--view 60,-30"
for f in cx cz cmx cv; do
    cmp -s c.png $f.png && fail "$f.png is the default picture"
done
cmp -s cx.png cmx.png && fail "--up x and --up -x draw the same"

# ---- boundary edges ------------------------------------------------------------
# The bowl's rim from straight above: a dark circle, all of it and nothing
# else; none on a closed mesh.
run "$phks" render bowl.off -o rim.png --size 300x300 --regions 1 --up z \
    --view 0,90 --json
expect_rc 0 "bowl from above"; cp out rim.json
look ring rim.png rim.json
look dark rim.png rim.json; [ "$n" -ge 200 ] || fail "only $n rim pixels"
run "$phks" render a.off -o closed.png --size 300x300 --regions 1 --json
expect_rc 0 "closed"; cp out closed.json
look dark closed.png closed.json; [ "$n" = 0 ] || fail "$n boundary pixels on a closed mesh"
# The default view turns a hole to the far side: none of its edge shows;
# turned half round, it faces the viewer.
run "$phks" render side.off -o away.png --size 300x300 --regions 1 --json
expect_rc 0 "holed"; cp out away.json
grep -q '"boundary_edges": [1-9]' away.json || fail "side.off has no hole"
look dark away.png away.json; [ "$n" -le 5 ] || fail "$n hole pixels face the viewer"
run "$phks" render side.off -o facing.png --size 300x300 --regions 1 \
    --view 210,20 --json
expect_rc 0 "holed, turned"; cp out facing.json; look dark facing.png facing.json
[ "$n" -ge 50 ] || fail "only $n hole pixels with the hole turned to the viewer"

# ---- captions ------------------------------------------------------------------
# The caption's glyphs grow with the picture: three times the height, three
# times the rows of ink under the tile.
run "$phks" render a.off -o small.png --size 600x400 --json; expect_rc 0 "600x400"
cp out small.json; look ink-rows small.png small.json; small=$n
run "$phks" render a.off -o large.png --size 1800x1200 --json
expect_rc 0 "1800x1200"; cp out large.json; look ink-rows large.png large.json
[ "$n" -ge 25 ] || fail "the caption at 1800x1200 has $n rows of ink"
[ $((n * 10)) -ge $((small * 24)) ] && [ $((n * 10)) -le $((small * 36)) ] ||
    fail "caption rows of ink: $small at 600x400, $n at 1800x1200"

# ---- the options' usage errors ---------------------------------------------------
run "$phks" render a.off b.off -o x.png --pairs some; expect_rc 2 "--pairs some"
run "$phks" render a.off -o x.png --view 30; expect_rc 2 "--view without EL"
run "$phks" render a.off -o x.png --view 30,91; expect_rc 2 "--view EL 91"
run "$phks" render a.off -o x.png --view 30,x; expect_rc 2 "--view 30,x"
run "$phks" render a.off -o x.png --up w; expect_rc 2 "--up w"
run "$phks" render a.off -o x.png --up -; expect_rc 2 "--up -"
run "$phks" render a.off -o x.png --up xy; expect_rc 2 "--up xy"

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
expect_err "^phks: --regions: '0' is not a whole number from 1 to 100000$"
run "$phks" render a.off -o x.png --time -1; expect_rc 2 "negative time"
expect_err "^phks: --time: '-1' is not a time above 0 and at most 1e9 (in units of tau)$"
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
