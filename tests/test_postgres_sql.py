#!/usr/bin/env python3
"""test_postgres_sql.py BUILD_ROOT PHKS_TOOL [SHARED_MESHES]

The extension's SQL that guards itself and reads short (docs/postgres.md),
on a throwaway cluster:
  - phks_topk(q, k, table) is `phks db query --json`'s top k on the same
    entries (ids and scores exactly), shortlisting by the signatures or by
    a phks_key column;
  - equality: every input is stored as its canonical blob (a format-1 blob
    as the current format's bytes), and =, DISTINCT, GROUP BY, hash joins
    and a hash index work;
  - the trigger phks_one_option_set refuses a row made with other options
    than the table's, naming the option, on insert and on update, and when
    two first rows are written at once.
"""
import json
import os
import struct
import subprocess
import sys
import time
import zlib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import pgutil  # noqa: E402

build_root, phks = sys.argv[1], sys.argv[2]
shared = sys.argv[3] if len(sys.argv) > 3 else os.environ.get(
    "PHKS_SHARED_MESHES", "")

failures = pgutil.failures
check = pgutil.check


def tool_topk(db, q, k):
    r = subprocess.run([phks, "db", "query", db, q, "-k", str(k), "--json"],
                       capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit("phks db query: " + r.stderr)
    return [(h["id"], float(h["score"])) for h in json.loads(r.stdout)]


def test_topk(pg, sigs, work):
    """40 entries, each twice: more than the shortlist of 32, with ties."""
    entries = sigs + sigs
    db = os.path.join(work, "topk.db")
    pgutil.tool_db(phks, db, entries)
    values = ",\n".join("(%d, '%s')" % (i + 1, pgutil.hexfile(e))
                        for i, e in enumerate(entries))
    pg.sql("CREATE TABLE shapes (id bigint PRIMARY KEY, "
           "signature phks_signature NOT NULL, "
           "key phks_key GENERATED ALWAYS AS (phks_key(signature)) STORED);\n"
           "INSERT INTO shapes VALUES %s;\nANALYZE shapes;" % values)
    for q in sigs[::7]:
        for k in (1, 10, 33, len(entries)):
            want = tool_topk(db, q, k)
            for call in ("phks_topk(%s, %d, 'shapes')",
                         "phks_topk(%s, %d, 'shapes', key_column => 'key')"):
                rows = pg.sql("SELECT id, score FROM %s;" %
                              (call % (pgutil.literal(q), k)))
                got = [(int(r[0]), float(r[1])) for r in rows]
                check(got == want, "%s: %s\n  tool %s" % (
                    call % (os.path.basename(q), k), got[:4], want[:4]))
    rows = pg.sql("SELECT count(*) FROM phks_topk(%s, 0, 'shapes');" %
                  pgutil.literal(sigs[0]))
    check(rows == [["0"]], "k = 0 gives no rows: %s" % rows)
    err = pg.error("SELECT * FROM phks_topk(%s, -1, 'shapes');" %
                   pgutil.literal(sigs[0]))
    check("k must be 0 or more" in err, "k = -1: " + err)
    err = pg.error("SELECT * FROM phks_topk(%s, 3, 'shapes', 'nope');" %
                   pgutil.literal(sigs[0]))
    check("nope" in err, "an unknown column: " + err)
    print("phks_topk equals phks db query on %d entries" % len(entries))


def format1_blob(path):
    """The format-1 bytes (0.1.0's) of a format-2 blob made with
    boundary_margin 0, hks_scaling none and the vertices' quadrature: the
    same without the fields at offsets 52 (8 bytes) and 60 (4 bytes), the
    checksum made again (docs/formats.md)."""
    with open(path, "rb") as f:
        blob = f.read()
    assert struct.unpack_from("<H", blob, 4)[0] == 2
    old = bytearray(blob[:52] + blob[64:-4])
    struct.pack_into("<H", old, 4, 1)
    return bytes(old) + struct.pack("<I", zlib.crc32(bytes(old)))


def test_equality(pg, sigs, meshes, work):
    values = ",\n".join("(%d, '%s')" % (i + 1, pgutil.hexfile(s))
                        for i, s in enumerate(sigs + sigs))
    pg.sql("CREATE TABLE twice (id bigint, sig phks_signature);\n"
           "INSERT INTO twice VALUES %s;\nANALYZE twice;" % values)
    rows = pg.sql("SELECT count(DISTINCT sig), count(*) FROM twice;")
    check(rows == [[str(len(sigs)), str(2 * len(sigs))]],
          "count(DISTINCT sig): %s" % rows)
    rows = pg.sql("SELECT count(*) FROM (SELECT sig FROM twice GROUP BY sig "
                  "HAVING count(*) = 2) AS g;")
    check(rows == [[str(len(sigs))]], "GROUP BY sig: %s" % rows)
    rows = pg.sql("SELECT count(*) FROM (SELECT sig FROM twice UNION "
                  "SELECT sig FROM twice) AS u;")
    check(rows == [[str(len(sigs))]], "UNION: %s" % rows)
    hash_join = ("SET enable_mergejoin = off; SET enable_nestloop = off;\n"
                 "%sSELECT count(*) FROM twice a JOIN twice b ON a.sig = "
                 "b.sig AND a.id <> b.id;")
    rows = pg.sql(hash_join % "")
    check(rows == [[str(2 * len(sigs))]], "a hash join: %s" % rows)
    plan = pg.sql(hash_join % "EXPLAIN ")
    check(any("Hash Join" in r[0] for r in plan), "plan: %s" % plan)
    rows = pg.sql("SELECT count(*) FROM twice WHERE sig = %s AND sig <> %s;"
                  % (pgutil.literal(sigs[3]), pgutil.literal(sigs[4])))
    check(rows == [["2"]], "= and <> with a constant: %s" % rows)
    lookup = ("SET enable_seqscan = off;\n%sSELECT id FROM twice WHERE "
              "sig = %s ORDER BY id;" % ("%s", pgutil.literal(sigs[5])))
    pg.sql("CREATE INDEX twice_sig ON twice USING hash (sig);")
    check(pg.sql(lookup % "") == [["6"], [str(len(sigs) + 6)]],
          "a hash index finds both rows")
    check(any("twice_sig" in r[0] for r in pg.sql(lookup % "EXPLAIN ")),
          "the hash index is used")

    # A format-1 blob is stored as the current format's bytes of the same
    # signature, and equals it.
    made = pgutil.signatures(phks, meshes[:1], os.path.join(work, "sigs"),
                             ["--boundary-margin", "0", "--hks-scaling",
                              "none", "--matching", "nearest",
                              "--quadrature", "vertices"])[0]
    old = format1_blob(made)
    rows = pg.sql("SELECT '%s'::phks_signature::bytea = decode('%s', 'hex'),"
                  " '%s'::phks_signature = '%s'::phks_signature;"
                  % (old.hex(), pgutil.hexfile(made), old.hex(),
                     pgutil.hexfile(made)))
    check(rows == [["t", "t"]], "a format-1 blob is stored canonical: %s"
          % rows)
    rows = pg.sql("SELECT bool_and(sig::text = '%s') FROM twice WHERE id = 1;"
                  % pgutil.hexfile(sigs[0]))
    check(rows == [["t"]], "a current blob is stored unchanged")
    print("equality checked on %d signatures" % len(sigs))


def test_one_option_set(pg, sigs, meshes, work):
    other = pgutil.signatures(phks, meshes[:1], os.path.join(work, "sigs"),
                              ["--hks-scaling", "none"])[0]
    guarded = ("CREATE TABLE %s (id bigint, sig phks_signature);\n"
               "CREATE TRIGGER one_option_set AFTER INSERT OR UPDATE OF sig "
               "ON %s FOR EACH ROW EXECUTE FUNCTION "
               "phks_one_option_set('sig');\n")
    pg.sql(guarded % ("guarded", "guarded") +
           "INSERT INTO guarded VALUES (1, %s), (2, %s);" %
           (pgutil.literal(sigs[0]), pgutil.literal(sigs[1])))
    err = pg.error("INSERT INTO guarded VALUES (3, %s);" %
                   pgutil.literal(other))
    check("guarded.sig holds signatures made with other options: "
          "hks_scaling none against local_area" in err, "insert: " + err)
    err = pg.error("UPDATE guarded SET sig = %s WHERE id = 1;" %
                   pgutil.literal(other))
    check("hks_scaling none against local_area" in err, "update: " + err)
    rows = pg.sql("UPDATE guarded SET sig = %s WHERE id = 1; "
                  "SELECT count(*) FROM guarded;" % pgutil.literal(sigs[2]))
    check(rows == [["2"]], "an update within the option set: %s" % rows)
    err = pg.error("CREATE TABLE misused (id bigint, sig phks_signature);\n"
                   "CREATE TRIGGER t BEFORE INSERT ON misused FOR EACH ROW "
                   "EXECUTE FUNCTION phks_one_option_set('sig');\n"
                   "INSERT INTO misused VALUES (1, %s);" %
                   pgutil.literal(sigs[0]))
    check("must be an AFTER INSERT OR UPDATE" in err, "misuse: " + err)

    # Two first rows at once: the second waits for the first and sees it.
    pg.sql(guarded % ("race", "race"))
    first = subprocess.Popen(
        pg_command(pg, "BEGIN; INSERT INTO race VALUES (1, %s); "
                   "SELECT pg_sleep(1.5); COMMIT;" % pgutil.literal(sigs[0])),
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(0.5)
    err = pg.error("INSERT INTO race VALUES (2, %s);" % pgutil.literal(other))
    first.communicate()
    check(first.returncode == 0 and "hks_scaling none against local_area" in
          err, "two first rows at once: %d, %s" % (first.returncode, err))
    check(pg.sql("SELECT id FROM race;") == [["1"]], "the first row stays")
    # The library's message names the function once, not twice.
    err = pg.error("SELECT phks_score_nearest(%s, %s);" %
                   (pgutil.literal(other), pgutil.literal(sigs[0])))
    check(err.count("phks_score_nearest:") == 1 and
          "different options (hks_scaling none against local_area)" in err,
          "a mismatch's message: " + err)
    print("phks_one_option_set checked")


def pg_command(pg, script):
    return [os.path.join(pg.bindir, "psql"), "-X", "-q", "-v",
            "ON_ERROR_STOP=1", "-h", pg.sock, "-p", str(pg.port), "-U",
            "postgres", "-d", "postgres", "-c", script]


def main():
    bindir = pgutil.pg_bindir()
    t0 = time.time()
    pgutil.install_extension(build_root)
    work = os.path.join(build_root, "tests", "postgres-sql-work")
    meshes, source = pgutil.test_meshes(shared, os.path.join(work, "meshes"),
                                        20)
    sigs = pgutil.signatures(phks, meshes, os.path.join(work,
                                                        "sigs-" + source))
    pg = pgutil.Cluster(bindir, "sql")
    pg.sql("CREATE EXTENSION phks;")
    test_topk(pg, sigs, work)
    test_equality(pg, sigs, meshes, work)
    test_one_option_set(pg, sigs, meshes, work)
    pg.stop()
    print("%d failures (%.1f s)" % (len(failures), time.time() - t0))
    sys.exit(1 if failures else 0)


main()
