#!/usr/bin/env python3
"""test_postgres.py BUILD_ROOT PHKS_TOOL [SHARED_MESHES]

The PostgreSQL extension (docs/postgres.md) on a throwaway cluster: the
SQL top-k equals `phks db query --json` on the same entries (ids, names
and scores exactly), in plain and in parallel plans: ORDER BY sig <~> q,
id LIMIT k on a table of at most 32 rows, and the two-stage query (a
shortlist by <#>, re-ranked by <~>) on a larger one; bad blobs and signatures made with other options give
errors (naming the option), never a crash; text and binary I/O round trip;
phks_signature_from_mesh equals the tool's signature byte for byte; the
accessors agree with `phks signature --json`.
"""
import json
import os
import struct
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import pgutil  # noqa: E402

build_root, phks = sys.argv[1], sys.argv[2]
shared = sys.argv[3] if len(sys.argv) > 3 else os.environ.get(
    "PHKS_SHARED_MESHES", "")

bindir = pgutil.pg_bindir()
t0 = time.time()
pgutil.install_extension(build_root)
work = os.path.join(build_root, "tests", "postgres-work")
os.makedirs(work, exist_ok=True)

failures = pgutil.failures
check = pgutil.check


# More entries than phks_db_query's shortlist of 32 for the two-stage
# query; the first 30 make the small table (at most 32 rows).
meshes, source = pgutil.test_meshes(shared, os.path.join(work, "meshes"),
                                    110)
sigs = pgutil.signatures(phks, meshes, os.path.join(work, "sigs-" + source))
entries, queries = sigs[:24], sigs[24:30] + sigs[:2]
# One entry twice: a tie that only the id breaks.
entries = entries + [entries[5]]
# Each of the others twice, under two ids: ties the shortlist cuts through.
many = entries + sigs[30:] + sigs[30:]
print("%d signatures in %.1f s" % (len(sigs), time.time() - t0))


db, db_many = os.path.join(work, "t.db"), os.path.join(work, "many.db")
pgutil.tool_db(phks, db, entries)
pgutil.tool_db(phks, db_many, many)

pg = pgutil.Cluster(bindir, "single")
print("cluster on port %d (%.1f s)" % (pg.port, time.time() - t0))
pg.sql("CREATE EXTENSION phks;")
version = pg.sql("SELECT extversion FROM pg_extension WHERE extname='phks';")
print("extension version", version[0][0])

# A default signature (10 KB with its spin images) does not fit a page and
# goes to TOAST whatever the target, leaving the heap a page or two, which
# the planner gives no worker of its own accord: parallel_workers asks for
# two, so that the parallel plans below are chosen.
for table, files in (("shapes", entries), ("many", many)):
    values = ",\n".join("(%d, '%s', '%s')" % (i + 1, e, pgutil.hexfile(e))
                        for i, e in enumerate(files))
    pg.sql("CREATE TABLE %s (id bigint PRIMARY KEY, name text NOT NULL, "
           "sig phks_signature NOT NULL) WITH (toast_tuple_target = 8160, "
           "parallel_workers = 2);\n"
           "INSERT INTO %s VALUES %s;\nANALYZE %s;"
           % (table, table, values, table))
# The large table as docs/postgres.md lays it out: a key beside each
# signature, the signatures out of the rows.
pg.sql("ALTER TABLE many ALTER COLUMN sig SET STORAGE external, ADD COLUMN "
       "key phks_key GENERATED ALWAYS AS (phks_key(sig)) STORED;\n"
       "VACUUM FULL many;\nANALYZE many;")

# Text output is the blob's hex; the stored bytes are the tool's.
rows = pg.sql("SELECT id, sig FROM shapes ORDER BY id;")
check(all(row[1] == pgutil.hexfile(entries[int(row[0]) - 1])
          for row in rows) and len(rows) == len(entries),
      "text output is the hex of the blob")
rows = pg.sql("SELECT count(*) FROM shapes WHERE sig::bytea = "
              "decode('%s', 'hex');" % pgutil.hexfile(entries[3]))
check(rows == [["1"]], "cast to bytea gives the blob")

PARALLEL = ("SET max_parallel_workers_per_gather = 2; "
            "SET parallel_setup_cost = 0; SET parallel_tuple_cost = 0; "
            "SET min_parallel_table_scan_size = 0; "
            "SET parallel_leader_participation = off;\n")


def sql_topk(q, k, prefix="", table="shapes"):
    rows = pg.sql(prefix + "SELECT id, name, sig <~> q FROM %s, "
                  "(SELECT '%s'::phks_signature AS q) AS query "
                  "ORDER BY sig <~> q, id LIMIT %d;"
                  % (table, pgutil.hexfile(q), k))
    return [(int(r[0]), r[1], float(r[2])) for r in rows]


def sql_two_stage(q, k, prefix=""):
    rows = pg.sql(prefix + pgutil.two_stage("many", pgutil.literal(q), k))
    return [(int(r[0]), r[1], float(r[2])) for r in rows]


def tool_topk(q, k, path=db):
    r = subprocess.run([phks, "db", "query", path, q, "-k", str(k), "--json"],
                       capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit("phks db query: " + r.stderr)
    return [(h["id"], h["name"], float(h["score"]))
            for h in json.loads(r.stdout)]


for q in queries + [entries[5]]:
    for k in (1, 5, 10, len(entries)):
        want = tool_topk(q, k)
        got = sql_topk(q, k)
        check(got == want, "top-%d of %s: SQL %s\n  tool %s" % (
            k, os.path.basename(q), got[:4], want[:4]))
    got = sql_topk(q, 10, PARALLEL)
    check(got == tool_topk(q, 10),
          "top-10 of %s in a parallel plan" % os.path.basename(q))
plan = pg.sql(PARALLEL + "EXPLAIN SELECT id FROM shapes ORDER BY sig <~> "
              "'%s', id LIMIT 10;" % pgutil.hexfile(queries[0]))
check(any("Gather" in r[0] for r in plan), "a parallel plan is chosen: %s"
      % plan)

# More rows than the shortlist: the two-stage form is phks_db_query, and
# the one-stage one is not (it ranks rows the shortlist leaves out).
one_stage_differs = False
for q in queries + [entries[5]]:
    for k in (1, 10, 100, len(many)):
        want = tool_topk(q, k, db_many)
        got = sql_two_stage(q, k)
        check(got == want, "two-stage top-%d of %s: SQL %s\n  tool %s" % (
            k, os.path.basename(q), got[:4], want[:4]))
        if k == 10:
            one_stage_differs |= sql_topk(q, k, table="many") != want
    got = sql_two_stage(q, 10, PARALLEL)
    check(got == tool_topk(q, 10, db_many),
          "two-stage top-10 of %s in a parallel plan" % os.path.basename(q))
# (Measured on the PSB meshes; generated ones may all be alike enough.)
if source == "psb":
    check(one_stage_differs, "the shortlist decides some top 10 of many")
print("two-stage top-k on %d rows checked (%.1f s)"
      % (len(many), time.time() - t0))

# entry <~> query is phks_score(query, entry), and entry <#> query
# phks_score_nearest(query, entry), bit for bit.
rows = pg.sql("SELECT bool_and(phks_score(a.sig, b.sig) = b.sig <~> a.sig "
              "AND phks_score_nearest(a.sig, b.sig) = b.sig <#> a.sig) "
              "FROM shapes a, shapes b;")
check(rows == [["t"]], "phks_score(q, e) equals e <~> q, "
      "phks_score_nearest(q, e) e <#> q")
# key <#> query is sig <#> query, bit for bit; a key is smaller and
# stays in its row, the signature leaves it.
rows = pg.sql("SELECT bool_and(e.key <#> q.sig = e.sig <#> q.sig), count(*) "
              "FROM many e, many q WHERE q.id <= 8;")
check(rows == [["t", str(8 * len(many))]], "key <#> q equals sig <#> q: %s"
      % rows)
rows = pg.sql("SELECT max(pg_column_size(key)), "
              "max(pg_column_size(sig::bytea)), "
              "pg_relation_size('many') < sum(length(sig::bytea)) FROM many;")
check(int(rows[0][0]) < 2000 and int(rows[0][1]) > 6000 and rows[0][2] == "t",
      "keys under 2 KB, signatures out of the rows: %s" % rows)
plan = pg.sql(PARALLEL + "EXPLAIN " + pgutil.two_stage(
    "many", pgutil.literal(queries[0]), 10))
check(any("Gather" in r[0] for r in plan),
      "the shortlist of keys runs in parallel: %s" % plan)

# The verified score is 0 for a signature against itself and asymmetric;
# the nearest one symmetric but for the order of its two sums.
rows = pg.sql("SELECT bool_and(a.sig <~> a.sig <= 1e-12), "
              "bool_or(abs((a.sig <~> b.sig) - (b.sig <~> a.sig)) > 1e-6), "
              "bool_and(abs((a.sig <#> b.sig) - (b.sig <#> a.sig)) <= "
              "1e-12 * (1 + (a.sig <#> b.sig))) FROM shapes a, shapes b;")
check(rows == [["t", "t", "t"]], "self 0, <~> asymmetric, <#> symmetric: %s"
      % rows)


def vectors(id_):
    text = pg.sql("SELECT phks_vectors(sig)::text FROM shapes WHERE id = %d;"
                  % id_)[0][0]
    return json.loads(text.replace("{", "[").replace("}", "]"))


def nearest_sum(a, b):
    return sum(min(sum(abs(x - y) for x, y in zip(u, v)) for v in b)
               for u in a)


# <#> is the paper's formula on phks_vectors.
a, b = vectors(1), vectors(2)
got = float(pg.sql("SELECT e.sig <#> q.sig FROM shapes e, shapes q "
                   "WHERE e.id = 2 AND q.id = 1;")[0][0])
want = nearest_sum(a, b) + nearest_sum(b, a)
check(abs(got - want) <= 1e-12 * want, "<#> %r against %r" % (got, want))
print("top-k checked (%.1f s)" % (time.time() - t0))

# Bad blobs: errors, never a crash.
good = pgutil.hexfile(entries[0])
flipped = good[:200] + ("0" if good[200] != "0" else "1") + good[201:]
for bad, what, expect in [
        ("zz", "not hex", "hex digit"),
        ("abc", "odd hex", "odd number"),
        ("", "empty", "phks_signature"),
        ("00ff", "short", "phks_signature"),
        (good[:-8], "truncated", "phks_signature"),
        (flipped, "flipped byte", "phks_signature"),
        ("50484b53" + "00" * 80, "magic only", "phks_signature")]:
    err = pg.error("SELECT '%s'::phks_signature;" % bad)
    check("ERROR" in err and expect in err, "bad blob (%s): %s" % (what, err))
    print("bad blob (%s): %s" % (what, err.strip().splitlines()[0]))
    err = pg.error("SELECT phks_feature_count(decode('%s', 'hex')::"
                   "phks_signature);" % bad) if what not in (
        "not hex", "odd hex") else "ERROR phks_signature"
    check("ERROR" in err, "bad bytea (%s): %s" % (what, err))
check(pg.sql("SELECT 1;") == [["1"]], "the server survives bad blobs")

# Bad keys: errors, never a crash. A key's text is the hex of its bytes:
# magic, version, count, length (4 bytes each), 4 bytes of padding, the
# options (72 bytes), then the vectors.
key = pg.sql("SELECT key FROM many WHERE id = 1;")[0][0]
nan = struct.pack("<d", float("nan")).hex()
for bad, what, expect in [
        ("zz", "not hex", "hex digit"),
        ("", "empty", "shorter than its header"),
        ("ff" + key[2:], "magic", "not a phks_key"),
        (key[:-16], "truncated", "does not match"),
        (key + "00" * 8, "longer", "does not match"),
        (key[:-16] + nan, "NaN", "not finite")]:
    err = pg.error("SELECT '%s'::phks_key;" % bad)
    check("ERROR" in err and expect in err, "bad key (%s): %s" % (what, err))
check(pg.sql("SELECT '%s'::phks_key::text = '%s';" % (key, key)) ==
      [["t"]], "a key's text round trip")

# Binary send/receive: COPY BINARY round trip, and a damaged binary blob.
copy = os.path.join(pg.root, "shapes.bin")
pg.sql("COPY shapes TO '%s' (FORMAT binary);\n"
       "CREATE TABLE shapes2 (LIKE shapes);\n"
       "COPY shapes2 FROM '%s' (FORMAT binary);" % (copy, copy))
rows = pg.sql("SELECT count(*) FROM shapes a JOIN shapes2 b USING (id) "
              "WHERE a.sig::bytea = b.sig::bytea;")
check(rows == [[str(len(entries))]], "binary COPY round trip: %s" % rows)
with open(copy, "rb") as f:
    data = bytearray(f.read())
data[len(data) // 2] ^= 0x55
bad_copy = os.path.join(pg.root, "bad.bin")
with open(bad_copy, "wb") as f:
    f.write(bytes(data))
err = pg.error("COPY shapes2 FROM '%s' (FORMAT binary);" % bad_copy)
check("ERROR" in err, "damaged binary COPY: %s" % err)

# Signatures made with other options: an error naming the option.
other = pgutil.signatures(phks, meshes[:1], os.path.join(work, "sigs-" +
                                                         source),
                          ["--hks-scaling", "none"])[0]
err = pg.error("SELECT id FROM shapes ORDER BY sig <~> '%s', id LIMIT 3;"
               % pgutil.hexfile(other))
check("hks_scaling" in err, "mismatched options name the option: %s" % err)
print("mismatch: " + err.strip().splitlines()[0])
err = pg.error("SELECT phks_score('%s', sig) FROM shapes;"
               % pgutil.hexfile(other))
check("hks_scaling" in err, "mismatched options (first argument): %s" % err)
err = pg.error("SELECT key <#> '%s' FROM many;" % pgutil.hexfile(other))
check("hks_scaling" in err, "a key of other options names it: %s" % err)
other2 = pgutil.signatures(phks, meshes[:1], os.path.join(work, "sigs-" +
                                                          source),
                           ["--operator", "literal"])[0]
err = pg.error("SELECT phks_score('%s', '%s');" % (pgutil.hexfile(other2),
                                                  good))
check("operator" in err, "mismatched operator names it: %s" % err)

# Accessors against the tool's --json.
r = subprocess.run([phks, "signature", entries[0], "--json"],
                   capture_output=True, text=True)
info = json.loads(r.stdout)
rows = pg.sql("SELECT phks_feature_count(sig), phks_vectors(sig)::text, "
              "phks_options(sig)::text FROM shapes WHERE id = 1;")
count, vectors, options = rows[0]
check(int(count) == info["feature_count"], "phks_feature_count")
vec = json.loads(vectors.replace("{", "[").replace("}", "]"))
check(vec == [f["vector"] for f in info["features"]],
      "phks_vectors equals the tool's vectors")
opts = json.loads(options)
tool_opts = info["options"]
check(all(opts[k] == tool_opts[k] for k in
          ("tau", "cutoff", "eigen_count", "feature_count", "scales",
           "feature_scale", "boundary_margin")),
      "phks_options: %s against %s" % (opts, tool_opts))
names = {"operator_kind": ("operator", ["literal", "random-walk"]),
         "box": ("box", ["principal", "axis-aligned"]),
         "hks_scaling": ("hks_scaling", ["none", "mean", "local-area"]),
         "quadrature": ("quadrature", ["vertices", "triangles"]),
         "matching": ("matching", ["nearest", "verified"]),
         "local_descriptor": ("local_descriptor", ["heat", "spin"]),
         "global_descriptor": ("global_descriptor", ["none", "d2"])}
check(all(names[k][1][opts[k]] == tool_opts[names[k][0]] for k in names),
      "phks_options enumerations: %s" % opts)
check(all(opts[k + "_name"] == tool_opts[names[k][0]].replace("-", "_")
          for k in names),
      "phks_options names the enumerations in SQL's words: %s" % opts)

# Signatures computed in the server equal the tool's, byte for byte.
for m, s in list(zip(meshes, sigs))[:3] + [(meshes[-1], sigs[-1])]:
    with open(m, "rb") as f:
        mesh_hex = f.read().hex()
    fmt = "off" if m.endswith(".off") else "auto"
    rows = pg.sql("SELECT phks_signature_from_mesh(decode('%s', 'hex'), "
                  "'%s');" % (mesh_hex, fmt))
    check(rows[0][0] == pgutil.hexfile(s),
          "phks_signature_from_mesh(%s) equals the tool's blob" %
          os.path.basename(m))
# With options: the tool's blob made with the same options, and again from
# that blob's own phks_options (how a table's options are taken from a
# row); every member absent keeps its default.
m, s = meshes[0], sigs[0]
with open(m, "rb") as f:
    mesh_hex = f.read().hex()
other = os.path.join(work, "other-options.sig")
subprocess.run([phks, "--quadrature", "vertices", "--hks-scaling", "none",
                "--matching", "nearest", "signature", m, "-o", other],
               check=True)
from_mesh = ("SELECT phks_signature_from_mesh(decode('%s', 'hex'), 'auto', "
             "%%s);" % mesh_hex)
rows = pg.sql(from_mesh % "'{\"quadrature\": \"vertices\", "
              "\"hks_scaling\": 0, \"matching\": \"nearest\"}'")
check(rows[0][0] == pgutil.hexfile(other),
      "phks_signature_from_mesh with options equals the tool's blob")
rows = pg.sql(from_mesh % ("phks_options('\\x%s'::bytea::phks_signature)"
                           "::jsonb" % pgutil.hexfile(other)))
check(rows[0][0] == pgutil.hexfile(other),
      "phks_signature_from_mesh with a row's phks_options makes its blob")
rows = pg.sql(from_mesh % "'{}'")
check(rows[0][0] == pgutil.hexfile(s), "no options: the defaults")
for options, words in [
        ('{"quadrature": "edges"}', "quadrature: 'edges' is not one of"),
        ('{"tau": -1}', "tau"),
        ('{"no_such": 1}', '"no_such" is no option'),
        ('{"threads": 2}', '"threads" cannot be set'),
        ('{"hks_scaling": 0, "hks_scaling_name": "mean"}',
         '"hks_scaling_name" disagrees'),
        ('{"matching": true}', '"matching" needs a number'),
        ('[1, 2]', "options must be a JSON object")]:
    err = pg.error(from_mesh % ("'%s'" % options))
    check("ERROR" in err and words in err,
          "options %s: %s" % (options, err.strip()))
err = pg.error("SELECT phks_signature_from_mesh('\\x4f46460a'::bytea);")
check("ERROR" in err and "phks_signature_from_mesh" in err,
      "a bad mesh: %s" % err)
err = pg.error("SELECT phks_signature_from_mesh('\\x00'::bytea, 'xyz');")
check("unknown format" in err, "an unknown format: %s" % err)
# Canceled by statement_timeout inside a computation, without a leak or a
# crash (the library is stopped by its progress callback).
big = max(meshes, key=os.path.getsize)
with open(big, "rb") as f:
    big_hex = f.read().hex()
err = pg.error("SET statement_timeout = '50ms'; SELECT "
               "phks_signature_from_mesh(decode('%s', 'hex'));" % big_hex)
check("canceling statement" in err, "statement_timeout cancels: %s" % err)
check(pg.sql("SELECT 1;") == [["1"]], "the server survives")

pg.stop()
print("%d failures (%.1f s)" % (len(failures), time.time() - t0))
sys.exit(1 if failures else 0)
