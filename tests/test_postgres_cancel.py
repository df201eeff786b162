#!/usr/bin/env python3
"""test_postgres_cancel.py BUILD_ROOT PART

The PostgreSQL extension's long work stops when asked, and its limits hold
(docs/postgres.md, "Limits, cancels and timeouts"), on a throwaway cluster:

  limits  phks.max_vertices and phks.max_mesh_size refuse a mesh above
          them with a message naming the setting (a gzip bomb included);
          a role that is not a superuser cannot raise them.
  mesh    a long phks_signature_from_mesh (a generated mesh of 80,400
          vertices, HKS-simp's path) stops within a second of
          pg_cancel_backend and of statement_timeout, at five points
          spread over its run.
  scan    a long scan (ORDER BY sig <~> q over a table of 18,000
          signatures) likewise.

Each stop is timed from just before the cancel is sent (or from the
statement's start plus its timeout) to psql's exit: that includes psql's
own start, so the figures are upper bounds.
"""
import gzip
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import pgutil  # noqa: E402

build_root, part = sys.argv[1], sys.argv[2]
STOP_WITHIN = 1.0  # seconds: the promise
POINTS = (0.1, 0.3, 0.5, 0.7, 0.8)  # fractions of the uninterrupted run

failures = pgutil.failures
check = pgutil.check


def psql_command(cluster, script):
    return [os.path.join(cluster.bindir, "psql"), "-X", "-q", "-A", "-t",
            "-v", "ON_ERROR_STOP=1", "-h", cluster.sock, "-p",
            str(cluster.port), "-U", "postgres", "-d", "postgres", "-c",
            script]


def start(cluster, script):
    """script in its own psql, named phks_long in pg_stat_activity (its
    parallel workers carry the name too: the cancel goes to the client's
    backend, the leader)."""
    return subprocess.Popen(psql_command(cluster,
                                         "SET application_name = phks_long; "
                                         + script),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)


def wait_until_running(cluster):
    """Until the long statement is seen active (its psql has connected)."""
    for _ in range(200):
        rows = cluster.sql("SELECT count(*) FROM pg_stat_activity WHERE "
                           "application_name = 'phks_long' AND "
                           "backend_type = 'client backend' AND "
                           "state = 'active';")
        if rows[0][0] == "1":
            return
        time.sleep(0.01)
    raise SystemExit("the long statement never started")


def uninterrupted(cluster, script):
    t0 = time.time()
    out = subprocess.run(psql_command(cluster, script), capture_output=True,
                         text=True)
    took = time.time() - t0
    if out.returncode != 0:
        raise SystemExit("%s failed: %s" % (script[:200], out.stderr))
    return took


def cancel_at(cluster, script, delay):
    """Seconds from the cancel to the statement's end, and psql's stderr."""
    proc = start(cluster, script)
    wait_until_running(cluster)
    time.sleep(delay)
    sent = time.time()
    cluster.sql("SELECT pg_cancel_backend(pid) FROM pg_stat_activity "
                "WHERE application_name = 'phks_long' AND "
                "backend_type = 'client backend';")
    _, err = proc.communicate()
    return time.time() - sent, err, proc.returncode


def timeout_at(cluster, script, timeout):
    """Seconds from statement_timeout's expiry to the statement's end."""
    t0 = time.time()
    out = subprocess.run(psql_command(
        cluster, "SET statement_timeout = %d; %s" % (int(timeout * 1000),
                                                    script)),
        capture_output=True, text=True)
    return time.time() - t0 - timeout, out.stderr, out.returncode


def sweep(cluster, name, script):
    """Cancels and timeouts at POINTS of the uninterrupted run (the
    faster of two, the second with the data in the cache)."""
    full = min(uninterrupted(cluster, script) for _ in range(2))
    print("%s: %.2f s uninterrupted" % (name, full))
    print("%-6s %8s %12s %12s" % ("", "at (s)", "cancel (s)", "timeout (s)"))
    worst = 0.0
    for fraction in POINTS:
        at = fraction * full
        cancel, err, rc = cancel_at(cluster, script, at)
        check(rc != 0 and "canceling statement due to user request" in err,
              "%s: cancelled at %.2f s: rc %d, %s" % (name, at, rc,
                                                      err.strip()))
        late, err, rc = timeout_at(cluster, script, at)
        check(rc != 0 and "statement timeout" in err,
              "%s: timeout at %.2f s: rc %d, %s" % (name, at, rc,
                                                    err.strip()))
        print("%-6s %8.2f %12.3f %12.3f" % (name, at, cancel, late))
        check(cancel < STOP_WITHIN, "%s: stopped %.3f s after the cancel at "
              "%.2f s" % (name, cancel, at))
        check(late < STOP_WITHIN, "%s: stopped %.3f s after the timeout at "
              "%.2f s" % (name, late, at))
        worst = max(worst, cancel, late)
    print("%s: every stop within %.3f s" % (name, worst))


def mesh_file(cluster, name, n, seed):
    """A generated mesh in the cluster's folder, readable by the server."""
    path = os.path.join(cluster.root, name)
    pgutil.bumpy_sphere_off(path, seed, n=n)
    os.chmod(path, 0o644)
    return path


# The administrator's setting in the limits part's server configuration.
ADMIN_MAX_VERTICES = 1199


def test_limits(cluster):
    path = mesh_file(cluster, "small.off", 24, 1)  # 1,200 vertices
    size = os.path.getsize(path)
    read = "phks_signature_from_mesh(pg_read_binary_file('%s'))" % path
    # The settings exist once the module is loaded (by LOAD, or by the
    # first call of one of its functions).
    rows = cluster.sql("LOAD 'phks'; SELECT name, setting, boot_val, unit "
                       "FROM pg_settings WHERE name LIKE 'phks.%' "
                       "ORDER BY name;")
    check(rows == [["phks.max_mesh_size", "262144", "262144", "kB"],
                   ["phks.max_vertices", str(ADMIN_MAX_VERTICES), "2000000",
                    ""]], "the settings: %s" % rows)

    err = cluster.error("\\set VERBOSITY verbose\nSELECT %s;" % read)
    check("54000" in err and
          "1200 vertices, more than the limit of 1199" in err and
          "phks.max_vertices is 1199" in err, "vertex limit: " + err)
    check(cluster.sql("SET phks.max_vertices = 1200; SELECT %s IS NOT NULL;"
                      % read) == [["t"]], "exactly at the vertex limit")

    err = cluster.error("SET phks.max_mesh_size = '%dB'; SELECT %s;" %
                        (size - 1024, read))
    check("bytes of mesh data, more than the limit" in err and
          "phks.max_mesh_size" in err, "size limit: " + err)

    bomb = os.path.join(cluster.root, "bomb.off.gz")
    with open(bomb, "wb") as f:
        f.write(gzip.compress(b"\0" * (64 << 20), 1))
    os.chmod(bomb, 0o644)
    err = cluster.error("SET phks.max_mesh_size = '1MB'; SELECT "
                        "phks_signature_from_mesh(pg_read_binary_file('%s'));"
                        % bomb)
    check("inflates to more than 1048576 bytes" in err and
          "phks.max_mesh_size is 1024 kB" in err, "gzip bomb: " + err)

    # A client cannot raise the limit, whether the module is loaded
    # before its SET or after (a placeholder's value is then dropped).
    cluster.sql("CREATE ROLE phks_client;")
    err = cluster.error("LOAD 'phks'; SET ROLE phks_client; "
                        "SET phks.max_vertices = 10000000;")
    check("permission denied to set parameter" in err,
          "a client raising the loaded limit: " + err)
    with open(path, "rb") as f:
        as_bytes = "phks_signature_from_mesh('\\x%s')" % f.read().hex()
    err = cluster.error("SET ROLE phks_client; SET phks.max_vertices = "
                        "10000000; SELECT %s;" % as_bytes)
    check("permission denied to set parameter" in err and
          "more than the limit of 1199" in err,
          "a client raising the limit before the load: " + err)
    print("limits: the settings, exact limits, a gzip bomb and a client "
          "checked")


def test_mesh(cluster):
    path = mesh_file(cluster, "big.off", 200, 3)  # 80,400 vertices
    sweep(cluster, "mesh", "SELECT phks_signature_from_mesh("
          "pg_read_binary_file('%s')) IS NOT NULL;" % path)


def test_scan(cluster):
    paths = [mesh_file(cluster, "scan%d.off" % i, 24, i) for i in range(6)]
    values = ", ".join("(phks_signature_from_mesh(pg_read_binary_file('%s')))"
                       % p for p in paths)
    cluster.sql("CREATE TABLE shapes (id bigint PRIMARY KEY, "
                "sig phks_signature NOT NULL) "
                "WITH (toast_tuple_target = 8160); "
                "CREATE TABLE sigs (sig phks_signature); "
                "INSERT INTO sigs VALUES %s; "
                "INSERT INTO shapes SELECT row_number() OVER (), sig "
                "FROM generate_series(1, 3000), sigs; "
                "VACUUM ANALYZE shapes;" % values)
    sweep(cluster, "scan", "SELECT id FROM shapes ORDER BY sig <~> "
          "(SELECT sig FROM sigs LIMIT 1), id LIMIT 10;")


def main():
    bindir = pgutil.pg_bindir()
    pgutil.install_extension(build_root)
    settings = ["phks.max_vertices=%d" % ADMIN_MAX_VERTICES] \
        if part == "limits" else []
    cluster = pgutil.Cluster(bindir, name="cancel", settings=settings)
    cluster.sql("CREATE EXTENSION phks;")
    started = cluster.sql("SELECT pg_postmaster_start_time();")
    {"limits": test_limits, "mesh": test_mesh, "scan": test_scan}[part](
        cluster)
    check(cluster.sql("SELECT pg_postmaster_start_time();") == started,
          "the server restarted (a backend crashed)")
    cluster.stop()
    if failures:
        print("%d failure(s)" % len(failures))
        sys.exit(1)


main()
