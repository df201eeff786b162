#!/usr/bin/env python3
"""test_postgres_load.py PART BUILD_ROOT PHKS_TOOL [SHARED_MESHES]

The PostgreSQL extension under load and faults (docs/postgres.md, "Load
and faults"), on throwaway clusters, with tables laid out as in "Large
tables" (a phks_key beside each signature; the two-stage top 10
shortlists by the key). PART is one of:

  load     eight clients run top-10 queries while a ninth inserts rows,
           one per transaction, for PHKS_PG_LOAD_SECONDS (60 unless set):
           no client meets an error, and every answer equals the same
           query run without parallel workers in the same snapshot, and
           again afterwards, serially, on the rows that snapshot held.
  kill     the backend of a client that inserts is killed (SIGKILL) in the
           middle of a statement of an open transaction: the server
           recovers, the table holds every row whose COMMIT was
           acknowledged, with its bytes, and none of the killed
           transaction's, and top-k answers are a fresh table's.
  dump     pg_dump in plain and custom formats, restored into new
           databases by psql and pg_restore: the same rows, byte for byte,
           and the same top-k answers.
  replica  a streaming replica (pg_basebackup -R) replays the rows
           inserted on the primary, answers the same top k, and refuses
           writes.
"""
import bisect
import collections
import hashlib
import os
import random
import signal
import subprocess
import sys
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import pgutil  # noqa: E402

if len(sys.argv) < 4:
    raise SystemExit(__doc__)
part, build_root, phks = sys.argv[1:4]
shared = sys.argv[4] if len(sys.argv) > 4 else os.environ.get(
    "PHKS_SHARED_MESHES", "")

bindir = pgutil.pg_bindir()
t0 = time.time()
pgutil.install_extension(build_root)
work = os.path.join(build_root, "tests", "postgres-work")
os.makedirs(work, exist_ok=True)

failures = pgutil.failures
check = pgutil.check


def table_sql(name):
    """docs/postgres.md's layout for large tables; ids from the table's
    sequence unless given."""
    return ("CREATE TABLE %s (id bigserial PRIMARY KEY, name text NOT NULL, "
            "sig phks_signature NOT NULL, key phks_key GENERATED ALWAYS AS "
            "(phks_key(sig)) STORED);\n"
            "ALTER TABLE %s ALTER COLUMN sig SET STORAGE external;\n"
            % (name, name))


class Row:
    """A signature file as a row to insert: its mesh's name, the blob's
    hex and md5."""

    def __init__(self, sig):
        with open(sig, "rb") as f:
            blob = f.read()
        self.name = os.path.basename(sig).split(".")[0]
        self.hex = blob.hex()
        self.md5 = hashlib.md5(blob).hexdigest()

    def values(self, with_id=None):
        if with_id is None:
            return "('%s', '%s')" % (self.name, self.hex)
        return "(%d, '%s', '%s')" % (with_id, self.name, self.hex)


def small_rows(count):
    """Rows of count small meshes' signatures: distinct blobs made in
    seconds (cached after the first run)."""
    meshes = pgutil.small_meshes(os.path.join(work, "small-meshes"), count)
    sigs = pgutil.signatures(phks, meshes, os.path.join(work, "sigs-small"),
                             jobs=os.cpu_count() or 1)
    return [Row(s) for s in sigs]


def real_meshes(count):
    """The smallest shared meshes (generated ones without them), the
    test_postgres.py ones, and rows of their signatures (15 features,
    6.5 KB)."""
    meshes, source = pgutil.test_meshes(shared, os.path.join(work, "meshes"),
                                        count)
    sigs = pgutil.signatures(phks, meshes, os.path.join(work, "sigs-" +
                                                        source),
                             jobs=os.cpu_count() or 1)
    return meshes, [Row(s) for s in sigs]


def insert_sql(table, rows):
    return "INSERT INTO %s (name, sig) VALUES %s;\n" % (
        table, ",\n".join(r.values() for r in rows))


def topk(cluster, table, q, db="postgres"):
    """The two-stage top 10 (docs/postgres.md) as text: ids, names, and
    scores as the server prints a float8, the shortest text that reads
    back to the same bits (extra_float_digits 1, the default)."""
    return [tuple(r) for r in
            cluster.sql(pgutil.two_stage(table, q, 10), db=db)]


def literal(row):
    return "'%s'::phks_signature" % row.hex


# ---- load

CLIENTS = 8
SMALL = 200
# The first queries' plans take two workers whenever there are free ones
# (8 clients share max_parallel_workers = 8).
PARALLEL = ("SET parallel_setup_cost = 0; SET parallel_tuple_cost = 0; "
            "SET min_parallel_table_scan_size = 0;")


def load_seconds():
    value = float(os.environ.get("PHKS_PG_LOAD_SECONDS") or 0)
    return value if value > 0 else 60


def query_expression(qid):
    return "(SELECT sig FROM queries WHERE qid = %d)" % qid


class Client(threading.Thread):
    """A connection that runs step() again and again until the deadline.
    Any failure, the server's or a reply that does not parse, is the
    client's error and ends it."""

    def __init__(self, pg, deadline):
        super().__init__()
        self.pg, self.deadline = pg, deadline
        self.slowest = 0.0
        self.error = None

    def run(self):
        session = pgutil.Session(self.pg)
        try:
            self.start_session(session)
            while time.time() < self.deadline:
                self.step(session)
        except Exception as e:
            self.error = "%s: %s" % (type(e).__name__, e)
        session.close()

    def start_session(self, session):
        pass

    def timed(self, session, script):
        start = time.time()
        rows = session.run(script)
        self.slowest = max(self.slowest, time.time() - start)
        return [tuple(r) for r in rows]


# What a reader saw in one transaction: the query, the rows its snapshot
# held (the highest id and their count), the top 10, and the top 10
# again without parallel workers.
Answer = collections.namedtuple("Answer",
                                "qid last_id rows_seen hits hits_plain")


class Reader(Client):
    """A client that runs the top 10 of random queries, each in a
    REPEATABLE READ transaction that also reads which rows its snapshot
    holds and runs the query a second time without parallel workers."""

    def __init__(self, pg, deadline, seed, queries):
        super().__init__(pg, deadline)
        self.rng = random.Random(seed)
        self.queries = queries
        self.answers = []

    def start_session(self, session):
        session.run(PARALLEL)

    def step(self, session):
        qid = self.rng.randrange(self.queries)
        query = pgutil.two_stage("shapes", query_expression(qid), 10)
        seen = session.run("BEGIN ISOLATION LEVEL REPEATABLE READ;\n"
                           "SELECT max(id), count(*) FROM shapes;")
        hits = self.timed(session, query)
        plain = self.timed(session, "SET LOCAL "
                           "max_parallel_workers_per_gather = 0;\n" + query)
        session.run("COMMIT;")
        self.answers.append(Answer(qid, int(seen[0][0]), int(seen[0][1]),
                                   hits, plain))


class Inserter(Client):
    """A client that inserts the rows in turn, again and again: one row
    per transaction, ids from the table's sequence."""

    def __init__(self, pg, deadline, rows):
        super().__init__(pg, deadline)
        self.rows = rows
        self.ids = []

    def step(self, session):
        row = self.rows[len(self.ids) % len(self.rows)]
        got = self.timed(session, "INSERT INTO shapes (name, sig) VALUES "
                         "%s RETURNING id;" % row.values())
        self.ids.append(int(got[0][0]))


def parallel_workers_while(pg, clients):
    """The number of parallel workers running, every half second while
    the clients run."""
    session = pgutil.Session(pg)
    counts = []
    while any(c.is_alive() for c in clients):
        counts.append(int(session.run(
            "SELECT count(*) FROM pg_stat_activity "
            "WHERE backend_type = 'parallel worker';")[0][0]))
        time.sleep(0.5)
    session.close()
    return counts


def serial_answers(pg, keys):
    """The top 10 of each (qid, max id) of keys, one after another on one
    connection, without parallel workers, on the rows id <= max id."""
    script = ["SET max_parallel_workers_per_gather = 0;"]
    for qid, last in keys:
        script.append(pgutil.two_stage(
            "(SELECT * FROM shapes WHERE id <= %d) AS visible" % last,
            query_expression(qid), 10))
        script.append("\\echo --")
    answers, current = [], []
    for row in pg.sql("\n".join(script)):
        if row == ["--"]:
            answers.append(current)
            current = []
        else:
            current.append(tuple(row))
    if len(answers) != len(keys):
        raise SystemExit("%d serial answers to %d queries"
                         % (len(answers), len(keys)))
    return dict(zip(keys, answers))


def part_load():
    seconds = load_seconds()
    small = small_rows(SMALL + 8)
    entries = small[:SMALL]
    # Queries in the table (their copies tie, and only the id breaks the
    # tie) and not.
    queries = entries[::SMALL // 8] + small[SMALL:]
    pg = pgutil.Cluster(bindir, "load")
    pg.sql("CREATE EXTENSION phks;\n" + table_sql("shapes") +
           insert_sql("shapes", entries) +
           "CREATE TABLE queries (qid int PRIMARY KEY, "
           "sig phks_signature NOT NULL);\n"
           "INSERT INTO queries VALUES %s;\nANALYZE shapes, queries;" %
           ",\n".join("(%d, '%s')" % (i, q.hex)
                      for i, q in enumerate(queries)))
    plan = pg.sql(PARALLEL + "EXPLAIN " +
                  pgutil.two_stage("shapes", query_expression(0), 10))
    check(any("Gather" in r[0] for r in plan),
          "the clients' first query has a parallel plan: %s" % plan)
    print("%d rows, %d queries; load for %g s (%.1f s)"
          % (SMALL, len(queries), seconds, time.time() - t0))

    deadline = time.time() + seconds
    readers = [Reader(pg, deadline, i, len(queries)) for i in range(CLIENTS)]
    inserter = Inserter(pg, deadline, entries)
    clients = readers + [inserter]
    for client in clients:
        client.start()
    workers = parallel_workers_while(pg, clients)
    for client in clients:
        client.join()

    errors = [c.error for c in clients if c.error]
    check(not errors, "no client meets an error: %s" % errors)
    answers = [a for r in readers for a in r.answers]
    print("load: %d queries (%d transactions) by %d clients, %d inserts, "
          "%d errors; slowest query %.3f s, slowest insert %.3f s"
          % (2 * len(answers), len(answers), CLIENTS, len(inserter.ids),
             len(errors), max(r.slowest for r in readers), inserter.slowest))
    print("parallel workers running: %.1f on average, %d at most"
          % (sum(workers) / max(1, len(workers)), max(workers, default=0)))
    check(max(workers, default=0) > 0, "parallel plans ran under the load")

    # One inserter committing in id order: a snapshot that saw id M saw
    # every row up to M and none after; its count confirms it.
    ids = [int(r[0]) for r in pg.sql("SELECT id FROM shapes ORDER BY id;")]
    check(ids == list(range(1, SMALL + 1)) + inserter.ids,
          "the table holds the first rows and every insert, in id order")
    bad = [a[:3] for a in answers
           if a.rows_seen != bisect.bisect_right(ids, a.last_id)]
    check(not bad, "each snapshot held the rows up to its max(id): %s"
          % bad[:5])
    bad = [a[:2] for a in answers if a.hits != a.hits_plain or
           len(a.hits) != 10]
    check(not bad, "the parallel and the plain plan agree in each "
          "snapshot: %s" % bad[:5])

    start = time.time()
    keys = sorted({(a.qid, a.last_id) for a in answers})
    serial = serial_answers(pg, keys)
    bad = [(a.qid, a.last_id, a.hits[:2], serial[a.qid, a.last_id][:2])
           for a in answers if a.hits != serial[a.qid, a.last_id]]
    check(not bad, "every answer equals the serial query on its snapshot's "
          "rows: %s" % bad[:3])
    print("%d answers (%d distinct queries and snapshots) checked against "
          "the serial ones, recomputed in %.1f s"
          % (len(answers), len(keys), time.time() - start))
    pg.stop()


# ---- kill

COMMITTED = 100


def postmaster_pid(pg):
    with open(os.path.join(pg.data, "postmaster.pid")) as f:
        return int(f.readline())


def wait_until_active(pg, pid, marker, timeout=30):
    """Waits until backend pid runs a statement holding marker."""
    end = time.time() + timeout
    while time.time() < end:
        rows = pg.sql("SELECT state, query LIKE '%%%s%%' FROM "
                      "pg_stat_activity WHERE pid = %d;" % (marker, pid))
        if rows == [["active", "t"]]:
            return
        time.sleep(0.05)
    raise SystemExit("backend %d never ran the statement" % pid)


def wait_for_connections(pg, timeout=60):
    """Seconds until the server accepts a connection and runs a query."""
    start = time.time()
    while time.time() - start < timeout:
        _, _, rc = pg.sql("SELECT 1;", check=False)
        if rc == 0:
            return time.time() - start
        time.sleep(0.02)
    raise SystemExit("the server did not come back in %d s" % timeout)


def part_kill():
    rows = small_rows(SMALL)
    meshes, real = real_meshes(30)
    slow = list(zip(meshes, real))[-6:]
    pg = pgutil.Cluster(bindir, "kill")
    pg.sql("CREATE EXTENSION phks;\n" + table_sql("shapes"))
    postmaster = postmaster_pid(pg)
    started = pg.sql("SELECT pg_postmaster_start_time();")[0][0]

    session = pgutil.Session(pg)
    pid = int(session.run("SELECT pg_backend_pid();")[0][0])
    acknowledged = {}
    for row in rows[:COMMITTED]:
        got = session.run("BEGIN;\nINSERT INTO shapes (name, sig) VALUES %s "
                          "RETURNING id;\nCOMMIT;" % row.values())
        acknowledged[int(got[0][0])] = row
    # The transaction to kill: rows inserted, then a statement that
    # computes signatures in the server for seconds.
    doomed_rows = rows[COMMITTED:COMMITTED + 5]
    doomed = session.run("BEGIN;\nINSERT INTO shapes (name, sig) VALUES %s "
                         "RETURNING id;" % ", ".join(r.values()
                                                     for r in doomed_rows))
    values = []
    for mesh, row in slow:
        with open(mesh, "rb") as f:
            values.append("('%s', decode('%s', 'hex'))" % (row.name,
                                                          f.read().hex()))
    session.send("INSERT INTO shapes (name, sig) SELECT name, "
                 "phks_signature_from_mesh(mesh) FROM (VALUES %s) AS m "
                 "(name, mesh) RETURNING id;" % ", ".join(values))
    wait_until_active(pg, pid, "phks_signature_from_mesh")
    time.sleep(1)
    state = pg.sql("SELECT state FROM pg_stat_activity WHERE pid = %d;"
                   % pid)
    os.kill(pid, signal.SIGKILL)
    killed = time.time()
    check(state == [["active"]], "killed mid-statement: %s" % state)
    try:
        session.receive()
        check(False, "the killed statement returned")
    except pgutil.SQLError as e:
        check("server closed the connection unexpectedly" in str(e),
              "the client lost its connection: %s" % e)
    session.close()
    recovery = wait_for_connections(pg)
    print("killed backend %d 1 s into a statement of %d signatures, in a "
          "transaction of %d rows; the server accepted connections again "
          "%.2f s later" % (pid, len(slow), len(doomed), recovery))

    with open(pg.log) as f:
        log = f.read()
    check("was terminated by signal 9" in log and
          "all server processes terminated; reinitializing" in log,
          "the postmaster saw the kill and restarted the backends")
    check(postmaster_pid(pg) == postmaster, "the same postmaster")
    print("pg_postmaster_start_time %s, then %s" % (
        started, pg.sql("SELECT pg_postmaster_start_time();")[0][0]))

    found = pg.sql("SELECT id, name, md5(sig::bytea) FROM shapes "
                   "ORDER BY id;")
    want = [[str(i), acknowledged[i].name, acknowledged[i].md5]
            for i in sorted(acknowledged)]
    check(found == want, "every acknowledged row with its bytes, and no "
          "other: %d rows found of %d committed" % (len(found), len(want)))
    check(not {int(r[0]) for r in doomed} & {int(r[0]) for r in found},
          "none of the killed transaction's rows")
    check(pg.sql("SELECT bool_and(key::text = phks_key(sig)::text) FROM "
                 "shapes;") == [["t"]], "each key is its signature's")
    print("%d rows committed, %d found, with their bytes"
          % (len(want), len(found)))

    pg.sql(table_sql("fresh") + "INSERT INTO fresh (id, name, sig) VALUES "
           "%s;\nANALYZE shapes, fresh;" % ",\n".join(
               acknowledged[i].values(i) for i in sorted(acknowledged)))
    for q in rows[:COMMITTED:20] + doomed_rows[:3] + real[:2]:
        check(topk(pg, "shapes", literal(q)) == topk(pg, "fresh", literal(q)),
              "top 10 of %s after the kill equals a fresh table's" % q.name)
    got = pg.sql(insert_sql("shapes", rows[-1:]).rstrip(";\n") +
                 " RETURNING id;")
    check(int(got[0][0]) > max(acknowledged), "inserts go on: id %s" % got)
    pg.stop()


# ---- dump

ROW_BYTES = ("SELECT id, name, md5(sig::bytea), md5(phks_key_send(key)), "
             "length(sig::bytea) + length(phks_key_send(key)) FROM shapes "
             "ORDER BY id;")


def as_postgres(pg, tool, *args):
    """Runs a client program of the server's as the postgres user, on the
    cluster's socket."""
    cmd = pg.as_postgres + [os.path.join(bindir, tool), "-h", pg.sock, "-p",
                            str(pg.port), "-U", "postgres"] + list(args)
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit("%s failed:\n%s" % (" ".join(cmd), out.stderr))


def part_dump():
    rows = small_rows(SMALL) + real_meshes(30)[1]
    pg = pgutil.Cluster(bindir, "dump")
    pg.sql("CREATE EXTENSION phks;\n" + table_sql("shapes") +
           insert_sql("shapes", rows) + "ANALYZE shapes;")
    plain = os.path.join(pg.root, "shapes.sql")
    custom = os.path.join(pg.root, "shapes.dump")
    as_postgres(pg, "pg_dump", "-d", "postgres", "-f", plain)
    as_postgres(pg, "pg_dump", "-d", "postgres", "-Fc", "-f", custom)
    pg.sql("CREATE DATABASE plain;\nCREATE DATABASE custom;")
    as_postgres(pg, "psql", "-X", "-q", "-v", "ON_ERROR_STOP=1", "-d",
                "plain", "-f", plain)
    as_postgres(pg, "pg_restore", "--exit-on-error", "-d", "custom", custom)
    with open(plain) as f:
        check("COPY public.shapes (id, name, sig) FROM stdin;" in f.read(),
              "the dump leaves the keys out (a generated column)")
    print("dumped %d rows: plain %d bytes, custom %d bytes (%.1f s)"
          % (len(rows), os.path.getsize(plain), os.path.getsize(custom),
             time.time() - t0))

    original = pg.sql(ROW_BYTES)
    check(len(original) == len(rows), "%d rows" % len(original))
    layout = ("SELECT attstorage FROM pg_attribute WHERE attrelid = "
              "'shapes'::regclass AND attname = 'sig';"
              "SELECT last_value FROM shapes_id_seq;")
    for db in ("plain", "custom"):
        check(pg.sql(ROW_BYTES, db=db) == original,
              "%s restore: every row's id, name, signature and key bytes"
              % db)
        check(pg.sql(layout, db=db) == pg.sql(layout),
              "%s restore: the signatures' storage and the sequence" % db)
    compared = 2 * sum(int(r[4]) for r in original)
    print("%d rows and %d bytes of signatures and keys compared"
          % (len(original), compared))
    for q in rows[::40]:
        want = topk(pg, "shapes", literal(q))
        check(all(topk(pg, "shapes", literal(q), db) == want
                  for db in ("plain", "custom")),
              "top 10 of %s equal on the three databases" % q.name)
    pg.stop()


# ---- replica


def wait_for_replay(replica, lsn, timeout=60):
    """Waits until replica has replayed the primary's WAL up to lsn."""
    session = pgutil.Session(replica)
    end = time.time() + timeout
    while session.run("SELECT pg_last_wal_replay_lsn() >= '%s'::pg_lsn;"
                      % lsn) != [["t"]]:
        if time.time() > end:
            raise SystemExit("the replica did not replay %s in %d s"
                             % (lsn, timeout))
        time.sleep(0.001)
    session.close()


def part_replica():
    rows = small_rows(SMALL) + real_meshes(30)[1]
    before, after = rows[:SMALL // 2], rows[SMALL // 2:]
    primary = pgutil.Cluster(bindir, "primary")
    primary.sql("CREATE EXTENSION phks;\n" + table_sql("shapes") +
                insert_sql("shapes", before) + "ANALYZE shapes;")
    replica = pgutil.Cluster(bindir, "replica", primary=primary)
    print("replica of %d rows up (%.1f s)" % (len(before), time.time() - t0))

    session = pgutil.Session(primary)
    for row in after:
        session.run(insert_sql("shapes", [row]))
    committed = time.time()
    lsn = session.run("SELECT pg_current_wal_lsn();")[0][0]
    session.close()
    wait_for_replay(replica, lsn)
    print("%d rows inserted one per transaction; the replica had replayed "
          "the last %.3f s after its commit" % (len(after),
                                                time.time() - committed))
    check(primary.sql("SELECT state FROM pg_stat_replication;") ==
          [["streaming"]], "one replica, streaming")

    check(replica.sql("SELECT pg_is_in_recovery();") == [["t"]],
          "the replica is in recovery")
    check(replica.sql(ROW_BYTES) == primary.sql(ROW_BYTES) and
          len(primary.sql(ROW_BYTES)) == len(rows),
          "the replica holds every row, byte for byte")
    for q in rows[::25]:
        check(topk(replica, "shapes", literal(q)) ==
              topk(primary, "shapes", literal(q)),
              "top 10 of %s equal on the replica" % q.name)
    err = replica.error(insert_sql("shapes", rows[:1]))
    check("read-only transaction" in err, "the replica refuses an insert: %s"
          % err.strip())
    err = replica.error("CREATE TABLE t (i int);")
    check("read-only transaction" in err, "and a table: %s" % err.strip())
    print("the replica refuses writes: " + err.strip().splitlines()[0])
    replica.stop()
    primary.stop()


PARTS = {"load": part_load, "kill": part_kill, "dump": part_dump,
         "replica": part_replica}
if part not in PARTS:
    raise SystemExit("PART is one of %s" % ", ".join(PARTS))
PARTS[part]()
print("%d failures (%.1f s)" % (len(failures), time.time() - t0))
sys.exit(1 if failures else 0)
