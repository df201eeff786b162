"""pgutil.py - throwaway PostgreSQL clusters for the extension's tests and
benchmark (tests/test_postgres.py, tests/test_postgres_shards.py,
bench/bench_pg.sh). Standard library only.

install_extension() copies the build's phks.so, libphks.so.N, phks.control
and phks--V.sql into the server's own folders (pg_config --pkglibdir and
--sharedir/extension): phks.so's RUNPATH starts with $ORIGIN, so the server
finds the library beside it, whatever the build folder's permissions.
Cluster() runs initdb and pg_ctl as the `postgres` user when run as root
(the server refuses root) in a temporary folder, on a free port of
127.0.0.1 and a private socket folder; stop() (and exit, and SIGTERM/SIGINT)
stops it and removes the folder. Cluster(..., primary=p) is a streaming
replica of cluster p instead (pg_basebackup -R), stopped and removed
likewise. Session() is one long-lived psql connection fed through a pipe,
as a client's would be.
"""
import atexit
import glob
import os
import shutil
import signal
import socket
import struct
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor

SKIP = 77  # meson's exit code for a skipped test


def skip(message):
    print("SKIP: " + message)
    sys.exit(SKIP)


def pg_config(flag):
    exe = shutil.which("pg_config")
    if not exe:
        return None
    out = subprocess.run([exe, flag], capture_output=True, text=True)
    return out.stdout.strip() if out.returncode == 0 else None


def pg_bindir():
    bindir = pg_config("--bindir")
    if not bindir or not os.path.exists(os.path.join(bindir, "initdb")):
        skip("pg_config or initdb not found (Debian: apt-get install "
             "postgresql postgresql-server-dev-15)")
    return bindir


def install_extension(build_root):
    """Copies the build's extension into the server's folders."""
    module = os.path.join(build_root, "postgres", "phks.so")
    if not os.path.exists(module):
        skip("the extension was not built (postgres/ needs pg_config and "
             "the server headers)")
    pkglibdir = pg_config("--pkglibdir")
    extdir = os.path.join(pg_config("--sharedir"), "extension")
    for d in (pkglibdir, extdir):
        if not os.access(d, os.W_OK):
            skip("%s is not writable: the test installs the extension "
                 "there (run it as root, as CI does)" % d)
    libs = glob.glob(os.path.join(build_root, "lib", "libphks.so.*"))
    soname = [p for p in libs if os.path.islink(p)
              and os.path.basename(p).count(".") == 2]
    if not soname:
        raise SystemExit("no libphks.so.N in %s/lib" % build_root)
    for src, dst in [(module, os.path.join(pkglibdir, "phks.so")),
                     (soname[0], os.path.join(pkglibdir,
                                              os.path.basename(soname[0])))]:
        tmp = dst + ".tmp"
        shutil.copyfile(os.path.realpath(src), tmp)
        os.chmod(tmp, 0o755)
        os.replace(tmp, dst)
    ext = os.path.join(build_root, "postgres")
    for f in glob.glob(os.path.join(ext, "phks.control")) + \
            glob.glob(os.path.join(ext, "phks--*.sql")):
        shutil.copyfile(f, os.path.join(extdir, os.path.basename(f)))


def free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


_clusters = []


def _cleanup(*_):
    for c in list(_clusters):
        c.stop()
    if _:
        sys.exit(1)


atexit.register(_cleanup)
signal.signal(signal.SIGTERM, _cleanup)
signal.signal(signal.SIGINT, _cleanup)


# What a test found wrong: check() records and prints each failure, and
# the test exits 1 when the list is not empty.
failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL: " + what)


class SQLError(Exception):
    pass


class Cluster:
    def __init__(self, bindir, name="pg", settings=(), primary=None):
        self.bindir = bindir
        self.root = tempfile.mkdtemp(prefix="phks-%s-" % name)
        _clusters.append(self)
        self.as_postgres = []
        if os.geteuid() == 0:
            import pwd
            pw = pwd.getpwnam("postgres")
            os.chown(self.root, pw.pw_uid, pw.pw_gid)
            self.as_postgres = ["runuser", "-u", "postgres", "--"]
        self.data = os.path.join(self.root, "data")
        self.sock = self.root
        self.port = free_port()
        self.log = os.path.join(self.root, "server.log")
        env = ["env", "OPENBLAS_NUM_THREADS=1", "LC_ALL=C"]
        if primary is None:
            self._run(self.as_postgres + env +
                      [os.path.join(bindir, "initdb"), "-D", self.data,
                       "-U", "postgres", "--auth=trust", "-E", "UTF8",
                       "--no-sync"])
        else:
            # The primary's files as of a fast checkpoint (a spread one
            # would take minutes), the WAL written meanwhile, and (-R)
            # standby.signal with primary_conninfo: the server starts as a
            # hot standby that replays the primary's WAL as it streams in.
            # initdb's pg_hba.conf lets 127.0.0.1 replicate (trust).
            self._run(self.as_postgres + env +
                      [os.path.join(bindir, "pg_basebackup"), "-D",
                       self.data, "-d", primary.conninfo(), "-R",
                       "-X", "stream", "--checkpoint=fast", "--no-sync"])
        opts = "-c listen_addresses=127.0.0.1 -p %d -k %s -c fsync=off" % (
            self.port, self.sock)
        for s in settings:
            opts += " -c " + s
        # OPENBLAS_NUM_THREADS=1: OpenBLAS starts no thread pool in the
        # backends (docs/postgres.md).
        self._run(self.as_postgres + env +
                  [os.path.join(bindir, "pg_ctl"), "-D", self.data, "-l",
                   self.log, "-o", opts, "-w", "start"])
        self.running = True

    def _run(self, cmd):
        out = subprocess.run(cmd, capture_output=True, text=True)
        if out.returncode != 0:
            raise SystemExit("%s failed:\n%s%s" % (" ".join(cmd), out.stdout,
                                                   out.stderr))

    def stop(self):
        if self in _clusters:
            _clusters.remove(self)
        if getattr(self, "running", False):
            subprocess.run(self.as_postgres +
                           [os.path.join(self.bindir, "pg_ctl"), "-D",
                            self.data, "-m", "immediate", "-w", "stop"],
                           capture_output=True)
            self.running = False
        shutil.rmtree(self.root, ignore_errors=True)

    def conninfo(self):
        return "host=127.0.0.1 port=%d user=postgres dbname=postgres" % \
            self.port

    def psql(self, db="postgres"):
        """The psql command line for database db: unaligned rows without
        headers, stopping at the first error."""
        return [os.path.join(self.bindir, "psql"), "-X", "-q", "-A", "-t",
                "-v", "ON_ERROR_STOP=1", "-h", self.sock, "-p",
                str(self.port), "-U", "postgres", "-d", db]

    def sql(self, script, check=True, db="postgres"):
        """Runs script through psql (stdin); returns rows of '|'-separated
        fields. With check=False returns (rows, stderr, returncode). Bytes
        that are not UTF-8 in psql's output come back as U+FFFD."""
        out = subprocess.run(self.psql(db) + ["-f", "-"], input=script,
                             capture_output=True, text=True,
                             errors="replace")
        rows = [line.split("|") for line in out.stdout.splitlines()]
        if check:
            if out.returncode != 0:
                raise SQLError(out.stderr.strip() + "\n-- in:\n" +
                               script[:2000])
            return rows
        return rows, out.stderr, out.returncode

    def error(self, script, db="postgres"):
        """Runs script, which must fail; returns psql's stderr."""
        rows, err, rc = self.sql(script, check=False, db=db)
        if rc == 0:
            raise AssertionError("no error from: " + script[:300])
        if "server closed the connection" in err or \
                "terminated abnormally" in err:
            raise AssertionError("the backend crashed on: " + script[:300])
        return err


class Session:
    """One psql process on a pipe: a connection that lasts from script to
    script, as a client's does. run(script) returns the script's rows once
    it has run; send() and receive() split that, for a script to kill or
    time from outside. An error ends the session (ON_ERROR_STOP): SQLError
    with psql's stderr."""
    END = "-- end of script --"

    def __init__(self, cluster, db="postgres"):
        self.proc = subprocess.Popen(cluster.psql(db), stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True)

    def send(self, script):
        try:
            self.proc.stdin.write(script + "\n\\echo " + self.END + "\n")
            self.proc.stdin.flush()
        except BrokenPipeError:
            self._failed()

    def receive(self):
        """The rows up to the end of the script sent: psql prints its end
        mark only once every statement before it succeeded."""
        rows = []
        for line in iter(self.proc.stdout.readline, ""):
            if line.rstrip("\n") == self.END:
                return rows
            rows.append(line.rstrip("\n").split("|"))
        self._failed()

    def run(self, script):
        self.send(script)
        return self.receive()

    def _failed(self):
        try:
            self.proc.stdin.close()
        except BrokenPipeError:
            pass
        err = self.proc.stderr.read()
        self.proc.wait()
        raise SQLError(err.strip() or "psql exited (%d)" %
                       self.proc.returncode)

    def close(self):
        if self.proc.poll() is None:
            self.proc.stdin.close()
            self.proc.wait()
        self.proc.stdout.close()
        self.proc.stderr.close()


def bumpy_sphere_off(path, seed, n=24):
    """A sphere with a few smooth bumps (seeded), as an OFF file: meshes for
    when the shared PSB meshes are absent."""
    import math
    import random
    rng = random.Random(seed)
    bumps = [(rng.uniform(0, math.pi), rng.uniform(0, 2 * math.pi),
              rng.uniform(0.2, 0.8), rng.uniform(0.2, 0.6))
             for _ in range(1 + seed % 5)]
    ax = [1.0, rng.uniform(0.6, 1.4), rng.uniform(0.6, 1.4)]
    verts = []
    for i in range(n + 1):
        th = math.pi * i / n
        for j in range(2 * n):
            ph = 2 * math.pi * j / (2 * n)
            r = 1.0
            for (bt, bp, h, w) in bumps:
                d = math.acos(max(-1.0, min(1.0, math.sin(th) * math.sin(bt) *
                                            math.cos(ph - bp) +
                                            math.cos(th) * math.cos(bt))))
                r += h * math.exp(-(d / w) ** 2)
            verts.append((ax[0] * r * math.sin(th) * math.cos(ph),
                          ax[1] * r * math.sin(th) * math.sin(ph),
                          ax[2] * r * math.cos(th)))
    faces = []
    m = 2 * n
    for i in range(n):
        for j in range(m):
            a, b = i * m + j, i * m + (j + 1) % m
            c, d = a + m, b + m
            faces.append((a, c, b))
            faces.append((b, c, d))
    with open(path, "w") as f:
        f.write("OFF\n%d %d 0\n" % (len(verts), len(faces)))
        for v in verts:
            f.write("%.9g %.9g %.9g\n" % v)
        for t in faces:
            f.write("3 %d %d %d\n" % t)


def test_meshes(shared, workdir, count):
    """count mesh files: the smallest PSB meshes of the shared data, or
    generated ones when it is absent. Returns (paths, source)."""
    psb = os.path.join(shared or "", "psb")
    if shared and os.path.isdir(psb):
        files = sorted(glob.glob(os.path.join(psb, "*.off.gz")),
                       key=lambda p: (os.path.getsize(p), p))[:count]
        return sorted(files, key=lambda p: int(os.path.basename(p)
                                               .split(".")[0])), "psb"
    os.makedirs(workdir, exist_ok=True)
    paths = []
    for i in range(count):
        p = os.path.join(workdir, "gen%02d.off" % i)
        if not os.path.exists(p):
            bumpy_sphere_off(p, i)
        paths.append(p)
    print("shared meshes absent: %d generated meshes" % count)
    return paths, "generated"


def built_at(phks):
    """When the tool or the library it loads (build/lib) was last built:
    a cached signature older than that may hold another version's
    numbers."""
    lib = glob.glob(os.path.join(os.path.dirname(os.path.abspath(phks)),
                                 "..", "..", "lib", "libphks.so*"))
    return max(os.path.getmtime(p) for p in [phks] + lib)


def small_meshes(workdir, count):
    """count distinct small meshes (seeded bumpy spheres of 312 vertices,
    0.1 s a signature, 4 to 8 features), as OFF files: many rows' worth of
    signatures made in seconds."""
    os.makedirs(workdir, exist_ok=True)
    paths = []
    for i in range(count):
        p = os.path.join(workdir, "small%03d.off" % i)
        if not os.path.exists(p):
            bumpy_sphere_off(p, i, n=12)
        paths.append(p)
    return paths


def signatures(phks, meshes, cache, extra_args=(), jobs=1):
    """The tool's signature blob of each mesh (phks signature MESH -o X),
    cached in cache/ under the mesh's base name, made again when the tool
    or its library is newer; jobs tool processes at a time. Returns the
    .sig paths."""
    os.makedirs(cache, exist_ok=True)
    tag = "-".join(a.strip("-") for a in extra_args)
    newest = built_at(phks)

    def make(m):
        base = os.path.basename(m).split(".")[0]
        sig = os.path.join(cache, base + (("-" + tag) if tag else "") +
                           ".sig")
        if not os.path.exists(sig) or os.path.getmtime(sig) < newest:
            r = subprocess.run([phks] + list(extra_args) +
                               ["signature", m, "-o", sig + ".tmp"],
                               capture_output=True, text=True,
                               env=dict(os.environ, OPENBLAS_NUM_THREADS="1"))
            if r.returncode != 0:
                raise SystemExit("phks signature %s: %s" % (m, r.stderr))
            os.replace(sig + ".tmp", sig)
        return sig

    with ThreadPoolExecutor(max_workers=jobs) as pool:
        return list(pool.map(make, meshes))


def tool_db(phks, path, files):
    """A new database at path (any old one removed) of the tool's
    signatures of files, in order (ids 1..n), duplicates kept."""
    for f in (path, path + "-wal", path + "-shm"):
        if os.path.exists(f):
            os.remove(f)
    r = subprocess.run([phks, "db", "add", path, "-j", "1",
                        "--allow-duplicates"] + list(files),
                       capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit("phks db add: " + r.stderr)


def blob_format(blob):
    """The format number of a signature blob (docs/formats.md)."""
    return struct.unpack_from("<H", blob, 4)[0]


def header_size(fmt):
    """Bytes before the scales in a signature blob of format fmt: format
    1's 52, the margin and scaling fields from format 2 on, then one
    4-byte field more in each of formats 3 to 6 (docs/formats.md)."""
    return 52 + (12 if fmt >= 2 else 0) + (4 if fmt >= 3 else 0) + \
        (4 if fmt >= 4 else 0) + (4 if fmt >= 5 else 0) + \
        (4 if fmt >= 6 else 0)


def hexfile(path):
    with open(path, "rb") as f:
        return f.read().hex()


def two_stage(table, q, k, by="key"):
    """phks_db_query's top k as SQL (docs/postgres.md): the best max(k, 32)
    rows of table by <#> of column `by` (the table's phks_key column, or
    its signatures) against q (a SQL expression), re-ranked by <~>, ties by
    id. Rows of (id, name, score)."""
    return ("SELECT id, name, sig <~> q AS score FROM "
            "(SELECT id, name, sig, q FROM %s, (SELECT %s AS q) AS query "
            "ORDER BY %s <#> q, id LIMIT greatest(%d, 32)) AS shortlist "
            "ORDER BY score, id LIMIT %d;" % (table, q, by, k, k))


def literal(path):
    """A signature file as a SQL constant."""
    return "'%s'::phks_signature" % hexfile(path)


# phks_db_query's top k over a table partitioned into postgres_fdw shards
# with a LIMIT on every shard, so that each sends only its own shortlist
# (docs/scale.md): the global shortlist by <#> is among the shards' own,
# and <~> re-ranks it. The tests and bench/bench_pg.py create it on the
# coordinator.
def shard_topk(by="key"):
    """The function shard_topk(q, k), shortlisting by column `by` (the
    shards' phks_key column, or their signatures)."""
    return SHARD_TOPK.replace("{by}", by)


SHARD_TOPK = """
CREATE FUNCTION shard_topk(q phks_signature, k int)
RETURNS TABLE (id bigint, name text, score float8)
LANGUAGE plpgsql STABLE AS $$
DECLARE
  part regclass;
  parts text[] := '{}';
BEGIN
  FOR part IN SELECT inhrelid::regclass FROM pg_inherits
              WHERE inhparent = 'shapes'::regclass LOOP
    parts := parts || format('(SELECT id, name, sig, {by} <#> $1 AS nearest '
                             'FROM %s ORDER BY {by} <#> $1, id '
                             'LIMIT greatest($2, 32))', part);
  END LOOP;
  -- OFFSET 0 keeps the branches under a plain Append, which runs the
  -- shards at once with async_capable (a Merge Append would not).
  RETURN QUERY EXECUTE 'SELECT id, name, sig <~> $1 AS score FROM '
    || '(SELECT * FROM (SELECT * FROM ('
    || array_to_string(parts, ' UNION ALL ')
    || ') AS u OFFSET 0) AS s ORDER BY nearest, id '
    || 'LIMIT greatest($2, 32)) AS shortlist ORDER BY score, id LIMIT $2'
    USING q, k;
END $$;"""
