#!/usr/bin/env python3
"""test_postgres_shards.py BUILD_ROOT PHKS_TOOL [SHARED_MESHES]

Scale-out (docs/scale.md): three servers hold the shards, a coordinator
holds a table hash-partitioned on id whose partitions are postgres_fdw
foreign tables on the shards, with phks listed in the foreign server's
`extensions` so that <#> is computed on the shards. The sharded top-k
(the two-stage query: a shortlist by <#>, re-ranked by <~>) equals the
single server's (a plain table on the coordinator), ids and scores, and
the remote SQL carries the ORDER BY with <#>.
"""
import os
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
meshes, source = pgutil.test_meshes(shared, os.path.join(work, "meshes"), 30)
sigs = pgutil.signatures(phks, meshes, os.path.join(work, "sigs-" + source))
entries = sigs[:24] + [sigs[5]]  # a tie that only the id breaks
queries = sigs[24:] + sigs[:3]

failures = pgutil.failures
check = pgutil.check


SHARDS = 3
# docs/scale.md's layout: a key beside each signature, computed where the
# row is stored (on the coordinator for rows routed through it).
TABLE = ("(id bigint NOT NULL, name text NOT NULL, sig phks_signature "
         "NOT NULL, key phks_key GENERATED ALWAYS AS (phks_key(sig)) STORED)")
shards = [pgutil.Cluster(bindir, "shard%d" % i) for i in range(SHARDS)]
coord = pgutil.Cluster(bindir, "coordinator")
print("4 servers up (%.1f s)" % (time.time() - t0))

for s in shards:
    s.sql("CREATE EXTENSION phks;\nCREATE TABLE shapes %s;\n"
          "ALTER TABLE shapes ADD PRIMARY KEY (id), "
          "ALTER COLUMN sig SET STORAGE external;" % TABLE)
setup = ["CREATE EXTENSION phks;", "CREATE EXTENSION postgres_fdw;",
         "CREATE TABLE shapes %s PARTITION BY HASH (id);" % TABLE]
for i, s in enumerate(shards):
    setup += [
        "CREATE SERVER shard%d FOREIGN DATA WRAPPER postgres_fdw OPTIONS "
        "(host '127.0.0.1', port '%d', dbname 'postgres', "
        "extensions 'phks', fetch_size '100', fdw_tuple_cost '1');" %
        (i, s.port),
        "CREATE USER MAPPING FOR CURRENT_USER SERVER shard%d OPTIONS "
        "(user 'postgres');" % i,
        "CREATE FOREIGN TABLE shapes_%d PARTITION OF shapes FOR VALUES WITH "
        "(MODULUS %d, REMAINDER %d) SERVER shard%d OPTIONS "
        "(table_name 'shapes', use_remote_estimate 'true');" %
        (i, SHARDS, i, i)]
setup.append("CREATE TABLE shapes_single %s;" % TABLE)
coord.sql("\n".join(setup))

COPIES = 40
values = ",\n".join("(%d, '%s', '%s'::phks_signature)" %
                     (i + 1, os.path.basename(e), pgutil.hexfile(e))
                     for i, e in enumerate(entries))
# Every entry COPIES times under other ids (1000 rows: shards large enough
# for the planner to send LIMITs, and ties that only the id breaks). Rows
# go through the coordinator: routed to the shard of their hash.
rows_sql = ("SELECT g * %d + v.id, v.name, v.sig FROM (VALUES %s) AS "
            "v (id, name, sig), generate_series(0, %d) AS g" %
            (len(entries), values, COPIES - 1))
coord.sql("INSERT INTO shapes %s;\nINSERT INTO shapes_single %s;\n"
          "ANALYZE shapes_single;" % (rows_sql, rows_sql))
for s in shards:
    s.sql("ANALYZE shapes;")
counts = [int(s.sql("SELECT count(*) FROM shapes;")[0][0]) for s in shards]
print("rows per shard:", counts)
check(sum(counts) == COPIES * len(entries) and all(c > 0 for c in counts),
      "every shard holds rows: %s" % counts)


def topk(table, q, k):
    rows = coord.sql(pgutil.two_stage(table, pgutil.literal(q), k))
    return [(int(r[0]), r[1], float(r[2])) for r in rows]


for q in queries:
    for k in (1, 3, 10, 100, COPIES * len(entries)):
        single = topk("shapes_single", q, k)
        sharded = topk("shapes", q, k)
        check(len(single) == min(k, COPIES * len(entries)) and
              sharded == single,
              "top-%d of %s: sharded %s\n  single %s" %
              (k, os.path.basename(q), sharded[:3], single[:3]))

plan = coord.sql("EXPLAIN (VERBOSE, COSTS OFF) " +
                 pgutil.two_stage("shapes", pgutil.literal(queries[0]), 10))
remote = [r[0] for r in plan if "Remote SQL" in r[0]]
print("\n".join(r[0] for r in plan if "Remote SQL" not in r[0]
                and "Output" not in r[0] and "Key" not in r[0]))
print(remote[0][:100] + " ... " + remote[0][-60:] if remote else
      "no remote SQL")
check(len(remote) == SHARDS and all("ORDER BY (key OPERATOR(public.<#>)"
                                    in r for r in remote),
      "the scoring and the ORDER BY run on the shards: %s" %
      [r[:200] for r in remote])

# The same top k with a LIMIT on every shard (docs/scale.md): each shard
# sends only its own shortlist.
coord.sql(pgutil.shard_topk())
for q in queries[:3]:
    for k in (1, 10):
        rows = coord.sql("SELECT * FROM shard_topk('%s', %d);" %
                         (pgutil.hexfile(q), k))
        got = [(int(r[0]), r[1], float(r[2])) for r in rows]
        check(got == topk("shapes_single", q, k),
              "shard_topk top-%d of %s" % (k, os.path.basename(q)))
# With async_capable the per-shard form runs the shards at once.
coord.sql("".join("ALTER SERVER shard%d OPTIONS (ADD async_capable 'true');"
                  % i for i in range(SHARDS)))
qh = pgutil.hexfile(queries[0])
branch = ("(SELECT id, key <#> '%s' AS nearest FROM shapes_%%d ORDER BY "
          "key <#> '%s', id LIMIT 100)" % (qh, qh))
plan = coord.sql("EXPLAIN SELECT * FROM (SELECT * FROM (%s) AS u OFFSET 0) "
                 "AS hits ORDER BY nearest, id LIMIT 100;" %
                 " UNION ALL ".join(branch % i for i in range(SHARDS)))
check(sum("Async Foreign Scan" in r[0] for r in plan) == SHARDS,
      "async foreign scans: %s" % [r[0][:60] for r in plan])
for q in queries[:2]:
    rows = coord.sql("SELECT * FROM shard_topk('%s', 10);" % pgutil.hexfile(q))
    check([(int(r[0]), r[1], float(r[2])) for r in rows] ==
          topk("shapes_single", q, 10), "async shard_topk of %s" %
          os.path.basename(q))
plan = coord.sql("EXPLAIN (VERBOSE, COSTS OFF) SELECT id FROM shapes_0 "
                 "ORDER BY key <#> '%s', id LIMIT 100;" %
                 pgutil.hexfile(queries[0]))
# (With these few rows the planner may keep the LIMIT on the coordinator
# over the shard's sorted stream; on larger shards it sends it too.)
check(any("Remote SQL" in r[0] and "ORDER BY (key OPERATOR(public.<#>)" in
          r[0] for r in plan), "a shard sorts by <#> itself: %s" %
      [r[0][:80] + " ... " + r[0][-40:] for r in plan])

# A signature made with other options: the shard's error, naming it.
other = pgutil.signatures(phks, meshes[:1], os.path.join(work, "sigs-" +
                                                         source),
                          ["--hks-scaling", "none"])[0]
err = coord.error("SELECT id FROM shapes ORDER BY sig <~> '%s', id LIMIT 3;"
                  % pgutil.hexfile(other))
check("hks_scaling" in err, "a mismatch through the shards: %s" % err)

for c in shards + [coord]:
    c.stop()
print("%d failures (%.1f s)" % (len(failures), time.time() - t0))
sys.exit(1 if failures else 0)
