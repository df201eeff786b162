#!/usr/bin/env python3
"""bench_pg.py BUILD_DIR [-n N] [--queries Q] [--skip-single|--skip-shards]

Times phks_db_query's top 10 in SQL (the two-stage query of
docs/postgres.md: a shortlist of 32 by <#> q, re-ranked by sig <~> q) over
N synthetic signatures (default 100000) on one throwaway server, and on
three shard servers behind a postgres_fdw coordinator (docs/scale.md), all
on this machine. Every table keeps a phks_key beside each signature and
shortlists by key <#> q (docs/postgres.md, "Large tables"). Called by bench/bench_pg.sh; needs what tests/test_postgres.py
needs (root, the server packages, the built extension).

The synthetic signatures are valid blobs with the default options: 15
features at the default 15 scales, vectors of a real signature (the
tool's, of a generated mesh) moved by seeded noise, so that every score
differs, and that signature's distances between its feature points; they are loaded with COPY (FORMAT binary), through the type's
receive function, which validates each one.
"""
import argparse
import os
import random
import shutil
import statistics
import struct
import subprocess
import sys
import tempfile
import time
import zlib

here = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(here, "..", "tests"))
import pgutil  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("build")
ap.add_argument("-n", type=int, default=100000)
ap.add_argument("--queries", type=int, default=5)
ap.add_argument("--shards", type=int, default=3)
ap.add_argument("--skip-single", action="store_true")
ap.add_argument("--skip-shards", action="store_true")
args = ap.parse_args()
build = os.path.abspath(args.build)
phks = os.path.join(build, "tools", "phks", "phks")

bindir = pgutil.pg_bindir()
pgutil.install_extension(build)
tmp = tempfile.mkdtemp(prefix="phks-bench-")
mesh = os.path.join(tmp, "template.off")
pgutil.bumpy_sphere_off(mesh, 3)
template = open(pgutil.signatures(phks, [mesh], tmp)[0], "rb").read()
shutil.rmtree(tmp)

# The blob's layout: docs/formats.md (its header grew with the format).
H = pgutil.header_size(pgutil.blob_format(template))
S = struct.unpack_from("<I", template, 48)[0]
head = template[:H + 8 * S]
F = struct.unpack_from("<I", template, H + 8 * S)[0]
rec = 36 + 8 * S
base_vectors = []
for f in range(F):
    off = H + 8 * S + 4 + f * rec + 36
    base_vectors.append(struct.unpack_from("<%dd" % S, template, off))
# Everything after the features (the verified matching's samples,
# distances and spin images), the template's: only the vectors move.
geodesics = template[H + 8 * S + 4 + F * rec:-4]


def synthetic(seed):
    rng = random.Random(seed)
    body = bytearray(head)
    body += struct.pack("<I", F)
    for f in range(F):
        body += struct.pack("<I3dd", rng.randrange(1000), rng.random(),
                            rng.random(), rng.random(),
                            float("inf") if f == 0 else 100.0 / (f + 1))
        scale = rng.uniform(0.5, 1.5)
        body += struct.pack("<%dd" % S, *[v * scale + rng.gauss(0, 0.3)
                                          for v in base_vectors[f]])
    body += geodesics
    body += struct.pack("<I", zlib.crc32(bytes(body)) & 0xffffffff)
    return bytes(body)


def copy_binary(cluster, table, ids):
    """Streams rows (id, name, sig) of the given ids with COPY BINARY."""
    proc = subprocess.Popen(
        [os.path.join(bindir, "psql"), "-X", "-q", "-v", "ON_ERROR_STOP=1",
         "-h", cluster.sock, "-p", str(cluster.port), "-U", "postgres",
         "-c", "COPY %s FROM STDIN (FORMAT binary)" % table],
        stdin=subprocess.PIPE)
    out = proc.stdin
    out.write(b"PGCOPY\n\xff\r\n\x00" + struct.pack(">ii", 0, 0))
    for i in ids:
        name = b"syn%d" % i
        blob = synthetic(i)
        out.write(struct.pack(">hiq", 3, 8, i) +
                  struct.pack(">i", len(name)) + name +
                  struct.pack(">i", len(blob)) + blob)
    out.write(struct.pack(">h", -1))
    out.close()
    if proc.wait() != 0:
        raise SystemExit("COPY failed")


KEYED_TABLE = ("CREATE TABLE shapes (id bigint NOT NULL, name text NOT NULL, "
               "sig phks_signature NOT NULL, key phks_key GENERATED ALWAYS "
               "AS (phks_key(sig)) STORED);\n"
               "ALTER TABLE shapes ALTER COLUMN sig SET STORAGE external;")
queries = [synthetic(10 ** 9 + i).hex() for i in range(args.queries)]
SHARD_QUERY = "SELECT * FROM shard_topk('%s', 10);"


CPU = "\\! awk '{print \"cpu\", $14 + $15}' /proc/$PHKS_PID/stat\n"


def timed(cluster, table, pre="", shard_topk=False):
    """Median and best time of the queries, in one session after one
    warm-up query (connections to the shards, caches), and the median
    processor time of the session's own backend per query (user + system,
    from /proc: parallel workers' and shards' own are not in it)."""
    script = ("\\timing on\nSELECT pg_backend_pid() AS pid \\gset\n"
              "\\setenv PHKS_PID :pid\n" + pre +
              "".join((SHARD_QUERY % q if shard_topk else
                       pgutil.two_stage(table, "'%s'::phks_signature" % q,
                                        10)) + CPU + "\\echo ==\n"
                      for q in [queries[0]] + queries))
    # Each psql session's backend loads the module anew: the build's, in
    # case another build was installed since (the files are shared).
    pgutil.install_extension(build)
    out = subprocess.run(
        [os.path.join(bindir, "psql"), "-X", "-A", "-t", "-v",
         "ON_ERROR_STOP=1", "-h", cluster.sock, "-p", str(cluster.port),
         "-U", "postgres", "-f", "-"], input=script, capture_output=True,
        text=True)
    if out.returncode != 0:
        raise SystemExit("psql: " + out.stderr[-2000:])
    blocks = out.stdout.split("==\n")[:len(queries) + 1]
    tick = os.sysconf("SC_CLK_TCK")
    cpu = [float([x for x in b.splitlines() if x.startswith("cpu ")][-1]
                 .split()[1]) / tick for b in blocks]
    times, results = [], []
    for b in blocks[1:]:
        lines = b.splitlines()
        times.append(float([x for x in lines if x.startswith("Time:")][-1]
                           .split()[1]))
        results.append([x for x in lines if "|" in x])
    cpu_ms = statistics.median(1000 * (b - a) for a, b in zip(cpu, cpu[1:]))
    return statistics.median(times), min(times), cpu_ms, results


report = []
print("N = %d synthetic signatures, %d queries, top 10" % (args.n,
                                                         len(queries)))
single_results = None
if not args.skip_single:
    pg = pgutil.Cluster(bindir, "bench-single",
                        settings=["shared_buffers=1GB", "max_wal_size=4GB"])
    pg.sql("CREATE EXTENSION phks; " + KEYED_TABLE)
    t = time.time()
    copy_binary(pg, "shapes", range(1, args.n + 1))
    pg.sql("ANALYZE shapes; SELECT count(*) FROM shapes;")
    print("single: loaded in %.1f s" % (time.time() - t))
    med, best, cpu, single_results = timed(
        pg, "shapes", "SET max_parallel_workers_per_gather = 0;\n")
    report.append(("one server, one process", med, best, cpu))
    med, best, cpu, res = timed(pg, "shapes",
                           "SET max_parallel_workers_per_gather = 2;\n")
    assert res == single_results, "parallel plan differs"
    report.append(("one server, 2 parallel workers", med, best, cpu))
    pg.stop()

if not args.skip_shards:
    shards = [pgutil.Cluster(bindir, "bench-shard%d" % i,
                             settings=["shared_buffers=512MB",
                                       "max_wal_size=4GB"])
              for i in range(args.shards)]
    coord = pgutil.Cluster(bindir, "bench-coord")
    setup = ["CREATE EXTENSION phks;", "CREATE EXTENSION postgres_fdw;",
             "CREATE TABLE shapes (id bigint NOT NULL, name text NOT NULL, "
             "sig phks_signature NOT NULL, key phks_key GENERATED ALWAYS "
             "AS (phks_key(sig)) STORED) "
             "PARTITION BY HASH (id);"]
    t = time.time()
    for i, s in enumerate(shards):
        s.sql("CREATE EXTENSION phks; " + KEYED_TABLE)
        # Rows straight to their shard (the hash of the coordinator's
        # partitioning decides which: satisfies_hash_partition).
        setup += [
            "CREATE SERVER shard%d FOREIGN DATA WRAPPER postgres_fdw "
            "OPTIONS (host '127.0.0.1', port '%d', dbname 'postgres', "
            "extensions 'phks', fetch_size '100', fdw_tuple_cost '1');"
            % (i, s.port),
            "CREATE USER MAPPING FOR CURRENT_USER SERVER shard%d OPTIONS "
            "(user 'postgres');" % i,
            "CREATE FOREIGN TABLE shapes_%d PARTITION OF shapes FOR VALUES "
            "WITH (MODULUS %d, REMAINDER %d) SERVER shard%d OPTIONS "
            "(table_name 'shapes', use_remote_estimate 'true');"
            % (i, args.shards, i, i)]
    coord.sql("\n".join(setup))
    # Which shard holds each id: asked of the coordinator in one query.
    rows = coord.sql("SELECT i, (SELECT r FROM generate_series(0, %d) r "
                     "WHERE satisfies_hash_partition('shapes'::regclass, "
                     "%d, r, i)) FROM generate_series(1::bigint, %d) i;" %
                     (args.shards - 1, args.shards, args.n, ))
    owner = {}
    for i, r in rows:
        owner.setdefault(int(r), []).append(int(i))
    for r, s in enumerate(shards):
        copy_binary(s, "shapes", owner.get(r, []))
        s.sql("ANALYZE shapes;")
    print("shards: loaded in %.1f s (%s rows)" %
          (time.time() - t, [len(owner.get(r, [])) for r in
                             range(args.shards)]))
    med, best, cpu, res = timed(coord, "shapes")
    if single_results is not None:
        assert res == single_results, "sharded top-10 differs"
    report.append(("coordinator + %d shards (Merge Append)" % args.shards,
                   med, best, cpu))
    coord.sql(pgutil.shard_topk("key"))
    med, best, cpu, res = timed(coord, "shapes", "", shard_topk=True)
    if single_results is not None:
        assert res == single_results, "shard_topk differs"
    report.append(("coordinator + %d shards (shard_topk, LIMIT per shard)"
                   % args.shards, med, best, cpu))
    # The shards' scans at the same time (postgres_fdw's async Append).
    coord.sql("".join("ALTER SERVER shard%d OPTIONS (ADD async_capable "
                      "'true');" % i for i in range(args.shards)))
    med, best, cpu, res = timed(coord, "shapes", "", shard_topk=True)
    if single_results is not None:
        assert res == single_results, "async shard_topk differs"
    report.append(("coordinator + %d shards (shard_topk, async_capable)"
                   % args.shards, med, best, cpu))
    for c in shards + [coord]:
        c.stop()

print()
print("| setup | median ms | best ms | backend CPU ms |")
print("|---|---|---|---|")
for name, med, best, cpu in report:
    print("| %s | %.0f | %.0f | %.0f |" % (name, med, best, cpu))
