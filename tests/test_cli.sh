#!/bin/sh
# test_cli.sh PHKS - every command of the `phks` tool on small meshes made
# here: exit statuses, outputs, files written, and the messages for bad
# input. POSIX sh; needs awk.
set -u
phks=$1
case $phks in /*) ;; *) phks=$(pwd)/$phks ;; esac
helpers=$(cd "$(dirname "$0")" && pwd)/cli_helpers.sh
docs=$(cd "$(dirname "$0")/../docs" && pwd)/cli.md
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cd "$tmp" || exit 1

. "$helpers"
# The tool itself where its defaults are the subject; elsewhere the
# vertices' quadrature (cli_helpers.sh, at_vertices).
tool=$phks
phks=$(at_vertices "$tool")

mkdir -p set/star set/bar
blob 24 12 1.0 1.0 0.5 0.35 3 > a.off
blob 24 12 1.0 0.9 0.5 0.30 3 > b.off
for i in 0 1 2 3; do
    blob 24 12 1.0 1.0 0.5 0.3$i 3 > set/star/$i.off
    blob 24 12 1.$i 0.4 0.3 0.0$i 2 > set/bar/$i.off
done
printf 'not a mesh\n' > bad.off
printf 'file\tclass\tn_vertices\tn_faces\n' > set/MANIFEST.tsv
for c in star bar; do
    for i in 0 1 2 3; do
        printf '%s/%s.off\t%s\t266\t528\n' $c $i $c >> set/MANIFEST.tsv
    done
done

# ---- usage ------------------------------------------------------------------
run "$phks" --help;          expect_rc 0 "--help"; expect_out "usage: phks"
run "$phks";                 expect_rc 2 "no command"; expect_err "usage: phks"
run "$phks" frobnicate;      expect_rc 2 "unknown command"
expect_err "unknown command frobnicate"
run "$phks" --version;       expect_rc 0 "--version"; expect_out "libphks"
run "$phks" signature;       expect_rc 2 "signature without mesh"
expect_err "usage: phks signature MESH"
run "$phks" signature a.off --bogus; expect_rc 2 "unknown option"
expect_err "unknown option --bogus"
run "$phks" --operator sideways signature a.off; expect_rc 2 "bad operator"
expect_err "^phks: --operator: 'sideways' is not one of literal, random-walk$"
# Values in the tool's words only: the library's table also takes numbers.
run "$phks" --hks-scaling 2 signature a.off; expect_rc 2 "--hks-scaling 2"
expect_err "^phks: --hks-scaling: '2' is not one of none, mean, local-area$"
# Ranges are the library's, said in the tool's words.
run "$phks" --boundary-margin 101 signature a.off; expect_rc 2 \
    "--boundary-margin 101"
expect_err "^phks: --boundary-margin: boundary-margin 101 outside \\[0, 100\\]$"
run "$phks" --threads 1025 signature a.off; expect_rc 2 "--threads 1025"
expect_err "^phks: --threads: threads 1025 above 1024$"
run "$phks" signature a.off --threads; expect_rc 2 "--threads without value"

# ---- --help of every command ----------------------------------------------------
for cmd in signature match segment render bench db "db add" "db query" \
           "db list" "db info" "db remove"; do
    for h in --help -h; do
        # shellcheck disable=SC2086 # "db add" is two words
        run "$phks" $cmd $h; expect_rc 0 "$cmd $h"
        expect_out "^usage: phks $cmd"
        [ -s err ] && fail "$cmd $h: stderr"
    done
done
run "$phks" --help; expect_out "(local-area)"; expect_out "--progress"
expect_out "db info DB"; expect_out "-k K (10)"
run "$phks" render --help; expect_out "--size WxH .*16..4096 pixels (480x360)"
run "$phks" segment --help; expect_out "--regions N .*(15)"
expect_out "--time T .*(5)"; expect_out "--ascii .*(binary little-endian)"
run "$phks" db query --help; expect_out "-k K .*(10)"
run "$phks" db add --help; expect_out "--allow-duplicates"
run "$phks" bench --help; expect_out "--seeds N .*(1)"; expect_out "(psb/)"
expect_out "--group NAME=A,B"; expect_out "^ *phks bench --db LIST --queries LIST"
expect_out "--leave-one-out LIST"
run "$phks" --help; expect_out "bench --leave-one-out LIST"
# The overviews, `phks --help` and `phks db --help`, name every option of
# each command's own --help.
options_of() {
    # shellcheck disable=SC2086 # "db add" is two words
    "$phks" $1 --help | grep -oE '(^|[ [])--?[a-z][-a-z]*' |
        sed 's/^[ [][ [:space:]]*//' | grep -vx -- '--help' | sort -u
}
"$phks" --help > overview
"$phks" db --help > db_overview
for cmd in signature match segment render bench "db add" "db query" "db list" \
           "db info" "db remove"; do
    for opt in $(options_of "$cmd"); do
        grep -q -- "[[ ]$opt[] ]" overview ||
            fail "phks --help lacks $cmd's $opt"
        case $cmd in
        db*) grep -q -- "[[ ]$opt[] ]" db_overview ||
                 fail "phks db --help lacks $cmd's $opt" ;;
        esac
    done
done

# ---- signature --------------------------------------------------------------
run "$phks" signature a.off -o a.sig; expect_rc 0 "signature"
expect_out "a.off: 266 vertices, 528 triangles"
expect_out "features x 15 scales"
expect_out "wrote a.sig"
[ "$(head -c 4 a.sig)" = PHKS ] || fail "a.sig does not start with PHKS"
run "$phks" signature a.sig;  expect_rc 0 "signature of a blob"
expect_out "persistence"
run "$phks" signature missing.off; expect_rc 1 "missing mesh"
expect_err "^phks: missing.off: "
run "$phks" signature bad.off; expect_rc 1 "bad mesh"
expect_err "^phks: bad.off: "
printf 'PHKS garbage' > bad.sig
run "$phks" signature bad.sig; expect_rc 1 "bad blob"
expect_err "^phks: bad.sig: "

# ---- --json, and vertex ids in the file's numbering ---------------------------
py=/usr/bin/python3
run "$phks" signature a.off --json -o a.sig; expect_rc 0 "signature --json"
$py -c 'import json,sys; d=json.load(sys.stdin)
assert d["vertex_ids"] == "file" and d["vertices"] == 266
assert d["output"] == "a.sig" and d["options"]["hks_scaling"] == "local-area"
assert d["feature_count"] == len(d["features"]) > 0
for f in d["features"]:
    assert len(f["vector"]) == 15 and 0 <= f["vertex"] < 266
    assert len(f["position"]) == 3
assert d["features"][0]["persistence"] is None   # infinite
print(" ".join(str(f["vertex"]) for f in d["features"]))' < out > a.ids ||
    fail "signature --json"
# The same mesh behind 5 unused vertices: every id moves by 5, and the
# position printed is the file's vertex at that id.
awk 'NR == 1 { print; next }
     NR == 2 { print $1 + 5, $2, $3; for (i = 0; i < 5; i++) print 9, 9, i; next }
     NF == 3 && n < 266 { n++; print; next }
     { print $1, $2 + 5, $3 + 5, $4 + 5 }' a.off > shifted.off
run "$phks" signature shifted.off --json; expect_rc 0 "signature of shifted.off"
$py -c 'import json,sys
d = json.load(open("out"))
lines = open("shifted.off").read().split("\n")
ids = [int(i) for i in open("a.ids").read().split()]
assert sorted(f["vertex"] for f in d["features"]) == sorted(i + 5 for i in ids), "ids"
for f in d["features"]:
    xyz = [float(x) for x in lines[2 + f["vertex"]].split()]
    assert xyz == f["position"], (xyz, f["position"])' ||
    fail "shifted.off: ids not in the file's numbering"
run "$phks" signature shifted.off; expect_rc 0 "signature text of shifted.off"
first=$(cut -d' ' -f1 a.ids)
expect_out "^ *0 *$((first + 5)) "
run "$phks" signature a.sig --json; expect_rc 0 "signature --json of a blob"
$py -c 'import json,sys; d=json.load(sys.stdin)
assert d["vertex_ids"] == "cleaned" and d["source"] == "signature"' < out ||
    fail "blob --json"
run "$phks" --matching nearest match a.off b.off --json
expect_rc 0 "match --matching nearest --json"
cp out nearest.json
run "$phks" match a.off b.off --json; expect_rc 0 "match --json"
cp out match.json
run "$phks" match a.off b.off; expect_rc 0 "match text"
text_score=$(sed -n 's/^score \([^ ]*\) .*/\1/p' out)
$py -c 'import json,sys; d=json.load(open("match.json"))
n = json.load(open("nearest.json"))
assert "%.6g" % d["score"] == sys.argv[1], (d["score"], sys.argv[1])
c = n["correspondences"]
assert abs(sum(x["distance"] for x in c) - n["score"]) < 1e-9 * n["score"]
assert not any(x["verified"] for x in c)
# nothing verified; the similarity in (0, 1) by the NEAREST formula
assert n["verified"] == 0 and n["features"] > 0, n
assert 0 < n["similarity"] < 1, n["similarity"]
# two different shapes: the similarity in [0, 1], verified at most all
assert 0 <= d["similarity"] <= 1, d["similarity"]
assert 0 <= d["verified"] <= d["features"], (d["verified"], d["features"])
nv = sum(1 for x in d["correspondences"] if x["direction"] == "a_to_b"
         and x["verified"])
assert d["verified"] == nv, (d["verified"], nv)
# verified: the paper score times 1 - the share verified, never above it
assert 0 <= d["score"] <= n["score"] * (1 + 1e-12), (d["score"], n["score"])
c = d["correspondences"]
assert all(isinstance(x["verified"], bool) for x in c)
assert {x["direction"] for x in c} == {"a_to_b", "b_to_a"}
for x in c:
    assert 0 <= x["vertex_a"] < 266 and 0 <= x["vertex_b"] < 266
    assert len(x["position_a"]) == 3 == len(x["position_b"])' "$text_score" ||
    fail "match --json against the text score $text_score"
run "$phks" match shifted.off a.off --json; expect_rc 0 "match shifted.off"
# a's vertex at a point is b's at the same point, 5 on; the verified
# partner may be a symmetric copy of the point, so positions decide
$py -c 'import json,sys; d=json.load(sys.stdin); assert d["score"] == 0
c = d["correspondences"]
at_a = {tuple(x["position_a"]): x["vertex_a"] for x in c}
at_b = {tuple(x["position_b"]): x["vertex_b"] for x in c}
assert len(at_a) == d["features"] and at_a.keys() == at_b.keys()
assert all(at_a[p] == at_b[p] + 5 for p in at_a)' \
    < out || fail "match: ids of shifted.off not shifted"

# ---- progress -----------------------------------------------------------------
run "$phks" --progress signature a.off --json; expect_rc 0 "--progress"
expect_err "^phks: a.off: eigen-decomposition$"; expect_err "^phks: a.off: done$"
$py -c 'import json,sys; json.load(sys.stdin)' < out ||
    fail "--progress: stdout is not clean JSON"
run "$phks" signature a.off --json; expect_rc 0 "no terminal, no progress"
[ -s err ] && fail "progress without a terminal or --progress"
run "$phks" segment a.off -o p.ply --json --progress; expect_rc 0 \
    "segment --progress"
expect_err "a.off: regions$"
$py -c 'import json,sys; json.load(sys.stdin)' < out || fail "segment stdout"
run "$phks" --progress --no-progress match a.off b.off; expect_rc 0 \
    "--no-progress"
[ -s err ] && fail "--no-progress printed progress"

# ---- OBJ with several objects ---------------------------------------------------
awk 'NR > 2 && NF == 3 { print "v", $0 }' a.off > two.obj
awk 'NR > 2 && NF == 3 { print "v", $0 }' b.off >> two.obj
echo "o first" >> two.obj
awk 'NR > 2 && NF == 4 { print "f", $2 + 1, $3 + 1, $4 + 1 }' a.off >> two.obj
echo "o second" >> two.obj
awk 'NR > 2 && NF == 4 { print "f", $2 + 267, $3 + 267, $4 + 267 }' b.off >> two.obj
run "$phks" signature two.obj; expect_rc 0 "signature of two objects"
expect_err "two.obj: note: 2 objects or groups (first, second) merged into one shape"
expect_out "532 vertices, 1056 triangles"
run "$phks" --object second signature two.obj -o second.sig; expect_rc 0 \
    "--object second"
[ -s err ] && fail "--object: a note"
expect_out "266 vertices, 528 triangles"
run "$phks" match second.sig b.off --json; expect_rc 0 "second against b.off"
$py -c 'import json,sys; d=json.load(sys.stdin); assert d["score"] == 0' < out ||
    fail "--object second is not b.off"
run "$phks" --object first signature two.obj --json; expect_rc 0 "--object first"
$py -c 'import json,sys; d=json.load(sys.stdin)
ids = [int(i) for i in open("a.ids").read().split()]
assert [f["vertex"] for f in d["features"]] == ids' < out ||
    fail "--object first: not a.off's features"
run "$phks" --object third signature two.obj; expect_rc 1 "--object third"
expect_err "no object or group named third (it has: first, second)"
run "$phks" --object first signature a.off; expect_rc 1 "--object on OFF"
expect_err "applies to uncompressed OBJ files and to the formats read through assimp"

# ---- glTF (and the other formats of assimp) ---------------------------------
# A unit cube, 8 vertices and 12 triangles, as OFF and as glTF 2.0 with the
# same vertex order: one buffer, embedded as base64, of 8 float32 positions
# (96 bytes) and 36 uint16 indices (72 bytes).
cat > cube.off <<'EOF'
OFF
8 12 0
0 0 0
1 0 0
1 1 0
0 1 0
0 0 1
1 0 1
1 1 1
0 1 1
3 0 2 1
3 0 3 2
3 4 5 6
3 4 6 7
3 0 1 5
3 0 5 4
3 1 2 6
3 1 6 5
3 2 3 7
3 2 7 6
3 3 0 4
3 3 4 7
EOF
cube_buffer=AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAACAPwAAgD8AAAAAAAAAAAAAgD8AAAAAAAAAAAAAAAAAAIA/AACAPwAAAAAAAIA/AACAPwAAgD8AAIA/AAAAAAAAgD8AAIA/AAACAAEAAAADAAIABAAFAAYABAAGAAcAAAABAAUAAAAFAAQAAQACAAYAAQAGAAUAAgADAAcAAgAHAAYAAwAAAAQAAwAEAAcA
gltf_head='{"asset":{"version":"2.0"},"scene":0,
"buffers":[{"byteLength":168,"uri":"data:application/octet-stream;base64,'$cube_buffer'"}],
"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":96},
               {"buffer":0,"byteOffset":96,"byteLength":72}],
"accessors":[{"bufferView":0,"componentType":5126,"count":8,"type":"VEC3",
              "min":[0,0,0],"max":[1,1,1]},
             {"bufferView":1,"componentType":5123,"count":36,"type":"SCALAR"}],'
cube_primitive='"primitives":[{"attributes":{"POSITION":0},"indices":1}]'
cat > cube.gltf <<EOF
$gltf_head
"meshes":[{"name":"boxmesh",$cube_primitive}],
"nodes":[{"name":"box","mesh":0}],
"scenes":[{"nodes":[0]}]}
EOF
# Two meshes on two nodes, the second moved by 3 along x.
cat > two.gltf <<EOF
$gltf_head
"meshes":[{"name":"cubeA",$cube_primitive},{"name":"cubeB",$cube_primitive}],
"nodes":[{"name":"first","mesh":0},
         {"name":"second","mesh":1,"translation":[3,0,0]}],
"scenes":[{"nodes":[0,1]}]}
EOF
# The cube as GLB: the JSON without the uri, then the buffer, each padded
# to 4 bytes.
$py -c 'import base64, json, struct
d = json.load(open("cube.gltf"))
b = base64.b64decode(d["buffers"][0].pop("uri").split(",")[1])
j = json.dumps(d).encode()
j += b" " * (-len(j) % 4)
b += bytes(-len(b) % 4)
open("cube.glb", "wb").write(struct.pack("<III", 0x46546C67, 2,
    28 + len(j) + len(b)) + struct.pack("<II", len(j), 0x4E4F534A) + j +
    struct.pack("<II", len(b), 0x004E4942) + b)' || fail "writing cube.glb"
run "$phks" signature cube.gltf --json
if grep -q "built without assimp" err; then
    expect_rc 1 "glTF without assimp"
    expect_err "^phks: cube.gltf: built without assimp: cannot read .gltf$"
    run "$phks" signature cube.glb; expect_rc 1 "GLB without assimp"
    expect_err "built without assimp: cannot read .glb"
    gzip -c cube.glb > cube.glb.gz
    run "$phks" signature cube.glb.gz; expect_rc 1 "gzip'd GLB without assimp"
    expect_err "^phks: cube.glb.gz: built without assimp: cannot read .glb$"
    echo "cli: built without assimp: the glTF checks are skipped"
else
    expect_rc 0 "signature of cube.gltf"
    [ -s err ] && fail "cube.gltf: a message"
    sed 1d out > cube_gltf.json
    run "$phks" signature cube.off --json; expect_rc 0 "signature of cube.off"
    sed 1d out | cmp -s - cube_gltf.json ||
        fail "cube.gltf's signature (vertex ids, numbers) is not cube.off's"
    $py -c 'import json,sys; d=json.load(sys.stdin)
assert d["vertices"] == 8 and d["triangles"] == 12, d' < out ||
        fail "cube.gltf: not 8 vertices"
    run "$phks" match cube.off cube.gltf --json; expect_rc 0 "match OFF, glTF"
    $py -c 'import json,sys; assert json.load(sys.stdin)["score"] == 0' \
        < out || fail "cube.gltf against cube.off: score not 0"
    run "$phks" signature cube.glb -o glb.sig; expect_rc 0 "signature of .glb"
    expect_out "8 vertices, 12 triangles"
    run "$phks" match glb.sig cube.off; expect_rc 0 "match GLB, OFF"
    expect_out "^score 0  similarity 1.000  "
    # Compressed scenes: inflated, then read by assimp under the name
    # without .gz, so that the files a scene refers to are found beside
    # it (a glTF's .bin here, from another folder).
    gzip -c cube.glb > cube.glb.gz
    run "$phks" signature cube.glb.gz -o glbgz.sig; expect_rc 0 \
        "signature of .glb.gz"
    expect_out "8 vertices, 12 triangles"
    run "$phks" match glbgz.sig cube.off; expect_rc 0 "match .glb.gz, OFF"
    expect_out "^score 0  similarity 1.000  "
    mkdir split
    $py -c 'import base64, json
d = json.load(open("cube.gltf"))
b = d["buffers"][0]
open("split/cube.bin", "wb").write(base64.b64decode(b["uri"].split(",")[1]))
b["uri"] = "cube.bin"
json.dump(d, open("split/cube.gltf", "w"))' || fail "writing split/cube.gltf"
    gzip split/cube.gltf
    (cd set && "$phks" signature ../split/cube.gltf.gz) >out 2>err; rc=$?
    expect_rc 0 "signature of a .gltf.gz with its .bin beside it"
    expect_out "8 vertices, 12 triangles"
    head -c 200 cube.glb.gz > cut.glb.gz
    run "$phks" signature cut.glb.gz; expect_rc 1 "a truncated .glb.gz"
    expect_err "^phks: cut.glb.gz: gzip data: truncated"
    run "$phks" signature two.gltf; expect_rc 0 "signature of two meshes"
    expect_err "^phks: two.gltf: note: 2 meshes (first, second) merged into one shape; --object NAME reads one$"
    expect_out "16 vertices, 24 triangles"
    run "$phks" --object second signature two.gltf --json; expect_rc 0 \
        "--object second (a node)"
    [ -s err ] && fail "--object second: a note"
    $py -c 'import json,sys; d=json.load(sys.stdin)
assert d["vertices"] == 8, d
assert all(f["position"][0] >= 3 for f in d["features"]), d' < out ||
        fail "--object second: not the moved cube"
    run "$phks" --object cubeA signature two.gltf; expect_rc 0 \
        "--object cubeA (a mesh)"
    expect_out "8 vertices, 12 triangles"
    run "$phks" --object third signature two.gltf; expect_rc 1 \
        "--object third in glTF"
    expect_err "no node or mesh named third (it has: first, second, cubeA, cubeB)"
    # A node and its mesh of one name, and two nodes of one name: each
    # name listed once.
    cat > same.gltf <<EOF
$gltf_head
"meshes":[{"name":"cube",$cube_primitive},{"name":"other",$cube_primitive}],
"nodes":[{"name":"cube","mesh":0},
         {"name":"cube","mesh":1,"translation":[3,0,0]}],
"scenes":[{"nodes":[0,1]}]}
EOF
    run "$phks" --object third signature same.gltf; expect_rc 1 \
        "--object third in a glTF of repeated names"
    expect_err "^phks: same.gltf: no node or mesh named third (it has: cube, other)$"
    printf '{"asset":' > broken.gltf
    run "$phks" signature broken.gltf; expect_rc 1 "a broken glTF"
    expect_err "^phks: broken.gltf: assimp: "
    mkdir scene && cp cube.gltf cube.off cube.glb.gz scene/
    run "$phks" db add scene.db scene -j 1 --allow-duplicates; expect_rc 0 \
        "db add of a folder"
    run "$phks" db list scene.db; expect_rc 0 "db list"
    expect_out "scene/cube.gltf"; expect_out "scene/cube.off"
    expect_out "scene/cube.glb.gz"
    run "$phks" signature nowhere.glb; expect_rc 1 "a missing GLB"
    expect_err "^phks: nowhere.glb: No such file"
fi

# ---- match ------------------------------------------------------------------
run "$phks" match a.off b.off; expect_rc 0 "match meshes"
expect_out "^score "; expect_out "position in A"
run "$phks" match a.sig a.off; expect_rc 0 "match blob and mesh"
expect_out "^score 0  similarity 1.000  verified \([0-9]*\) of \1$"
run "$phks" match a.sig a.off --json; expect_rc 0 "match itself --json"
$py -c 'import json,sys; d=json.load(sys.stdin)
assert d["similarity"] == 1 and d["verified"] == d["features"] > 0, d' \
    < out || fail "match of a signature with itself: not 1, n of n"
run "$phks" --matching nearest match a.off b.off; expect_rc 0 \
    "match --matching nearest"
expect_out "^score [0-9.]*  similarity 0\.[0-9]*  verified 0 of [1-9]"
run "$phks" match a.sig b.off --operator literal; expect_rc 1 \
    "match of different options"
expect_err "different options"
run "$phks" match a.off; expect_rc 2 "match with one file"
run "$phks" match a.off missing.off; expect_rc 1 "match with a missing file"
expect_err "^phks: missing.off: "

# ---- segment ----------------------------------------------------------------
# plyinfo FILE: a small PLY reader (ascii and binary_little_endian): prints
# "format", the element counts, and checks that every face's corners are
# vertices, regions are -1..features-1, features name vertices whose
# position they carry, and that each vertex carries a region and colour.
cat > plyinfo.py <<'PY'
import struct, sys
data = open(sys.argv[1], 'rb').read()
end = data.index(b'end_header\n') + len(b'end_header\n')
header = data[:end].decode().split('\n')
assert header[0] == 'ply'
fmt = header[1].split()[1]
elements = []
for line in header:
    w = line.split()
    if w and w[0] == 'element':
        elements.append((w[1], int(w[2]), []))
    elif w and w[0] == 'property':
        elements[-1][2].append(w[1:])
codes = {'uchar': 'B', 'char': 'b', 'int': 'i', 'uint': 'I', 'float': 'f',
         'double': 'd', 'short': 'h', 'ushort': 'H'}
pos = end
tokens = data[end:].split() if fmt == 'ascii' else None
at = 0
def read(t):
    global pos, at
    if fmt == 'ascii':
        at += 1
        v = tokens[at - 1]
        return float(v) if t in ('float', 'double') else int(v)
    c = '<' + codes[t]
    v = struct.unpack_from(c, data, pos)[0]
    pos += struct.calcsize(c)
    return v
rows = {}
for name, count, props in elements:
    rows[name] = []
    for _ in range(count):
        r = {}
        for p in props:
            if p[0] == 'list':
                n = read(p[1])
                r[p[3]] = [read(p[2]) for _ in range(n)]
            else:
                r[p[1]] = read(p[0])
        rows[name].append(r)
assert (pos == len(data)) if fmt != 'ascii' else (at == len(tokens))
V, F, R = rows['vertex'], rows['face'], rows['feature']
for f in F:
    assert all(0 <= i < len(V) for i in f['vertex_indices'])
    assert -1 <= f['region'] < len(R)
for v in V:
    assert -1 <= v['region'] < len(R) and 0 <= v['red'] <= 255
for k, r in enumerate(R):
    v = V[r['vertex']]
    assert r['region'] == k and (v['x'], v['y'], v['z']) == (r['x'], r['y'], r['z'])
    assert v['file_vertex'] == r['file_vertex']
print(fmt, len(V), len(F), len(R), len({(f['red'], f['green'], f['blue']) for f in F}),
      ' '.join(str(r['file_vertex']) for r in R))
PY
py=/usr/bin/python3
run "$phks" segment a.off -o seg.ply; expect_rc 0 "segment"
expect_out "regions of HKS"; expect_out "wrote seg.ply"
head -c 40 seg.ply | grep -q 'format binary_little_endian' ||
    fail "seg.ply: not binary little-endian by default"
info=$($py plyinfo.py seg.ply) || fail "seg.ply: not read back"
set -- $info
[ "$1 $2 $3" = "binary_little_endian 266 528" ] || fail "seg.ply: $info"
[ "$4" -ge 3 ] && [ "$5" -ge 3 ] || fail "seg.ply: regions/colours $info"
run "$phks" segment a.off -o seg.ply --ascii --regions 4 --time 20 --json
expect_rc 0 "segment --ascii --regions 4 --time 20 --json"
$py -c 'import json,sys; d=json.load(sys.stdin)
assert d["region_count"] == 4 == len(d["regions"]) and d["time"] == 20
assert d["format"] == "ascii" and d["vertices"] == 266
assert sum(r["triangles"] for r in d["regions"]) <= 528
assert all(0 <= r["vertex"] < 266 and r["hks"] > 0 for r in d["regions"])
print(" ".join(str(r["vertex"]) for r in d["regions"]))' < out > ids ||
    fail "segment --json"
info=$($py plyinfo.py seg.ply) || fail "ascii seg.ply: not read back"
set -- $info
[ "$1 $2 $3 $4" = "ascii 266 528 4" ] || fail "ascii seg.ply: $info"
shift 5
[ "$*" = "$(cat ids)" ] || fail "segment: feature vertices $* not $(cat ids)"
run "$phks" segment a.off -o seg.obj; expect_rc 1 "segment -o seg.obj"
expect_err "seg.obj: segment writes PLY only"
[ -e seg.obj ] && fail "segment wrote seg.obj"
run "$phks" segment a.off -o x.ply --regions 0; expect_rc 2 "--regions 0"
expect_err "^phks: --regions: '0' is not a whole number from 1 to 100000$"
run "$phks" segment a.off -o x.ply --time -1; expect_rc 2 "--time -1"
expect_err "^phks: --time: '-1' is not a time above 0 and at most 1e9 (in units of tau)$"
run "$phks" segment a.off; expect_rc 2 "segment without -o"
expect_err "usage: phks segment"
run "$phks" segment bad.off -o x.ply; expect_rc 1 "segment of a bad mesh"
expect_err "^phks: bad.off: "

# segment keeps the file's used vertices; file_vertex maps them back.
run "$phks" segment shifted.off -o shifted.ply --regions 4 --time 20 --json
expect_rc 0 "segment of shifted.off"
info=$($py plyinfo.py shifted.ply) || fail "shifted.ply: not read back"
set -- $info
[ "$2 $3 $4" = "266 528 4" ] || fail "shifted.ply: $info"
shift 5
# (the maxima's HKS values tie to rounding, so their order may differ)
[ "$(echo "$*" | tr ' ' '\n' | sort -n | tr '\n' ' ')" = \
  "$(tr ' ' '\n' < ids | awk 'NF { print $1 + 5 }' | sort -n | tr '\n' ' ')" ] ||
    fail "shifted.ply: feature file_vertex $* not ids + 5"
$py -c 'import json,sys; d=json.load(sys.stdin)
assert sorted(r["vertex"] for r in d["regions"]) == sorted(int(i) + 5 for i in open("ids").read().split())' \
    < out || fail "segment --json of shifted.off: ids not in the file's numbering"

# ---- db ---------------------------------------------------------------------
# The ids follow the command line whatever -j.
run "$phks" db add t.db a.off b.off --label blob -j 1; expect_rc 0 "db add"
expect_out "^added 1 a.off$"; expect_out "2 added, 0 failed"
run "$phks" db list t.db; expect_rc 0 "db list"
expect_out "^ *1  blob  *[0-9][0-9]*  a.off$"; expect_out "^ *2  blob .* b.off$"
run "$phks" db add t.db missing.off set/star/0.off; expect_rc 1 \
    "db add with a missing file"
expect_err "^phks: missing.off: "; expect_out "1 added, 1 failed"
run "$phks" db add m.db --manifest set/MANIFEST.tsv -j 2; expect_rc 0 \
    "db add --manifest"
expect_out "8 added"
run "$phks" db list m.db; expect_rc 0 "db list of the manifest"
expect_out "bar .* bar/3.off"; expect_out "star .* star/0.off"
# Eight meshes on four workers, twice: the same ids for the same files, in
# the order given (the workers finish in any order).
for run_no in 1 2; do
    run "$phks" db add "j4-$run_no.db" set/bar/* set/star/* -j 4; expect_rc 0 \
        "db add -j 4, run $run_no"
    "$phks" db list "j4-$run_no.db" --json > "j4-$run_no.json" ||
        fail "db list --json of run $run_no"
done
cmp -s j4-1.json j4-2.json || fail "db add -j 4: the ids differ between runs"
$py -c 'import json,sys; d=json.load(sys.stdin)
assert [e["name"] for e in d] == sys.argv[1:], d' set/bar/* set/star/* \
    < j4-1.json || fail "db add -j 4: the ids are not in the order given"
run "$phks" db query t.db a.sig -k 2; expect_rc 0 "db query"
expect_out "^ *1 *1 *0 *1.000 *\([0-9]*\)/\1 *blob *a.off$"
expect_out "similarity verified"
[ "$(wc -l < out)" -eq 3 ] || fail "db query -k 2: not 2 hits"
run "$phks" db query t.db a.off --json -k 1; expect_rc 0 "db query --json"
expect_out '"rank": 1, "id": 1, "score": 0, "similarity": 1, "verified": \([0-9]*\), "features": \1, "label": "blob", "name": "a.off"'
if command -v python3 >/dev/null; then
    python3 -c 'import json,sys; assert len(json.load(sys.stdin)) == 1' \
        < out || fail "db query --json: not JSON"
fi
run "$phks" db query t.db a.off -k 0; expect_rc 2 "db query -k 0"
expect_err "^phks: -k: '0' is not a whole number from 1 to 1000000$"
# A database made with other options: add and query use the database's.
run "$phks" --hks-scaling none db add plain.db a.off -j 1; expect_rc 0 \
    "db add with --hks-scaling none"
run "$phks" db add plain.db b.off -j 1; expect_rc 0 \
    "db add with the defaults to a database made with none"
run "$phks" db query plain.db b.off -k 1; expect_rc 0 \
    "db query with the defaults of a database made with none"
expect_out "^ *1 *2 *0 .* b.off$"
run "$phks" --hks-scaling none db add t.db b.off -j 1; expect_rc 1 \
    "db add with an explicit option the database differs in"
expect_err "^phks: t.db: the options given are not the database's: --hks-scaling none against local-area (drop the option, or use another database)$"
run "$phks" --operator literal db query t.db b.off; expect_rc 1 \
    "db query with an explicit option the database differs in"
expect_err "^phks: t.db: the options given are not the database's: --operator literal against random-walk "
run "$phks" --hks-scaling local-area db query t.db b.off -k 1; expect_rc 0 \
    "an explicit option equal to the database's"
# A blob made with other options: the option and both values in the tool's
# words, never the library's C names (hks_scaling, local_area).
run "$phks" --hks-scaling none signature a.off -o none.sig; expect_rc 0
run "$phks" db add t.db none.sig; expect_rc 1 "db add of an incompatible blob"
expect_err "^phks: none.sig: made with other options than the database's: --hks-scaling none against local-area$"
run "$phks" db query t.db none.sig; expect_rc 1 "db query of an incompatible blob"
expect_err "^phks: none.sig: made with other options than the database's: --hks-scaling none against local-area$"
! grep -q "hks_scaling\|local_area" err || fail "db query: C spelling in a message"
# --quadrature: a box of 12 triangles (its faces far longer than the
# kernel), the default recorded, triangles refused against a database
# made at the vertices.
printf 'OFF\n8 12 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n3 0 2 1\n3 0 3 2\n3 4 5 6\n3 4 6 7\n3 0 1 5\n3 0 5 4\n3 1 2 6\n3 1 6 5\n3 2 3 7\n3 2 7 6\n3 3 0 4\n3 3 4 7\n' > box.off
run "$tool" signature box.off --json; expect_rc 0 "signature of the box"
expect_out '"quadrature": "triangles"'
run "$phks" signature box.off --json; expect_rc 0 \
    "signature --quadrature vertices"
expect_out '"quadrature": "vertices"'
run "$tool" --quadrature bogus signature box.off; expect_rc 2 \
    "--quadrature bogus"
expect_err "^phks: --quadrature: 'bogus' is not one of vertices, triangles$"
run "$tool" --quadrature triangles db query t.db box.off; expect_rc 1 \
    "db query --quadrature triangles against a database made without"
expect_err "^phks: t.db: the options given are not the database's: --quadrature triangles against vertices "
run "$tool" signature box.off -o q.sig; expect_rc 0
run "$phks" match q.sig box.off; expect_rc 1 "match of blobs made with other quadratures"
expect_err "^phks: q.sig and box.off: made with different options: --quadrature triangles against vertices$"
# --local-descriptor: recorded, refused against a database or a blob of
# the other one (both verified); ignored with --matching nearest.
run "$phks" --local-descriptor heat signature box.off --json; expect_rc 0 \
    "signature --local-descriptor heat"
expect_out '"local_descriptor": "heat"'
run "$phks" --local-descriptor hks signature box.off; expect_rc 2 \
    "--local-descriptor hks"
expect_err "^phks: --local-descriptor: 'hks' is not one of heat, spin$"
run "$phks" --local-descriptor heat db query t.db box.off; expect_rc 1 \
    "db query --local-descriptor heat against a database of spin images"
expect_err "^phks: t.db: the options given are not the database's: --local-descriptor heat against spin "
run "$phks" --local-descriptor heat signature box.off -o h.sig; expect_rc 0
run "$phks" match h.sig box.off; expect_rc 1 "match of blobs made with other local descriptors"
expect_err "^phks: h.sig and box.off: made with different options: --local-descriptor heat against spin$"
run "$phks" --matching nearest --local-descriptor heat signature box.off \
    -o hn.sig; expect_rc 0
run "$phks" --matching nearest match hn.sig box.off; expect_rc 0 \
    "nearest matching ignores the local descriptor"
# --global-descriptor: recorded, refused against a database of the other
# one (both verified), shown in the options summary; ignored with
# --matching nearest.
run "$phks" --global-descriptor d2 signature box.off --json; expect_rc 0 \
    "signature --global-descriptor d2"
expect_out '"global_descriptor": "d2"'
run "$phks" --global-descriptor D2 signature box.off; expect_rc 2 \
    "--global-descriptor D2"
expect_err "^phks: --global-descriptor: 'D2' is not one of none, d2$"
run "$phks" --global-descriptor d2 db query t.db box.off; expect_rc 1 \
    "db query --global-descriptor d2 against a database without"
expect_err "^phks: t.db: the options given are not the database's: --global-descriptor d2 against none "
run "$phks" db info t.db; expect_rc 0 "db info"
expect_out "matching verified, local descriptor spin, global descriptor none, HKS-simp"
run "$phks" --global-descriptor d2 signature a.off -o d2.sig; expect_rc 0 \
    "a d2 blob"
run "$phks" --global-descriptor d2 match d2.sig b.off; expect_rc 0 \
    "match of a d2 blob"
head -n 1 out > d2_blob_line
run "$phks" --global-descriptor d2 match a.off b.off; expect_rc 0 \
    "d2 match of meshes"
head -n 1 out | cmp -s - d2_blob_line ||
    fail "a d2 blob scores other than its mesh: $(cat d2_blob_line)"
run "$phks" match a.off b.off; expect_rc 0 "match without d2"
head -n 1 out | cmp -s - d2_blob_line &&
    fail "d2 leaves the score as it was: $(cat d2_blob_line)"
run "$phks" --matching nearest --global-descriptor d2 signature box.off \
    -o dn.sig; expect_rc 0 "a nearest signature leaves the global descriptor out"
run "$phks" --matching nearest match dn.sig box.off; expect_rc 0 \
    "nearest matching ignores the global descriptor"
# Blobs, directories, duplicates.
mkdir -p tree/sub tree/sub/deeper
cp a.off tree/sub/z.off; cp a.sig tree/a.sig; cp b.off tree/sub/deeper/b.off
cp a.off tree/readme.txt
run "$phks" db add d.db tree -j 1; expect_rc 0 "db add of a directory"
expect_out "^added 1 tree/a.sig$"; expect_out "^added 2 tree/sub/deeper/b.off$"
expect_out "^skipped tree/sub/z.off: the same signature as entry 1$"
expect_out "^d.db: 2 added, 0 failed, skipped 1 duplicate$"
grep -q readme out && fail "db add took readme.txt"
run "$phks" db add d.db a.off b.off tree -j 2; expect_rc 0 "db add again"
expect_out "^d.db: 0 added, 0 failed, skipped 5 duplicates$"
run "$phks" db add d.db a.sig --allow-duplicates; expect_rc 0 \
    "db add --allow-duplicates"
expect_out "^added 3 a.sig$"
run "$phks" db list d.db --json; expect_rc 0 "db list --json"
$py -c 'import json,sys; d=json.load(sys.stdin)
assert [e["id"] for e in d] == [1, 2, 3]
assert [e["name"] for e in d] == ["tree/a.sig", "tree/sub/deeper/b.off", "a.sig"]
assert all(e["label"] == "" and e["features"] > 0 for e in d)' < out ||
    fail "db list --json"
run "$phks" --progress db add p.db a.off b.off -j 1; expect_rc 0 \
    "db add --progress"
expect_err "^phks: 2/2 files$"
run "$phks" db info d.db; expect_rc 0 "db info"
expect_out "^path *d.db$"; expect_out "^format *2$"; expect_out "^entries *3$"
expect_out "^options *operator random-walk, .*HKS scaling local-area"
run "$phks" db info plain.db --json; expect_rc 0 "db info --json"
$py -c 'import json,sys; d=json.load(sys.stdin)
assert d["path"] == "plain.db" and d["format"] == 2 and d["entries"] == 2
o = d["options"]
assert o["hks_scaling"] == "none" and o["operator"] == "random-walk"
assert o["feature_count"] == 15 and len(o["scales"]) == 15 and o["tau"] == 0.0002
assert o["boundary_margin"] == 2 and o["box"] == "principal"' < out ||
    fail "db info --json"
run "$phks" db info missing.db; expect_rc 1 "db info of no db"
grep -q 'PHKS_' err && fail "a C identifier in a message"
expect_err "phks: missing.db: .*phks db add. creates a database"
run "$phks" db query missing.db a.off; expect_rc 1 "db query of no db"
expect_err "^phks: missing.db: "
run "$phks" db query bad.off a.off; expect_rc 1 "db query of a non-db"
expect_err "^phks: bad.off: "
run "$phks" db remove t.db 1; expect_rc 0 "db remove"
run "$phks" db list t.db; expect_rc 0 "db list after remove"
grep -q 'a.off' out && fail "db remove: a.off still listed"
run "$phks" db remove t.db 1; expect_rc 1 "db remove of a removed id"
expect_err "^phks: t.db: no entry with id 1$"
run "$phks" db remove t.db one; expect_rc 2 "db remove of a non-number"
run "$phks" db frob t.db; expect_rc 2 "unknown db command"

# ---- bench ------------------------------------------------------------------
# class_row CLASS TSV: the by-class row of the bench report, as the ranks
# of the class's queries in the --queries-out file TSV give it.
class_row() {
    awk -F'\t' -v c="$1" '
        function pct(h, n) {
            return n ? sprintf(" %.1f |", 100 * h / n) : " - |"
        }
        NR > 1 && $4 == c {
            if ($5 < 0) { failed++; next }
            s = $2 == "complete" ? 1 : 2
            n[s]++; n[3]++
            for (k = 1; k <= 5; k += 2)
                if ($5 >= 1 && $5 <= k) { h[s, k]++; h[3, k]++ }
        }
        END {
            row = sprintf("| %s | %d | %d |", c, n[3], failed)
            for (s = 1; s <= 3; s++)
                for (k = 1; k <= 5; k += 2)
                    row = row pct(h[s, k], n[s])
            print row
        }' "$2"
}
# The by-class table's rows of out (without --group): their queries (n)
# summed.
class_queries() {
    awk -F'|' '/^\| class \| n \|/ { on = 1; getline; next }
        on && !NF { on = 0 } on { n += $3 } END { print n + 0 }' out
}
# documented WHAT: every key of the JSON in out is a word of a code span of
# docs/cli.md.
documented() {
    $py -c 'import json,re,sys
words = {w for span in re.findall(r"`([^`]*)`", open(sys.argv[1]).read())
         for w in re.findall(r"\w+", span)}
def keys(x):
    if isinstance(x, dict):
        for k, v in x.items():
            yield k
            yield from keys(v)
    elif isinstance(x, list):
        for v in x:
            yield from keys(v)
missing = sorted(set(keys(json.load(sys.stdin))) - words)
assert not missing, missing' "$docs" < out ||
        fail "$1: JSON fields missing in docs/cli.md"
}
run "$phks" bench set/MANIFEST.tsv --prefix "" --cache cache \
    --queries-out q.tsv -j 2 --no-source
expect_rc 0 "bench"
for c in star bar; do
    grep -qxF -- "$(class_row $c q.tsv)" out ||
        fail "bench: the by-class row of $c is not $(class_row $c q.tsv)"
done
[ "$(class_queries)" -eq "$(awk -F'|' '/^\| all \|/ { print $3 + 0 }' out)" ] ||
    fail "bench: the classes' queries do not add up to all"
expect_out "| queries | n | failed | Top-1 | Top-3 | Top-5 |"
expect_out "^| all | "; expect_out "^| partial+incomplete | "
expect_out "next to the cut"
expect_out "8 models: 2 query models (6 queries per seed), 6 database models"
expect_out "Signatures: 12 computed, 0 from the cache"
[ "$(wc -l < q.tsv)" -eq 7 ] || fail "bench: q.tsv has not 7 lines"
head -1 q.tsv | grep -q "^file	kind	seed	class	rank	top1_label	top1_score	top1_similarity	top1_verified	features$" ||
    fail "bench: q.tsv header"
awk -F'\t' 'NR > 1 && !($8 >= 0 && $8 <= 1 && $9 <= $10 && $10 > 0 &&
                        $7 >= 0) { bad = 1 } END { exit bad }' q.tsv ||
    fail "bench: q.tsv top1 score, similarity or verified out of range"
[ "$(ls cache | grep -c '^[0-9a-f]\{16\}\.sig$')" -eq 12 ] ||
    fail "bench: cache has not 12 signatures"
cp q.tsv q1.tsv
run "$phks" bench set/MANIFEST.tsv --prefix "" --cache cache \
    --queries-out q.tsv -j 1 --no-source
expect_rc 0 "bench from the cache"
expect_out "Signatures: 0 computed, 12 from the cache"
cmp -s q.tsv q1.tsv || fail "bench: results differ with the cache and -j 1"
run "$phks" bench set/MANIFEST.tsv --prefix "" --cache cache -j 1 --json \
    --progress --no-source
expect_rc 0 "bench --json"
expect_err "^phks: 12/12 signatures$"
$py -c 'import json,sys; d=json.load(sys.stdin)
assert d["signatures"] == {"computed": 0, "cached": 12, "failed": 0}
assert d["models"] == 8 and d["query_models"] == 2 and d["queries_per_seed"] == 6
p = d["pooled"]
rows = {r["queries"]: r for r in p["retrieval"]}
assert list(rows) == ["complete", "partial", "incomplete", "partial+incomplete", "all"]
assert rows["all"]["n"] + rows["all"]["failed"] == 6
assert rows["all"]["n"] == sum(rows[k]["n"] for k in ("complete", "partial", "incomplete"))
assert len(d["seeds"]) == 1 and d["seeds"][0]["results"] == p
assert p["database"]["entries"] == 6 and len(p["cut"]) == 3
assert d["source"] is None
c = {x["class"]: x for x in d["by_class"]}
assert list(c) == ["star", "bar"] and d["group"] is None
assert sum(x["queries"] for x in c.values()) == rows["all"]["n"]
for k in ("failed", "top1_hits", "top3_hits", "top5_hits"):
    assert sum(x["retrieval"][2][k] for x in c.values()) == rows["all"][k]
sets = ["complete", "partial+incomplete", "all"]
assert [r["queries"] for r in c["star"]["retrieval"]] == sets
print("| all | %d | %d |" % (rows["all"]["n"], rows["all"]["failed"]))' \
    < out > all_row || fail "bench --json"
run "$phks" bench set/MANIFEST.tsv --prefix "" --cache cache -j 1 --no-source
expect_out "^$(cat all_row)"
grep -q "Source retrieval" out && fail "bench --no-source: a source table"
# --group: one more by-class row; of every class, the query sets' rows.
run "$phks" bench set/MANIFEST.tsv --prefix "" --cache cache -j 1 --no-source \
    --json --group both=bar,star
expect_rc 0 "bench --group"
$py -c 'import json,sys; d=json.load(sys.stdin)
rows = {r["queries"]: r for r in d["pooled"]["retrieval"]}
g = d["group"]
assert g["name"] == "both" and g["classes"] == "bar,star"
assert g["queries"] == rows["all"]["n"] and g["failed"] == rows["all"]["failed"]
assert g["retrieval"] == [rows[k]
                          for k in ("complete", "partial+incomplete", "all")]' \
    < out || fail "bench --json --group"
documented "bench --json --group"
run "$phks" bench set/MANIFEST.tsv --prefix "" --cache cache -j 1 --no-source \
    --group "one of them=star"
expect_rc 0 "bench --group, markdown"
expect_out "; the last row, one of them, pools star:$"
star=$(class_row star q.tsv)
grep -qxF -- "| one of them |${star#| star |}" out ||
    fail "bench --group: its row is not star's"
run "$phks" bench set/MANIFEST.tsv --prefix "" --group both=star,nope
expect_rc 1 "bench --group of an unknown class"
expect_err "no class nope among the selected classes"
run "$phks" bench set/MANIFEST.tsv --prefix "" --classes star --group x=bar
expect_rc 1 "bench --group of a class not selected"; expect_err "no class bar"
run "$phks" bench set/MANIFEST.tsv --prefix "" --group star
expect_rc 2 "bench --group without a name"; expect_err "NAME=A,B"
# The source part: every version of every model, the protocol's cached.
run "$phks" bench set/MANIFEST.tsv --prefix "" --cache cache -j 2 --json \
    --one-character bar
expect_rc 0 "bench with the source part"
$py -c 'import json,sys; d=json.load(sys.stdin)
assert d["signatures"] == {"computed": 12, "cached": 12, "failed": 0}
s = d["source"]
assert s["one_character"] == "bar" and s["database"] == {"entries": 8, "failed": 0}
assert len(s["seeds"]) == 1 and s["seeds"][0]["results"] == s["pooled"]
r = {x["queries"]: x for x in s["pooled"]["retrieval"]}
c = {x["versions"]: x for x in s["pooled"]["correspondences"]}
assert list(r) == list(c) == ["partial", "incomplete", "partial+incomplete"]
assert r["partial+incomplete"]["n"] == 16 and c["partial+incomplete"]["n"] == 16
assert r["partial"]["top1_hits"] <= r["partial"]["top5_hits"] <= 8
assert c["partial"]["verified_correct"] <= c["partial"]["verified"] <= c["partial"]["features"]
assert c["partial"]["median_error"] >= 0' < out ||
    fail "bench --json: the source part"
documented "bench --json with the source part"
run "$phks" bench set/MANIFEST.tsv --prefix "" --cache cache -j 1
expect_out "^## Source retrieval and correspondences"
expect_out "^| versions | n | failed | features | correct, percent | "
expect_out "^| partial+incomplete | 16 | 0 | "
run "$phks" bench set/MANIFEST.tsv --prefix "" --seeds 2 --classes star \
    --max-per-class 4 --queries-out q3.tsv
expect_rc 0 "bench --seeds 2"
grep -qxF -- "$(class_row star q3.tsv)" out ||
    fail "bench --seeds 2: the by-class row is not the seeds' pooled"
[ "$(grep -c '^| class |' out)" -eq 1 ] ||
    fail "bench --seeds 2: a by-class table per seed"
expect_out "^## Seed 2"; expect_out "^## All seeds (pooled)"
expect_out "^### Seed 2"; expect_out "^### All seeds (pooled)"
run "$phks" bench set/MANIFEST.tsv --prefix "" --classes nope
expect_rc 1 "bench of an unknown class"; expect_err "no class nope"
run "$phks" bench missing.tsv; expect_rc 1 "bench of a missing manifest"
expect_err "^phks: missing.tsv: "
run "$phks" bench set/MANIFEST.tsv --seeds 0; expect_rc 2 "bench --seeds 0"
expect_err "^phks: --seeds: '0' is not a whole number from 1 to 1000000$"
# The comparison rows: a comparison run with a cache stores every output
# of each version's one eigen-solve (the three feature functions'
# signatures and the eigenvalues), and the other rows' runs read them;
# its HKS signatures are the default run's.
run "$phks" bench set/MANIFEST.tsv --prefix "" --cache rows -j 2 --no-source \
    --feature-function agd
expect_rc 0 "bench --feature-function agd"
expect_out "^Feature function: agd; descriptor: the signatures"
expect_out "Signatures: 12 computed, 0 from the cache"
[ "$(ls rows | grep -c '^[0-9a-f]\{16\}\.sig$')" -eq 36 ] &&
    [ "$(ls rows | grep -c '^[0-9a-f]\{16\}\.evd$')" -eq 12 ] ||
    fail "bench --feature-function agd: not 36 signatures and 12 eigenvalues"
for row in "--feature-function gc" "--descriptor evd" "--feature-function hks"
do
    run "$phks" bench set/MANIFEST.tsv --prefix "" --cache rows -j 1 \
        --no-source --queries-out q2.tsv $row
    expect_rc 0 "bench $row"
    expect_out "Signatures: 0 computed, 12 from the cache"
    expect_out "^| all | 6 | 0 | "
done
cmp -s q2.tsv q1.tsv || fail "bench: the comparison run's HKS signatures differ"
run "$phks" bench set/MANIFEST.tsv --prefix "" --descriptor evd -j 2 --no-source
expect_rc 0 "bench --descriptor evd"
expect_out "^Feature function: hks; descriptor: evd"
expect_out "Signatures: 12 computed, 0 from the cache"
run "$phks" bench set/MANIFEST.tsv --feature-function sift
expect_rc 2 "bench --feature-function sift"
run "$phks" bench set/MANIFEST.tsv --descriptor evd --feature-function gc
expect_rc 2 "bench --descriptor evd --feature-function gc"
expect_err "no --feature-function"
# ---- bench on lists of one's own -------------------------------------------
# A database of six meshes of three classes; queries: a copy of star0's
# file (identical to that entry), bar1 and egg0 themselves (files of both
# lists: one signature each), and egg1 without a source.
mkdir -p lists/m
blob 24 12 1.0 1.0 0.5 0.35 3 > lists/m/star0.off
blob 24 12 1.0 1.0 0.5 0.25 5 > lists/m/star1.off
blob 24 12 1.3 0.4 0.3 0.05 2 > lists/m/bar0.off
blob 24 12 1.1 0.4 0.3 0.02 2 > lists/m/bar1.off
blob 24 12 0.6 0.6 0.9 0.15 4 > lists/m/egg0.off
blob 24 12 0.6 0.7 0.9 0.10 4 > lists/m/egg1.off
for f in star0 bar0 egg0; do cp lists/m/$f.off lists/m/$f-copy.off; done
printf 'file\tclass\tname\n' > lists/db.tsv
for f in star0 star1 bar0 bar1 egg0 egg1; do
    printf 'm/%s.off\t%s\t%s\n' $f "${f%?}" $f >> lists/db.tsv
done
printf '%s\t%s\t%s\t%s\n' file class kind source \
    m/star0-copy.off star complete star0 m/bar1.off bar partial bar1 \
    m/egg0.off egg incomplete egg0 m/egg1.off egg "" "" > lists/q.tsv
run "$phks" bench --db lists/db.tsv --queries lists/q.tsv --cache lcache \
    -j 2 --json
expect_rc 0 "bench --db --queries"
$py -c 'import json,sys; d=json.load(sys.stdin)
assert d["mode"] == "queries" and d["db_list"] == "lists/db.tsv"
assert d["queries_list"] == "lists/q.tsv"
assert d["database_entries"] == 6 and d["query_count"] == 4
assert d["signatures"] == {"computed": 7, "cached": 0, "failed": 0}
r = d["results"]
assert r["database"] == {"entries": 6, "complete": 6, "partial": 0,
                         "incomplete": 0, "failed": 0}
n = {x["queries"]: x["n"] for x in r["retrieval"]}
assert n == {"complete": 2, "partial": 1, "incomplete": 1,
             "partial+incomplete": 2, "all": 4}, n
assert [c["class"] for c in d["by_class"]] == ["star", "bar", "egg"]
assert [c["queries"] for c in d["by_class"]] == [1, 1, 2]
s = d["source"]
assert s["named"] == 3
src = {x["queries"]: x for x in s["retrieval"]}
assert src["all"]["n"] == 3 and src["all"]["top1"] == 100, src["all"]
q = d["queries"]
assert [x["name"] for x in q] == ["m/star0-copy.off", "m/bar1.off",
                                  "m/egg0.off", "m/egg1.off"]
assert [x["kind"] for x in q] == ["complete", "partial", "incomplete",
                                  "complete"]
assert [x["source_rank"] for x in q] == [1, 1, 1, None]
assert [x["best"] for x in q][:3] == ["star0", "bar1", "egg0"]
assert q[3]["source"] is None
for x in q:
    assert 0 <= x["rank"] <= 20 and x["best_class"] is not None
# Its ranks in the --queries-out form, for class_row.
print("name\tkind\tseed\tclass\trank")
for x in q:
    print("%s\t%s\t1\t%s\t%d" % (x["name"], x["kind"], x["class"], x["rank"]))' \
    < out > lq.tsv || fail "bench --db --queries --json"
documented "bench --db --queries --json"
run "$phks" bench --db lists/db.tsv --queries lists/q.tsv --cache lcache -j 1
expect_rc 0 "bench --db --queries, markdown"
expect_out "database lists/db.tsv (6 entries), queries lists/q.tsv (4 queries)"
expect_out "^Database: 6 entries (6 complete, 0 partial, 0 incomplete), 0 failed"
expect_out "^## Source retrieval"; expect_out "^The 3 queries that name"
expect_out "^| all | 3 | 0 | 100.0 | 100.0 | 100.0 |$"
expect_out "Signatures: 0 computed, 7 from the cache, 0 failed"
grep -q "next to the cut" out && fail "bench --db: a table of cuts"
for c in star bar egg; do
    grep -qxF -- "$(class_row $c lq.tsv)" out ||
        fail "bench --db: the by-class row of $c is not $(class_row $c lq.tsv)"
done
# Leave-one-out: two identical meshes per class (bar0 one file under two
# names, one signature) find each other first, never themselves.
printf '%s\t%s\t%s\n' file class name \
    m/star0.off star star0 m/star0-copy.off star star0-copy \
    m/bar0.off bar bar0 m/bar0.off bar bar0-again \
    m/egg0.off egg egg0 m/egg0-copy.off egg egg0-copy > lists/twins.tsv
run "$phks" bench --leave-one-out lists/twins.tsv --cache lcache -j 2 --json
expect_rc 0 "bench --leave-one-out"
$py -c 'import json,sys; d=json.load(sys.stdin)
assert d["mode"] == "leave-one-out" and d["queries_list"] is None
assert d["database_entries"] == 6 and d["query_count"] == 6
sig = d["signatures"]
assert sig["computed"] + sig["cached"] == 5 and sig["failed"] == 0, sig
rows = {x["queries"]: x for x in d["results"]["retrieval"]}
assert rows["all"]["n"] == 6 and rows["all"]["top1"] == 100
assert d["source"] is None
twin = {"star0": "star0-copy", "bar0": "bar0-again", "egg0": "egg0-copy"}
twin.update({v: k for k, v in twin.items()})
for x in d["queries"]:
    assert x["rank"] == 1 and x["best"] == twin[x["name"]], x' < out ||
    fail "bench --leave-one-out --json"
documented "bench --leave-one-out --json"
run "$phks" bench --leave-one-out lists/twins.tsv --cache lcache -j 2
expect_rc 0 "bench --leave-one-out, markdown"
expect_out "leave-one-out over lists/twins.tsv (6 entries)"
expect_out "^| all | 6 | 0 | 100.0 | 100.0 | 100.0 |$"
expect_out "^| bar | 2 | 0 | 100.0 | "
# Bad lists: named by file and line, before any signature.
printf 'file\tkind\nm/star0.off\tcomplete\n' > lists/no-class.tsv
run "$phks" bench --db lists/db.tsv --queries lists/no-class.tsv
expect_rc 1 "bench --queries without a class column"
expect_err "^phks: lists/no-class.tsv:1: the header names no column \"class\""
printf 'file\tclass\tkind\nm/star0.off\tstar\tcomplete\nm/bar0.off\tbar\tscan\n' \
    > lists/bad-kind.tsv
run "$phks" bench --db lists/db.tsv --queries lists/bad-kind.tsv
expect_rc 1 "bench --queries of an unknown kind"
expect_err "^phks: lists/bad-kind.tsv:3: unknown kind \"scan\""
printf 'file\tclass\tsource\nm/star0.off\tstar\tstar0\nm/bar0.off\tbar\tbar9\n' \
    > lists/bad-source.tsv
run "$phks" bench --db lists/db.tsv --queries lists/bad-source.tsv
expect_rc 1 "bench --queries of an unknown source"
expect_err "^phks: lists/bad-source.tsv:3: source \"bar9\" is no name of lists/db.tsv$"
printf 'file\tclass\nm/star0.off\tstar\nm/nope.off\tbar\n' > lists/no-file.tsv
run "$phks" bench --leave-one-out lists/no-file.tsv --cache lcache2
expect_rc 1 "bench --leave-one-out of a missing file"
expect_err "^phks: lists/no-file.tsv:3: lists/m/nope.off: No such file"
[ -e lcache2 ] && fail "bench of a missing file: a cache made"
printf 'file\tclass\nm/star0.off\tstar\nm/star0.off\tstar\n' > lists/twice.tsv
run "$phks" bench --db lists/twice.tsv --queries lists/q.tsv
expect_rc 1 "bench --db of one name twice"
expect_err "^phks: lists/twice.tsv:3: the name \"m/star0.off\" is line 2's too"
printf 'file\tclass\nm/star0.off\n' > lists/short.tsv
run "$phks" bench --leave-one-out lists/short.tsv
expect_rc 1 "bench --leave-one-out of a row without a class"
expect_err "^phks: lists/short.tsv:2: expected a file and a class"
run "$phks" bench --db lists/db.tsv; expect_rc 2 "bench --db without --queries"
expect_err "either --db LIST and --queries LIST, or --leave-one-out LIST"
run "$phks" bench --leave-one-out lists/twins.tsv --seeds 2
expect_rc 2 "bench --leave-one-out --seeds"; expect_err "unknown option --seeds"
run "$phks" bench set/MANIFEST.tsv --leave-one-out lists/twins.tsv
expect_rc 2 "bench MANIFEST --leave-one-out"
# The source part on real models (two classes of small meshes), when the
# shared data is there: its rates are numbers in [0, 100].
shared=${PHKS_SHARED_MESHES:-}
if [ -n "$shared" ] && [ -f "$shared/MANIFEST.tsv" ]; then
    run "$phks" bench "$shared/MANIFEST.tsv" --classes Bearing,Plier \
        --max-per-class 4 -j 2 --json
    expect_rc 0 "bench of shared models"
    $py -c 'import json,sys; d=json.load(sys.stdin)
p = d["source"]["pooled"]
rows = p["retrieval"] + p["correspondences"]
assert len(rows) == 6
for r in rows:
    for k in ("top1", "top5") if "queries" in r else ("percent", "verified_percent"):
        assert isinstance(r[k], (int, float)) and 0 <= r[k] <= 100, (r, k)' \
        < out || fail "bench of shared models: the source part"
else
    echo "cli: no shared meshes: the bench of real models is skipped"
fi
echo "cli: all checks passed"
