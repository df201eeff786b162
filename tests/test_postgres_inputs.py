#!/usr/bin/env python3
"""test_postgres_inputs.py BUILD_ROOT PHKS_TOOL PART [SHARED_MESHES]

The server stays up under bad input (issue 27): every SQL entry point of
the extension (docs/postgres.md) is fed inputs made to hurt, and each
call either succeeds or raises an ERROR with a message; the backend never
crashes and its error paths leak nothing. PART picks one group, one
meson test each so that each stays short:

  blobs   signature blobs: the text and binary input of phks_signature,
          the bytea cast, the accessors, phks_key(sig) and the scores, on
          the fuzz corpora, test_hostile.c's blobs, seeded mutations of
          valid blobs, and signatures made with other options
  meshes  phks_signature_from_mesh with every format name, on the fuzz
          corpora, test_hostile.c's meshes (non-finite, extreme and
          degenerate coordinates, lying counts, indices at UINT32_MAX,
          truncated and lying gzip, a gzip bomb) and seeded mutations of
          small meshes in every format (most with options, through
          phks_signature_from_mesh(mesh, format, options))
  keys    phks_key's text and binary input and key <#> sig on damaged and
          mutated keys
  memory  10,000 failing calls in one backend: its resident memory

The C functions behind the accessors and the scores decode their
arguments themselves, so that a damaged datum (a corrupt page) cannot
hurt them; SQL's typed input never lets one through, so the test also
declares them over bytea, in the schema raw, and hands them the bad
bytes directly.

A crash shows as (a) psql's "server closed the connection", (b) the
server log's "terminated by signal", or (c) another backend pid or
postmaster start time at the end of a psql session than at its start.
"""
import collections
import gzip
import os
import random
import re
import shutil
import struct
import sys
import time
import zlib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import pgutil  # noqa: E402

build_root, phks, part = sys.argv[1], sys.argv[2], sys.argv[3]
shared = sys.argv[4] if len(sys.argv) > 4 else os.environ.get(
    "PHKS_SHARED_MESHES", "")
source_root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
corpus = os.path.join(source_root, "fuzz", "corpus")

failures = pgutil.failures
check = pgutil.check


def sql_text(s):
    return "'" + s.replace("'", "''") + "'"


# ---------------------------------------------------------------------
# Statements, run many to a psql session with ON_ERROR_STOP off; each
# statement on one line of the script, so that psql's "psql:<stdin>:LINE:
# ERROR: ..." says whose error it is.
# ---------------------------------------------------------------------
class Statement:
    """entry: the entry point it exercises (the summary's rows); kind: the
    kind of input; expect: None (any outcome), "" (an error), or a text
    the error's message must contain."""

    def __init__(self, entry, kind, sql, expect=None):
        self.entry, self.kind, self.sql, self.expect = entry, kind, sql, expect


SESSION_STATEMENTS = 1500
IDENTITY = "SELECT 'backend', pg_backend_pid(), pg_postmaster_start_time();"
PSQL_LINE = re.compile(r"^psql:<stdin>:(\d+): (?:(\w+):\s+)?(.*)$")
CRASH_IN_PSQL = ("server closed the connection", "terminated abnormally",
                 "connection to server was lost")
CRASH_IN_LOG = ("terminated by signal", "was terminated", "server process")


class Tally:
    """Statements run and errors per entry point and per kind of input,
    and the messages of each kind's errors."""

    def __init__(self):
        self.entries = collections.OrderedDict()
        self.kinds = collections.OrderedDict()
        self.messages = collections.defaultdict(collections.Counter)

    def add(self, statement, error):
        for table, key in ((self.entries, statement.entry),
                           (self.kinds, statement.kind)):
            row = table.setdefault(key, [0, 0])
            row[0] += 1
            row[1] += error is not None
        if error is not None:
            self.messages[statement.kind][error] += 1

    def print(self):
        print("%-40s %7s %7s %8s" % ("entry point", "run", "errors",
                                     "accepted"))
        for entry, (run, errors) in self.entries.items():
            print("%-40s %7d %7d %8d" % (entry, run, errors, run - errors))
        run = sum(r[0] for r in self.entries.values())
        errors = sum(r[1] for r in self.entries.values())
        print("%-40s %7d %7d %8d" % ("total", run, errors, run - errors))
        print("\n%-32s %7s %7s %8s  most frequent error" % (
            "kind of input", "run", "errors", "accepted"))
        for kind, (run, errors) in sorted(self.kinds.items()):
            top = self.messages[kind].most_common(1)
            print("%-32s %7d %7d %8d  %s" % (kind, run, errors, run - errors,
                                             top[0][0][:80] if top else ""))


def session_script(statements):
    """The psql script of one session, and the line of its first
    statement."""
    head = ["\\set ON_ERROR_STOP off", "\\set VERBOSITY terse",
            # A tiny input never takes a minute: a hang would show here.
            "SET statement_timeout = '60s';", IDENTITY, "\\o /dev/null"]
    lines = head + [s.sql for s in statements] + ["\\o", IDENTITY]
    assert all("\n" not in s.sql for s in statements)
    return "\n".join(lines) + "\n", len(head) + 1


def session_errors(stderr, first, count):
    """Each statement's error, "SEVERITY: message", or None; and the
    lines psql printed that belong to no statement's error."""
    errors, other = [None] * count, []
    for line in stderr.splitlines():
        m = PSQL_LINE.match(line)
        n = int(m.group(1)) - first if m else -1
        if m and m.group(2) and 0 <= n < count:
            errors[n] = "%s: %s" % (m.group(2), m.group(3))
        else:
            other.append(line)
    return errors, other


def read_from(path, offset):
    with open(path, errors="replace") as f:
        f.seek(offset)
        return f.read()


def crash_statement(stderr, first, statements):
    """The statement psql lost its connection in, as far as it says."""
    for line in stderr.splitlines():
        m = PSQL_LINE.match(line)
        if m and any(c in line for c in CRASH_IN_PSQL):
            n = int(m.group(1)) - first
            return statements[n].sql[:300] if 0 <= n < len(statements) \
                else line
    return "?"


def run_session(pg, statements, tally):
    script, first = session_script(statements)
    log_at = os.path.getsize(pg.log)
    rows, err, _ = pg.sql(script, check=False)
    log = read_from(pg.log, log_at)
    backends = [tuple(r[1:]) for r in rows if r and r[0] == "backend"]
    errors, other = session_errors(err, first, len(statements))
    crashed = [m for m in CRASH_IN_PSQL if m in err] + \
        [m for m in CRASH_IN_LOG if m in log]
    if len(backends) != 2 or backends[0] != backends[1]:
        crashed.append("the backend or the postmaster changed: %s" %
                       backends)
    if crashed:
        check(False, "CRASH (%s) at: %s\n%s" % (
            "; ".join(crashed), crash_statement(err, first, statements),
            log[-2000:]))
        return
    check(not other, "psql printed: %s" % other[:5])
    for s, e in zip(statements, errors):
        tally.add(s, e)
        if e is not None:
            check(e.startswith("ERROR: ") and len(e) > len("ERROR: ") + 5,
                  "%s (%s): not an ERROR with a message: %s" %
                  (s.entry, s.kind, e))
            check("\ufffd" not in e, "%s (%s): the message is not valid "
                  "UTF-8: %s" % (s.entry, s.kind, e))
            check("statement timeout" not in e,
                  "%s (%s) ran for a minute: %s" % (s.entry, s.kind,
                                                    s.sql[:200]))
        if s.expect is not None:
            check(e is not None and s.expect in e,
                  "%s (%s): wanted an error%s, got %s: %s" % (
                      s.entry, s.kind,
                      (" with \"%s\"" % s.expect) if s.expect else "",
                      e or "success", s.sql[:160]))


def run(pg, statements, tally):
    for i in range(0, len(statements), SESSION_STATEMENTS):
        run_session(pg, statements[i:i + SESSION_STATEMENTS], tally)


# ---------------------------------------------------------------------
# Inputs as tables and files
# ---------------------------------------------------------------------
def load_table(pg, work, table, values):
    """Creates table (id int, b bytea) holding values, by a text COPY."""
    path = os.path.join(work, table + ".copy")
    with open(path, "w") as f:
        for i, v in enumerate(values):
            f.write("%d\t\\\\x%s\n" % (i, v.hex()))
    pg.sql("DROP TABLE IF EXISTS %s;\n"
           "CREATE TABLE %s (id int PRIMARY KEY, b bytea NOT NULL);\n"
           "\\copy %s from '%s'\n" % (table, table, table, path))


def pgcopy_file(path, value):
    """A binary COPY file (PostgreSQL's PGCOPY format) of one row of one
    column holding value."""
    with open(path, "wb") as f:
        f.write(b"PGCOPY\n\xff\r\n\x00" + struct.pack(">ii", 0, 0) +
                struct.pack(">hi", 1, len(value)) + value +
                struct.pack(">h", -1))


def copy_statements(work, table, entry, inputs):
    """One binary COPY of one row per input (a bad row aborts its COPY):
    the type's receive function on each value."""
    folder = os.path.join(work, "copy-" + table)
    shutil.rmtree(folder, ignore_errors=True)
    os.makedirs(folder)
    out = []
    for i, (kind, value, expect) in enumerate(inputs):
        path = os.path.join(folder, "%05d.bin" % i)
        pgcopy_file(path, value)
        out.append(Statement(entry, kind, "\\copy %s from '%s' with "
                             "(format binary)" % (table, path), expect))
    return out


# ---------------------------------------------------------------------
# Mutations, seeded so that runs repeat
# ---------------------------------------------------------------------
HOSTILE_NUMBERS = [b"nan", b"inf", b"-inf", b"1e308", b"1e309", b"-1",
                   b"4294967295", b"4294967296", b"99999999999999999999",
                   b"0x10", b"1e-320", b"-0", b"", b"1.#IND"]


def mutate(rng, data, others, text=False):
    """(kind, bytes): data with random byte flips, a cut, an insertion, a
    deletion, a splice with one of others or a duplicated stretch; for a
    text file also a digit changed or a number replaced by a hostile
    one."""
    kinds = ["flip", "truncate", "insert", "delete", "splice", "duplicate"]
    kind = rng.choice(kinds + (["digit", "number"] if text else []))
    b = bytearray(data)
    at = rng.randrange(len(b))
    if kind == "flip":
        for _ in range(rng.randint(1, 8)):
            b[rng.randrange(len(b))] ^= rng.randint(1, 255)
    elif kind == "truncate":
        del b[at:]
    elif kind == "insert":
        b[at:at] = rng.randbytes(rng.randint(1, 16))
    elif kind == "delete":
        del b[at:at + rng.randint(1, 64)]
    elif kind == "splice":
        other = rng.choice(others)
        b = b[:at] + other[rng.randrange(len(other)):]
    elif kind == "duplicate":
        b[at:at] = b[rng.randrange(len(b)):][:rng.randint(1, 256)]
    else:
        numbers = [m for m in re.finditer(rb"[-+0-9.eE]+", bytes(b))]
        m = rng.choice(numbers)
        if kind == "digit":
            digits = [i for i in range(m.start(), m.end())
                      if b[i:i + 1].isdigit()] or [m.start()]
            b[rng.choice(digits)] = ord(str(rng.randrange(10)))
        else:
            b[m.start():m.end()] = rng.choice(HOSTILE_NUMBERS)
    return kind, bytes(b)


# ---------------------------------------------------------------------
# Signature blobs (docs/formats.md): the options block, the scales, the
# feature count, the features, (format 4) the layout, (format 5 with
# spin images) the unit box's scale and the points' images, (format 6
# with D2) the shape distribution, then a CRC-32 of every byte before it.
# ---------------------------------------------------------------------
SPIN_BYTES = 100
SHAPE_BINS = 32


header_size = pgutil.header_size
blob_format = pgutil.blob_format


def count_offset(blob):
    scales = struct.unpack_from("<I", blob, 48)[0]
    return header_size(blob_format(blob)) + 8 * scales


def reseal(blob):
    """blob with its CRC-32 made right again, as an encoder would write
    it."""
    return blob[:-4] + struct.pack("<I", zlib.crc32(blob[:-4]))


def with_field(blob, offset, fmt, value):
    b = bytearray(blob)
    struct.pack_into(fmt, b, offset, value)
    return reseal(bytes(b))


def d2_blob(heat):
    """The format-6 blob of a format-4 one's signature made with the
    shape distribution D2: both descriptors' fields (heat, d2) after the
    matching, a distribution after the layout. Made here rather than by
    the tool so that the blobs' part does not depend on how the
    distribution is computed."""
    shape = bytes(range(200, 200 - SHAPE_BINS, -1))
    six = heat[:4] + struct.pack("<H", 6) + heat[6:72] + \
        struct.pack("<II", 0, 1) + heat[72:-4] + shape + heat[-4:]
    return reseal(six)


def hostile_blobs(verified, nearest):
    """test_hostile.c's damaged blobs and more, resealed so that they pass
    the checksum and reach the checks behind it: (kind, blob, what the
    error must say). verified: a format-4 blob (with its layout), a
    format-5 one (with its spin images too) or a format-6 one (with its
    shape distribution); nearest: a format-2 one."""
    v, n = verified, nearest
    fmt = blob_format(v)
    features = count_offset(v) + 4
    scales = struct.unpack_from("<I", v, 48)[0]
    count = struct.unpack_from("<I", v, count_offset(v))[0]
    samples_at = features + count * (36 + 8 * scales)
    points = count + struct.unpack_from("<I", v, samples_at)[0]
    spin = fmt >= 5 and struct.unpack_from("<I", v, 72)[0] == 1
    shape = fmt >= 6 and struct.unpack_from("<I", v, 76)[0] == 1
    out = [
        ("empty", b"", "shorter than any format"),
        ("seven bytes", v[:7], "shorter than any format"),
        ("header only", v[:header_size(fmt)], "bytes"),
        ("bad magic", b"PHKZ" + v[4:], "magic"),
        ("newer format", with_field(v, 4, "<H", 7), "newer"),
        ("format 0", with_field(v, 4, "<H", 0), "format 0"),
        ("flags", with_field(v, 6, "<H", 1), "flags"),
        ("count lies", with_field(v, count_offset(v), "<I", 0xFFFFFFFF),
         "need"),
        ("count lies", with_field(n, count_offset(n), "<I", 0xFFFFFFFF),
         "need"),
        # One more feature: the samples' count is read from the wrong place.
        ("count lies", with_field(v, count_offset(v), "<I", count + 1),
         "samples"),
        ("no features", with_field(n, count_offset(n), "<I", 0), "need"),
        ("samples lie", with_field(v, samples_at, "<I", 21), "samples"),
        ("samples lie", with_field(v, samples_at, "<I", 0xFFFFFFFF),
         "samples"),
        ("scales lie", with_field(v, 48, "<I", 0), "scales"),
        ("scales lie", with_field(v, 48, "<I", 0xFFFFFFFF), "scales"),
        ("bad options", with_field(v, 8, "<d", -1.0), "tau"),
        ("bad options", with_field(v, 8, "<d", float("nan")), "tau"),
        ("bad options", with_field(v, 16, "<d", float("inf")),
         "bad options"),
        ("bad options", with_field(v, 24, "<I", 0), "bad options"),
        ("bad options", with_field(v, 28, "<I", 0), "bad options"),
        ("bad options", with_field(v, 32, "<d", -3.0), "bad options"),
        ("bad options", with_field(v, 40, "<I", 7), "bad options"),
        ("bad options", with_field(v, 44, "<I", 9), "bad options"),
        ("bad options", with_field(v, 52, "<d", -1.0), "bad options"),
        ("bad options", with_field(v, 60, "<I", 9), "bad options"),
        ("bad options", with_field(v, 64, "<I", 5), "bad options"),
        # A matching without a layout: the size no longer fits.
        ("bad options", with_field(v, 68, "<I", 5), "need"),
        ("bad options", with_field(n, 60, "<I", 0xFFFFFFFF), "bad options"),
        ("bad options", with_field(v, header_size(fmt), "<d", -1.0),
         "bad options"),
    ]
    if spin:
        # Another local descriptor: no images, the size no longer fits.
        out += [("bad options", with_field(v, 72, "<I", 7), "need"),
                ("bad options", with_field(v, 72, "<I", 0), "need"),
                ("images cut", reseal(v[:-5] + v[-4:]), "need")]
    if shape:
        # Another global descriptor: no distribution, the size no longer
        # fits.
        out += [("bad options", with_field(v, 76, "<I", 7), "need"),
                ("bad options", with_field(v, 76, "<I", 0), "need"),
                ("shape cut", reseal(v[:-5] + v[-4:]), "need")]
    # Numbers no encoder writes, behind a right checksum.
    for what, offset, value in [("position", 4, float("inf")),
                                ("persistence", 28, -1.0),
                                ("persistence", 28, float("nan")),
                                ("vector", 36, float("nan")),
                                ("vector", 36 + 8 * (scales - 1),
                                 float("-inf"))]:
        out.append(("impossible " + what,
                    with_field(v, features + offset, "<d", value),
                    "impossible number"))
    # The layout's last boundary distance and last geodesic one.
    geodesic_end = len(v) - 4 - (8 + points * SPIN_BYTES if spin else 0) - \
        (SHAPE_BINS if shape else 0)
    boundary_end = geodesic_end - 4 * (points * (points - 1) // 2)
    for what, offset in (("boundary", boundary_end - 4),
                         ("geodesic", geodesic_end - 4)):
        out.append(("impossible " + what, with_field(v, offset, "<f", -1.0),
                    "impossible number"))
    return out


def flipped_bytes(rng, valid, n):
    """n blobs with one byte flipped: every one an error, mostly the
    checksum's."""
    out = []
    for _ in range(n):
        b = bytearray(rng.choice(valid))
        b[rng.randrange(len(b))] ^= rng.randint(1, 255)
        out.append(("one byte flipped", bytes(b), ""))
    return out


def mutated_blobs(rng, valid, n):
    """n seeded mutations of valid blobs, half of them resealed: those
    without a right checksum must all fail (but a splice may give back a
    valid blob); the resealed ones reach the decoder's other checks and
    may pass."""
    out = []
    for _ in range(n):
        kind, b = mutate(rng, rng.choice(valid), valid)
        if len(b) >= 8 and rng.random() < 0.5:
            out.append((kind + ", resealed", reseal(b), None))
        else:
            out.append((kind, b, None if b in valid else ""))
    return out


def text_inputs(good_hex, type_name):
    """Text that is no hex blob, or is one in another spelling: (kind,
    literal text, what the error must say, or None where it is good)."""
    mid = len(good_hex) // 4 * 2  # even: the first digit of a byte
    return [
        ("not hex", "zz", "hex digit"),
        ("not hex", good_hex[:mid] + "g" + good_hex[mid + 1:], "hex digit"),
        ("not hex", good_hex[:mid] + " " + good_hex[mid + 1:], "hex digit"),
        # The whole character, not its first byte (invalid UTF-8).
        ("not hex", good_hex[:mid] + "é" + good_hex[mid + 2:],
         "\"é\" is not a hex digit"),
        ("not hex", good_hex[:mid + 1] + "é" + good_hex[mid + 3:],
         "\"é\" is not a hex digit"),
        ("not hex", good_hex[:mid] + "€" + good_hex[mid + 3:],
         "\"€\" is not a hex digit"),
        ("not hex", " " + good_hex[1:], "hex digit"),
        ("not hex", "\\x\\x" + good_hex, "hex digit"),
        ("odd length", "abc", "odd number"),
        ("odd length", good_hex[:-1], "odd number"),
        ("odd length", "\\x" + good_hex + "0", "odd number"),
        ("empty", "", type_name),
        ("empty", "\\x", type_name),
        ("a megabyte of zeros", "00" * (1 << 19), type_name),
        ("\\x prefix", "\\x" + good_hex, None),
        ("upper case", "\\X" + good_hex.upper(), None),
    ]


# ---------------------------------------------------------------------
# Small meshes in every format the loader reads
# ---------------------------------------------------------------------
def read_off(path):
    with open(path) as f:
        lines = f.read().split("\n")
    nv, nf = map(int, lines[1].split()[:2])
    verts = [tuple(map(float, lines[2 + i].split())) for i in range(nv)]
    faces = [tuple(map(int, lines[2 + nv + i].split()[1:]))
             for i in range(nf)]
    return verts, faces


def ply_header(kind, verts, faces):
    return ("ply\nformat %s 1.0\nelement vertex %d\nproperty float x\n"
            "property float y\nproperty float z\nelement face %d\n"
            "property list uchar int vertex_indices\nend_header\n" %
            (kind, len(verts), len(faces))).encode()


def normal(a, b, c):
    u = [b[i] - a[i] for i in range(3)]
    v = [c[i] - a[i] for i in range(3)]
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0])


def mesh_files(verts, faces):
    """{name: (format name, bytes)}: the mesh as OFF, OBJ, PLY (ASCII and
    both binary byte orders), STL (ASCII and binary), and each gzipped."""
    off = "OFF\n%d %d 0\n" % (len(verts), len(faces)) + \
        "".join("%.9g %.9g %.9g\n" % v for v in verts) + \
        "".join("3 %d %d %d\n" % f for f in faces)
    obj = "".join("v %.9g %.9g %.9g\n" % v for v in verts) + \
        "".join("f %d %d %d\n" % (a + 1, b + 1, c + 1) for a, b, c in faces)
    ply_ascii = ply_header("ascii", verts, faces) + (
        "".join("%.9g %.9g %.9g\n" % v for v in verts) +
        "".join("3 %d %d %d\n" % f for f in faces)).encode()
    plys = {}
    for order, sign in (("little", "<"), ("big", ">")):
        plys["ply_" + order] = ply_header(
            "binary_%s_endian" % order, verts, faces) + \
            b"".join(struct.pack(sign + "3f", *v) for v in verts) + \
            b"".join(struct.pack(sign + "B3i", 3, *f) for f in faces)
    stl_ascii = "solid s\n" + "".join(
        "facet normal %.9g %.9g %.9g\nouter loop\n" % normal(*corners) +
        "".join("vertex %.9g %.9g %.9g\n" % c for c in corners) +
        "endloop\nendfacet\n"
        for corners in ([verts[i] for i in f] for f in faces)) + \
        "endsolid s\n"
    stl_binary = b"binary".ljust(80, b"\0") + struct.pack("<I", len(faces)) \
        + b"".join(struct.pack("<12fH", *normal(*c), *c[0], *c[1], *c[2], 0)
                   for c in ([verts[i] for i in f] for f in faces))
    files = {"off": ("off", off.encode()), "obj": ("obj", obj.encode()),
             "ply_ascii": ("ply", ply_ascii),
             "ply_little": ("ply", plys["ply_little"]),
             "ply_big": ("ply", plys["ply_big"]),
             "stl_ascii": ("stl", stl_ascii.encode()),
             "stl_binary": ("stl", stl_binary)}
    for name, (fmt, data) in list(files.items()):
        files[name + ".gz"] = (fmt, gzip.compress(data, mtime=0))
    return files


def gzip_members(*parts):
    return b"".join(gzip.compress(p, compresslevel=9, mtime=0)
                    for p in parts)


def gzip_zeros(size):
    """gzip of size zero bytes, compressed a chunk at a time."""
    z = zlib.compressobj(1, zlib.DEFLATED, 31)
    chunk = bytes(1 << 20)
    out = [z.compress(chunk) for _ in range(size // len(chunk))]
    return b"".join(out) + z.compress(bytes(size % len(chunk))) + z.flush()


def binary_stl(corners):
    return b"binary".ljust(80, b"\0") + struct.pack("<I", len(corners)) + \
        b"".join(struct.pack("<12fH", 0, 0, 0, *c, 0) for c in corners)


def binary_ply(big, double, vertices, faces, index="uint"):
    sign = ">" if big else "<"
    kind = "double" if double else "float"
    head = ("ply\nformat binary_%s_endian 1.0\nelement vertex %d\n"
            "property %s x\nproperty %s y\nproperty %s z\n"
            "element face %d\nproperty list uchar %s vertex_indices\n"
            "end_header\n" % ("big" if big else "little", len(vertices),
                              kind, kind, kind, len(faces), index)).encode()
    code = "I" if "uint" in index else "i"
    return head + b"".join(struct.pack(sign + ("3d" if double else "3f"), *v)
                           for v in vertices) + \
        b"".join(struct.pack(sign + "B3" + code, 3, *f) for f in faces)


TETRA_OFF = (b"OFF\n4 4 6\n0 0 0\n1.5 0 0\n0 2.25 0\n0 0 3\n"
             b"3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n")
PLY_ASCII_HEAD = (b"ply\nformat ascii 1.0\nelement vertex 3\n"
                  b"property float x\nproperty float y\nproperty float z\n"
                  b"element face 1\nproperty list uchar uint vertex_indices\n"
                  b"end_header\n")
NAN, INF = float("nan"), float("inf")


def hostile_meshes():
    """test_hostile.c's meshes: (kind, bytes), each an error whatever the
    format it is read as."""
    out = [("non-finite", t) for t in [
        b"v 0 0 0\nv 1 0 0\nv 0 1 inf\nf 1 2 3\n",
        b"v 0 0 0\nv 1e309 0 0\nv 0 1 0\nf 1 2 3\n",
        b"OFF\n3 1 0\n0 0 0\n1 0 0\nnan(0x7ff) 1 0\n3 0 1 2\n",
        b"OFF\n3 1 0\n0 0 0\n-1.#IND 0 0\n0 1 0\n3 0 1 2\n",
        b"solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
        b"vertex 1 -Infinity 0\nvertex 0 1 0\nendloop\nendfacet\n"
        b"endsolid s\n",
        PLY_ASCII_HEAD + b"0 0 0\n1 0 0\n0 1e400 0\n3 0 1 2\n",
        binary_ply(False, True, [(0, 0, 0), (1, 0, 0), (0, INF, 0)],
                   [(0, 1, 2)]),
        binary_ply(True, False, [(0, 0, 0), (1, 0, 0), (0, NAN, 0)],
                   [(0, 1, 2)]),
        binary_stl([(0, 0, 0, 1, 0, 0, 0, NAN, 0)])]]
    out += [("too large", t) for t in [
        b"v 0 0 0\nv 1e200 0 0\nv 0 1e200 0\nf 1 2 3\n",
        b"v -1e308 0 0\nv 1e308 0 0\nv 0 1 0\nf 1 2 3\n"]]
    out += [("zero area", t) for t in [
        b"v 0 0 0\nv 1 1 1\nv 2 2 2\nv 3 3 3\nv -4 -4 -4\nf 1 2 3 4 5\n",
        b"OFF\n4 2 0\n0 0 0\n1 0 0\n0.5 1e-13 0\n0.5 -1e-13 0\n"
        b"3 0 1 2\n3 0 3 1\n",
        b"solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
        b"vertex 0 0 0\nvertex 1 1 1\nendloop\nendfacet\n"
        b"facet normal 0 0 1\nouter loop\nvertex 2 0 0\nvertex -0 0 0\n"
        b"vertex 0 0 -0\nendloop\nendfacet\nendsolid s\n",
        binary_ply(False, False, [(7.5, 7.5, 7.5)] * 4,
                   [(0, 1, 2), (1, 2, 3)]),
        binary_stl([(1, 2, 3, 1, 2, 3, 1, 2, 3)])]]
    # A billion elements declared in about 100 bytes.
    billion = [b"OFF\n1000000000 1 0\n",
               b"OFF\n3 1000000000 0\n0 0 0\n1 0 0\n0 1 0\n",
               b"ply\nformat ascii 1.0\nelement vertex 1000000000\n"
               b"property float x\nproperty float y\nproperty float z\n"
               b"end_header\n",
               b"ply\nformat binary_little_endian 1.0\n"
               b"element vertex 1000000000\nproperty uchar x\n"
               b"property uchar y\nproperty uchar z\nend_header\n",
               b"ply\nformat binary_little_endian 1.0\n"
               b"element face 1000000000\n"
               b"property list uchar int vertex_indices\nend_header\n"]
    out += [("a billion declared", t.ljust(100 if t.startswith(b"OFF")
                                           else len(t) + 20, b"\n"))
            for t in billion]
    out.append(("a billion declared", (b"binary STL".ljust(80, b"\0") +
                                       struct.pack("<I", 1000000000))
                .ljust(100, b"\0")))
    out += [("counts at the limit", t) for t in [
        b"OFF\n4294967294 1\n",
        b"ply\nformat ascii 1.0\nelement face 4294967295\nend_header\n"]]
    out += [("index at UINT32_MAX", t) for t in [
        b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 4294967295\n",
        b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 4294967296 1\n",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4294967295\n",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 4294967296 1 2\n",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4294967295\n",
        PLY_ASCII_HEAD + b"0 0 0\n1 0 0\n0 1 0\n3 0 4294967295 1\n"]]
    for big in (False, True):
        out.append(("index at UINT32_MAX", binary_ply(
            big, False, [(0, 0, 0), (0, 0, 1), (0, 1, 0)],
            [(0, 0xFFFFFFFF, 1)], index="uint32")))
    lying = bytearray(gzip_members(TETRA_OFF))
    lying[-4:] = b"\xff\xff\xff\xff"
    out.append(("gzip size lies", bytes(lying)))
    return out


def extreme_meshes():
    """test_hostile.c's meshes at the ends of a double's range whose area
    is still a double: valid (their signatures are the library's
    business)."""
    out = [("extreme coordinates",
            b"v 0 0 0\nv 3e120 0 0\nv 0 4e120 0\nf 1 2 3\n")]
    for scale in (1e-150, 1e-100, 1e100, 1e150):
        corners = [(0, 0, 0), (scale, 0, 0), (scale, scale, 0),
                   (0, scale, scale)]
        out.append(("extreme coordinates", (
            "OFF\n4 2 0\n" + "".join("%r %r %r\n" % c for c in corners) +
            "3 0 1 2\n3 0 2 3\n").encode()))
    return out


def gzip_prefixes(rng, sphere_off):
    """Proper prefixes of gzip data, every one an error: all of a
    tetrahedron in one member and in two, a sample of a sphere's."""
    half = len(TETRA_OFF) // 2
    one = gzip_members(TETRA_OFF)
    two = gzip_members(TETRA_OFF[:half], TETRA_OFF[half:])
    big = gzip_members(sphere_off)
    cuts = [(one, n) for n in range(len(one))] + \
        [(two, n) for n in range(len(two))] + \
        [(big, n) for n in sorted(rng.sample(range(len(big)), 64))]
    return [("truncated gzip", data[:n]) for data, n in cuts]


# ---------------------------------------------------------------------
# The cluster and the valid inputs every part starts from
# ---------------------------------------------------------------------
RAW = """
CREATE SCHEMA raw;
CREATE FUNCTION raw.feature_count(bytea) RETURNS integer
  AS '$libdir/phks', 'phks_pg_feature_count' LANGUAGE C STRICT;
CREATE FUNCTION raw.vectors(bytea) RETURNS float8[]
  AS '$libdir/phks', 'phks_pg_vectors' LANGUAGE C STRICT;
CREATE FUNCTION raw.options(bytea) RETURNS json
  AS '$libdir/phks', 'phks_pg_options' LANGUAGE C STRICT;
CREATE FUNCTION raw.key(bytea) RETURNS phks_key
  AS '$libdir/phks', 'phks_pg_key_of' LANGUAGE C STRICT;
CREATE FUNCTION raw.score(bytea, bytea) RETURNS float8
  AS '$libdir/phks', 'phks_pg_score' LANGUAGE C STRICT;
CREATE FUNCTION raw.score_nearest(bytea, bytea) RETURNS float8
  AS '$libdir/phks', 'phks_pg_score_nearest' LANGUAGE C STRICT;
CREATE FUNCTION raw.distance(bytea, bytea) RETURNS float8
  AS '$libdir/phks', 'phks_pg_distance' LANGUAGE C STRICT;
CREATE FUNCTION raw.nearest_distance(bytea, bytea) RETURNS float8
  AS '$libdir/phks', 'phks_pg_nearest_distance' LANGUAGE C STRICT;
CREATE FUNCTION raw.key_distance(phks_key, bytea) RETURNS float8
  AS '$libdir/phks', 'phks_pg_key_distance' LANGUAGE C STRICT;
CREATE FUNCTION raw.key_distance(bytea, phks_signature) RETURNS float8
  AS '$libdir/phks', 'phks_pg_key_distance' LANGUAGE C STRICT;
"""

# Signatures made with other options than the defaults: the global options
# of the tool (the nearest one at the vertices, so that it is format 2's:
# the default quadrature makes format 3).
OPTION_VARIANTS = [["--hks-scaling", "none"], ["--hks-scaling", "mean"],
                   ["--matching", "nearest", "--quadrature", "vertices"],
                   ["--quadrature", "vertices"],
                   ["--operator", "literal"], ["--boundary-margin", "0"],
                   ["--local-descriptor", "heat"]]


def start_cluster(work):
    pgutil.install_extension(build_root)
    # The statements carry kilobytes of hex: the log keeps their errors
    # but not their text.
    pg = pgutil.Cluster(pgutil.pg_bindir(), "inputs",
                        ["log_min_error_statement=panic"])
    pg.sql("CREATE EXTENSION phks;" + RAW)
    return pg


def small_meshes(work):
    """Bumpy spheres of 84 and 144 vertices (OFF paths): a signature of
    each takes milliseconds."""
    folder = os.path.join(work, "small")
    os.makedirs(folder, exist_ok=True)
    paths = []
    for seed, n in ((1, 6), (2, 8), (3, 8)):
        p = os.path.join(folder, "sphere%d-%d.off" % (seed, n))
        pgutil.bumpy_sphere_off(p, seed, n)
        paths.append(p)
    return paths


def valid_signatures(work):
    """(file name, blob) of the tool's signatures: of the small spheres
    and of the two smallest shared meshes (generated ones when those are
    absent) with the default options, and of the second sphere with each
    option variant."""
    small = small_meshes(work)
    meshes, source = pgutil.test_meshes(shared, os.path.join(work, "meshes"),
                                        2)
    paths = pgutil.signatures(phks, small + meshes,
                              os.path.join(work, "sigs-" + source))
    for args in OPTION_VARIANTS:
        paths += pgutil.signatures(phks, small[1:2],
                                   os.path.join(work, "sigs"), args)
    return [(os.path.basename(p), open(p, "rb").read()) for p in paths]


def corpus_inputs(*targets):
    """(kind, bytes) of every file of the fuzz corpora of targets."""
    out = []
    for t in targets:
        for f in sorted(os.listdir(os.path.join(corpus, t))):
            with open(os.path.join(corpus, t, f), "rb") as data:
                out.append(("corpus " + t, data.read()))
    return out


# ---------------------------------------------------------------------
# blobs
# ---------------------------------------------------------------------
# Each bad blob (id N of the table inputs) through every entry point that
# takes a signature: typed ones refuse it at input, the raw ones decode
# it themselves.
BLOB_ENTRIES = [
    ("phks_signature(bytea)", "phks_signature(b)"),
    ("phks_feature_count", "raw.feature_count(b)"),
    ("phks_vectors", "raw.vectors(b)"),
    ("phks_options", "raw.options(b)"),
    ("phks_key(sig)", "raw.key(b)"),
    ("phks_score (query bad)", "raw.score(b, g.sig::bytea)"),
    ("phks_score (entry bad)", "raw.score(g.sig::bytea, b)"),
    ("phks_score_nearest (a bad)", "raw.score_nearest(b, g.sig::bytea)"),
    ("phks_score_nearest (b bad)", "raw.score_nearest(g.sig::bytea, b)"),
    ("<~> (entry bad)", "raw.distance(b, g.sig::bytea)"),
    ("<~> (query bad)", "raw.distance(g.sig::bytea, b)"),
    ("<#> (entry bad)", "raw.nearest_distance(b, g.sig::bytea)"),
    ("<#> (query bad)", "raw.nearest_distance(g.sig::bytea, b)"),
    ("key <#> sig (sig bad)", "raw.key_distance(g.key, b)"),
]


def blob_statements(work, inputs):
    """Every entry point on every input: (kind, blob, expect)."""
    out = [Statement("phks_signature text input", kind,
                     "SELECT %s::phks_signature;" % sql_text(b.hex()), expect)
           for kind, b, expect in inputs]
    out += copy_statements(work, "recv_sigs",
                           "phks_signature binary input (COPY)", inputs)
    for entry, call in BLOB_ENTRIES:
        out += [Statement(entry, kind, "SELECT %s FROM inputs, good g "
                          "WHERE id = %d;" % (call, i), expect)
                for i, (kind, _, expect) in enumerate(inputs)]
    return out


def typed_score_statements(inputs):
    """The scores as a user writes them, one operand a bad literal."""
    out = []
    for kind, b, expect in inputs:
        lit = sql_text(b.hex())
        for entry, sql in [
                ("phks_score (typed)", "phks_score(%s, g.sig)"),
                ("phks_score_nearest (typed)",
                 "phks_score_nearest(g.sig, %s)"),
                ("<~> (typed)", "g.sig <~> %s"),
                ("<#> (typed)", "%s::phks_signature <#> g.sig"),
                ("key <#> sig (typed)", "g.key <#> %s")]:
            out.append(Statement(entry, kind, "SELECT %s FROM good g;" %
                                 (sql % lit), expect))
    return out


def mismatch_statements(variants):
    """Every score between signatures of one mesh made with different
    options: an error naming the option."""
    out = []
    for a in range(len(variants)):
        for b in range(len(variants)):
            if a == b:
                continue
            for entry, expr in [("phks_score", "phks_score(a.sig, b.sig)"),
                                ("phks_score_nearest",
                                 "phks_score_nearest(a.sig, b.sig)"),
                                ("<~>", "a.sig <~> b.sig"),
                                ("<#>", "a.sig <#> b.sig"),
                                ("key <#> sig", "a.key <#> b.sig")]:
                out.append(Statement(
                    entry + " (options differ)", "options differ",
                    "SELECT %s FROM variants a, variants b WHERE a.id = %d "
                    "AND b.id = %d;" % (expr, a, b), "different options"))
    return out


def part_blobs(pg, work, rng):
    valid = valid_signatures(work)
    blobs = [b for _, b in valid]
    verified = [b for b in blobs if blob_format(b) in (4, 5)]
    nearest = [b for b in blobs if blob_format(b) == 2]
    heat = [b for b in verified if blob_format(b) == 4]
    spin = [b for b in verified if blob_format(b) == 5]
    d2 = d2_blob(heat[-1])
    print("%d valid blobs: %s" % (len(valid), ", ".join(n for n, _ in valid)))
    corpus_blobs = corpus_inputs("fuzz_signature", "fuzz_db")
    fixed = [(kind, b, None) for kind, b in corpus_blobs] + \
        [("format 6 with d2", d2, None)] + \
        hostile_blobs(heat[-1], nearest[0]) + \
        hostile_blobs(spin[0], nearest[0]) + hostile_blobs(d2, nearest[0])
    # The corpus's blobs of older formats are mutated too.
    bases = blobs + [d2] + \
        [b for kind, b in corpus_blobs if "signature" in kind]
    inputs = fixed + flipped_bytes(rng, blobs, 300) + \
        mutated_blobs(rng, bases, 1700)
    load_table(pg, work, "inputs", [b for _, b, _ in inputs])
    good = verified[0]
    variants = [b for n, b in valid if "sphere2-8" in n]
    pg.sql("CREATE TABLE good AS SELECT s AS sig, phks_key(s) AS key FROM "
           "(SELECT %s::phks_signature AS s) AS q;\n"
           "CREATE TABLE recv_sigs (s phks_signature);\n"
           "CREATE TABLE variants (id int, sig phks_signature, key phks_key);"
           "\nINSERT INTO variants SELECT i - 1, s, phks_key(s) FROM "
           "unnest(ARRAY[%s]::phks_signature[]) WITH ORDINALITY AS u(s, i);"
           % (sql_text(good.hex()),
              ", ".join(sql_text(v.hex()) for v in variants)))
    print("%d inputs, %d option variants" % (len(inputs), len(variants)))

    tally = Tally()
    run(pg, [Statement("phks_signature text input", kind,
                       "SELECT %s::phks_signature;" % sql_text(t), expect)
             for kind, t, expect in text_inputs(good.hex(),
                                                "phks_signature")], tally)
    run(pg, typed_score_statements(fixed), tally)
    run(pg, blob_statements(work, inputs), tally)
    run(pg, mismatch_statements(variants), tally)
    tally.print()
    flips = tally.messages["one byte flipped"]
    crc = sum(n for m, n in flips.items() if "checksum" in m)
    print("one byte flipped: %d of %d errors name the checksum" %
          (crc, sum(flips.values())))
    check(crc >= 0.9 * sum(flips.values()),
          "one flipped byte is mostly a checksum error: %s" %
          flips.most_common(5))


# ---------------------------------------------------------------------
# meshes
# ---------------------------------------------------------------------
FORMATS = ["auto", "off", "obj", "ply", "stl"]
BAD_FORMATS = ["", "xyz", "gz", "off.gz", "o f f", "é", "x" * 1000]


def mesh_statement(i, fmt, kind, expect, options=None):
    """The call on input i read as fmt, with options (JSON) when given."""
    args = sql_text(fmt) + (", '%s'" % options if options else "")
    return Statement("phks_signature_from_mesh", kind,
                     "SELECT phks_signature_from_mesh(b, %s) FROM inputs "
                     "WHERE id = %d;" % (args, i), expect)


# The mutations' meshes are small and coarse: the default quadrature gives
# each some thousands of points inside its long triangles, a second of
# computing; most are read at the vertices (through the options), every
# eighth with the defaults.
AT_VERTICES = '{"quadrature": "vertices"}'


TEXT_MESHES = ("off", "obj", "ply_ascii", "stl_ascii")


def mesh_mutation(rng, bases):
    """(kind, bytes, format name) of a mutated mesh: a gzipped one has its
    compressed bytes mutated, or half the time its own, gzipped again;
    read as auto or as its own format."""
    name, fmt, data = rng.choice(bases)
    plain = name.replace(".gz", "")
    others = [d for n, _, d in bases if n == plain]
    if name.endswith(".gz") and rng.random() < 0.5:
        kind, m = mutate(rng, gzip.decompress(data), others,
                         text=plain in TEXT_MESHES)
        kind, m = kind + ", gzipped", gzip.compress(m, mtime=0)
    else:
        kind, m = mutate(rng, data, [d for n, _, d in bases if n == name],
                         text=name in TEXT_MESHES)
    return kind, m, rng.choice(["auto", fmt])


def part_meshes(pg, work, rng):
    small = small_meshes(work)
    bases = []
    for p in small:
        verts, faces = read_off(p)
        bases += [(name, fmt, data) for name, (fmt, data) in
                  mesh_files(verts, faces).items()]
    inputs = [(kind, data, None) for kind, data in corpus_inputs(
        "fuzz_gzip", "fuzz_load", "fuzz_obj", "fuzz_off", "fuzz_ply",
        "fuzz_stl")]
    inputs += [(kind, data, None) for kind, data in extreme_meshes()]
    inputs += [(kind, data, "") for kind, data in hostile_meshes()]
    sphere_off = bases[0][2]
    inputs += [(kind, data, "") for kind, data in
               gzip_prefixes(rng, sphere_off)]
    every_format = len(inputs)
    mutations = [mesh_mutation(rng, bases) for _ in range(6000)]
    inputs += [(k, m, None) for k, m, _ in mutations]
    inputs.append(("gzip bomb", gzip_zeros(100 << 20), ""))
    load_table(pg, work, "inputs", [b for _, b, _ in inputs])
    print("%d inputs (%d read as every format), %d base meshes" %
          (len(inputs), every_format, len(bases)))

    statements = []
    for i, (kind, _, expect) in enumerate(inputs[:every_format]):
        statements += [mesh_statement(i, fmt, kind, expect)
                       for fmt in FORMATS + ["OFF"]]
    statements += [mesh_statement(0, fmt, "unknown format", "unknown format")
                   for fmt in BAD_FORMATS]
    for j, (kind, _, fmt) in enumerate(mutations):
        statements.append(mesh_statement(every_format + j, fmt, kind, None,
                                         AT_VERTICES if j % 8 else None))
    bomb = len(inputs) - 1
    statements += [mesh_statement(bomb, fmt, "gzip bomb", "")
                   for fmt in FORMATS]
    tally = Tally()
    run(pg, statements, tally)
    tally.print()


# ---------------------------------------------------------------------
# keys: the hex of the key's bytes (phks_pg_key.c): magic, version, count,
# length, 4 bytes of padding, the options (72 bytes), the vectors.
# ---------------------------------------------------------------------
KEY_COUNT, KEY_LENGTH, KEY_OPTIONS, KEY_VECTORS = 8, 12, 20, 92


def key_field(key, offset, fmt, value):
    b = bytearray(key)
    struct.pack_into(fmt, b, offset, value)
    return bytes(b)


def hostile_keys(key):
    count, length = struct.unpack_from("<II", key, KEY_COUNT)
    return [
        ("empty key", b"", "shorter than its header"),
        ("short key", key[:KEY_VECTORS - 1], "shorter than its header"),
        ("bad magic", b"PHKZ" + key[4:], "not a phks_key"),
        ("newer version", key_field(key, 4, "<I", 2), "version"),
        ("count lies", key_field(key, KEY_COUNT, "<I", 0xFFFFFFFF),
         "does not match"),
        ("count lies", key_field(key, KEY_COUNT, "<I", count + 1),
         "does not match"),
        ("count lies", key_field(key, KEY_COUNT, "<I", 0), "does not match"),
        ("length lies", key_field(key, KEY_LENGTH, "<I", 0),
         "does not match"),
        ("length lies", key_field(key, KEY_LENGTH, "<I", 0xFFFFFFFF),
         "does not match"),
        ("length lies", key_field(key, KEY_LENGTH, "<I", length + 1),
         "does not match"),
        ("scales lie", key_field(key, KEY_OPTIONS + 48, "<I", length + 1),
         "does not match"),
        ("truncated key", key[:-8], "does not match"),
        ("longer key", key + bytes(8), "does not match"),
        ("non-finite vector", key_field(key, KEY_VECTORS, "<d", NAN),
         "not finite"),
        ("non-finite vector", key_field(key, len(key) - 8, "<d", -INF),
         "not finite"),
    ]


def key_statements(work, inputs):
    out = [Statement("phks_key text input", kind, "SELECT %s::phks_key;" %
                     sql_text(k.hex()), expect)
           for kind, k, expect in inputs]
    out += copy_statements(work, "recv_keys", "phks_key binary input (COPY)",
                           inputs)
    # Typed, a bad key is refused at input; an accepted one is scored (or
    # refused for its options).
    out += [Statement("key <#> sig (typed)", kind, "SELECT %s::phks_key <#> "
                      "g.sig FROM good g;" % sql_text(k.hex()), expect)
            for kind, k, expect in inputs]
    # Raw, the score checks the key's header itself (a regression: a
    # count that lied sent it past the key's end); its numbers are left to
    # the input's check.
    out += [Statement("key <#> sig (key bad)", kind,
                      "SELECT raw.key_distance(b, g.sig) FROM inputs, good g "
                      "WHERE id = %d;" % i,
                      None if kind == "non-finite vector" else expect)
            for i, (kind, _, expect) in enumerate(inputs)]
    return out


def part_keys(pg, work, rng):
    valid = valid_signatures(work)
    pg.sql("CREATE TABLE sigs (id int, sig phks_signature);\n"
           "INSERT INTO sigs SELECT i, s FROM unnest(ARRAY[%s]::"
           "phks_signature[]) WITH ORDINALITY AS u(s, i);\n"
           "CREATE TABLE good AS SELECT sig FROM sigs WHERE id = 1;\n"
           "CREATE TABLE recv_keys (k phks_key);" %
           ", ".join(sql_text(b.hex()) for _, b in valid))
    keys = [bytes.fromhex(r[0]) for r in
            pg.sql("SELECT phks_key(sig) FROM sigs ORDER BY id;")]
    inputs = hostile_keys(keys[0])
    for _ in range(4000):
        kind, k = mutate(rng, rng.choice(keys), keys)
        inputs.append((kind, k, None))
    load_table(pg, work, "inputs", [k for _, k, _ in inputs])
    print("%d keys, %d inputs" % (len(keys), len(inputs)))
    tally = Tally()
    texts = text_inputs(keys[0].hex(), "phks_key")
    run(pg, [Statement("phks_key text input", kind, "SELECT %s::phks_key;" %
                       sql_text(t), expect) for kind, t, expect in texts],
        tally)
    run(pg, key_statements(work, inputs), tally)
    tally.print()


# ---------------------------------------------------------------------
# memory: failing calls in one backend, its resident memory read from
# /proc/PID/status (the test runs as root, the server as postgres)
# ---------------------------------------------------------------------
FAIL_CALLS = """
CREATE TABLE failing (id int PRIMARY KEY, kind text NOT NULL,
                      b bytea, other bytea, t text);
-- Runs calls of the rows of failing in turn, each in its own
-- subtransaction; every one must fail.
CREATE FUNCTION fail_calls(calls int) RETURNS int LANGUAGE plpgsql AS $$
DECLARE
  r failing;
  kinds int := (SELECT count(*) FROM failing);
  failed int := 0;
BEGIN
  FOR i IN 0 .. calls - 1 LOOP
    SELECT * INTO r FROM failing WHERE id = i % kinds;
    BEGIN
      CASE r.kind
        WHEN 'cast' THEN PERFORM phks_signature(r.b);
        WHEN 'mesh' THEN PERFORM phks_signature_from_mesh(r.b, r.t);
        WHEN 'phks_score' THEN
          PERFORM phks_score(r.b::phks_signature, r.other::phks_signature);
        WHEN '<#>' THEN
          PERFORM r.b::phks_signature <#> r.other::phks_signature;
        WHEN 'key <#> sig' THEN
          PERFORM phks_key(r.b::phks_signature) <#> r.other::phks_signature;
        WHEN 'key' THEN PERFORM r.t::phks_key;
      END CASE;
    EXCEPTION WHEN others THEN
      failed := failed + 1;
    END;
  END LOOP;
  IF failed <> calls THEN
    RAISE EXCEPTION '% of % calls failed', failed, calls;
  END IF;
  RETURN failed;
END $$;
"""
WARM_UP, CALLS = 1000, 10000


def late_failing_off(path):
    """The mesh at path with its last face's index out of range: the
    reader has read every vertex and face before it fails."""
    with open(path, "rb") as f:
        data = f.read().rstrip(b"\n")
    return data[:data.rindex(b" ")] + b" 999999\n"


def failing_rows(work):
    """(kind, b, other, t) of calls that fail: the cast of damaged blobs
    (one that fails at the checksum, one whose bad numbers fail after the
    decoder allocated), mesh bytes that fail at once and meshes that fail
    late (plain and gzipped) or have no area, scores of signatures made
    with other options, and bad keys."""
    valid = valid_signatures(work)
    default = [b for n, b in valid if n == "sphere2-8.sig"][0]
    other = [b for n, b in valid if "hks-scaling-none" in n][0]
    nan_vector = [b for k, b, _ in hostile_blobs(default, other)
                  if k == "impossible vector"][0]
    late = late_failing_off(small_meshes(work)[1])
    flat = b"OFF\n4 2 0\n0 0 0\n1 0 0\n2 0 0\n3 0 0\n3 0 1 2\n3 1 2 3\n"
    key = "50484b4b01000000" + "00" * 100
    return [("cast", default[:-1] + bytes([default[-1] ^ 1]), None, None),
            ("cast", nan_vector, None, None),
            ("mesh", b"\x00garbage" * 10, None, "auto"),
            ("mesh", late, None, "auto"),
            ("mesh", gzip.compress(late, mtime=0), None, "off"),
            ("mesh", flat, None, "off"),
            ("phks_score", default, other, None),
            ("<#>", other, default, None),
            ("key <#> sig", default, other, None),
            ("key", None, None, key),
            ("key", None, None, "zz")]


def status_fields(path):
    with open(path) as f:
        fields = dict(line.split(":", 1) for line in f if ":" in line)
    return {k: int(fields[k].split()[0]) for k in ("VmRSS", "RssAnon")
            if k in fields}


def part_memory(pg, work, rng):
    rows = failing_rows(work)
    values = ", ".join("(%d, %s, %s, %s, %s)" % (
        i, sql_text(k),
        "'\\x%s'::bytea" % b.hex() if b is not None else "NULL",
        "'\\x%s'::bytea" % o.hex() if o is not None else "NULL",
        sql_text(t) if t is not None else "NULL")
        for i, (k, b, o, t) in enumerate(rows))
    pg.sql(FAIL_CALLS + "INSERT INTO failing VALUES %s;" % values)
    before, after = (os.path.join(work, n) for n in ("rss-before",
                                                      "rss-after"))
    for path in (before, after):
        if os.path.exists(path):
            os.remove(path)
    statements = [
        Statement("memory", "", "SELECT pg_backend_pid() AS pid \\gset"),
        Statement("memory", "", "\\setenv PHKS_BACKEND :pid"),
        Statement("memory", "", "SELECT fail_calls(%d);" % WARM_UP),
        Statement("memory", "", "\\! cat /proc/$PHKS_BACKEND/status > " +
                  before),
        Statement("memory", "", "SELECT fail_calls(%d);" % CALLS),
        Statement("memory", "", "\\! cat /proc/$PHKS_BACKEND/status > " +
                  after)]
    t = time.time()
    tally = Tally()
    run(pg, statements, tally)
    took = time.time() - t
    check(tally.entries["memory"][1] == 0,
          "every call of fail_calls failed: %s" % dict(tally.messages))
    rss0, rss1 = status_fields(before), status_fields(after)
    print("%d kinds of failing call; %d calls then %d in %.1f s" %
          (len(rows), WARM_UP, CALLS, took))
    for k in rss0:
        grown = rss1[k] - rss0[k]
        print("%s: %d KiB after %d calls, %d KiB after %d more: %+d KiB, "
              "%+.1f bytes a call" % (k, rss0[k], WARM_UP, rss1[k], CALLS,
                                      grown, grown * 1024.0 / CALLS))
        # Each kind of call runs 909 times; what the library allocates on
        # these paths (a decoded signature, a mesh's arrays, zlib's state)
        # takes 3 KiB or more, so one block leaked by any one kind of
        # call would grow the backend by 2.7 MiB or more. Measured: 28 KiB
        # once, then nothing over 100,000 more calls.
        check(grown < 1024, "%s grew by %d KiB over %d failing calls" %
              (k, grown, CALLS))


PARTS = {"blobs": part_blobs, "meshes": part_meshes, "keys": part_keys,
         "memory": part_memory}


def main():
    if part not in PARTS:
        raise SystemExit("PART is one of %s" % ", ".join(PARTS))
    t0 = time.time()
    work = os.path.join(build_root, "tests", "postgres-inputs-work", part)
    os.makedirs(work, exist_ok=True)
    pg = start_cluster(work)
    print("cluster on port %d (%.1f s)" % (pg.port, time.time() - t0))
    # Seeded by the part's name: each run feeds the same inputs.
    PARTS[part](pg, work, random.Random("phks-inputs-" + part))
    pg.stop()
    print("%s: %d failures (%.1f s)" % (part, len(failures),
                                        time.time() - t0))
    sys.exit(1 if failures else 0)


main()
