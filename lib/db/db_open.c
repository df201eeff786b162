/*
 * db_open.c - opening and closing a database: the file's header and
 * schema checked, an empty file given the schema, a format 1 file
 * upgraded, the connection set up. The file format is in
 * docs/formats.md.
 *
 * Durability: WAL journal (readers never block the writer nor the writer
 * them) with synchronous=FULL, so a write is on disk when its call
 * returns: a killed process, a crash or a power loss keeps every
 * committed write. NORMAL would also survive a killed process, but an OS
 * crash or power loss could roll back the last commits; FULL costs one
 * fsync per transaction, little beside the seconds a signature takes to
 * compute. A busy handler makes a process wait for another's write to
 * finish instead of failing (busy_wait).
 */
#include "db/db.h"

#include <stdio.h>
#include <string.h>
#include <time.h>

#define DB_APPLICATION_ID 0x50484B53 /* "PHKS" */
#define DB_FORMAT 2
#define DB_BUSY_MS 5000
#define DB_BUSY_POLL_NS 1000000 /* 1 ms */

/* ---- waiting for another writer */

static double seconds_now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* SQLite's busy handler: tries again every millisecond for DB_BUSY_MS.
 * SQLite's own (sqlite3_busy_timeout) sleeps up to 100 ms between tries,
 * so a process that commits back to back kept another out past the 5 s:
 * the lock is free only in the gaps between its transactions, and a try
 * every 100 ms seldom lands in one (test_db_faults' load saw it within a
 * minute). SQLite calls this with the connection's mutex held. */
static int busy_wait(void *arg, int tries)
{
    phks_db *db = arg;
    if (tries == 0)
        db->busy_since = seconds_now();
    if (seconds_now() - db->busy_since >= DB_BUSY_MS / 1000.0)
        return 0;
    nanosleep(&(struct timespec){0, DB_BUSY_POLL_NS}, NULL);
    return 1;
}

/* ---- the header */

typedef struct header {
    int64_t application_id, user_version, objects;
} header;

static phks_status read_header(phks_db *db, header *h)
{
    phks_status st =
        phks__db_query_int(db, "PRAGMA application_id", &h->application_id);
    if (st == PHKS_OK)
        st = phks__db_query_int(db, "PRAGMA user_version", &h->user_version);
    if (st == PHKS_OK)
        st = phks__db_query_int(db, "SELECT count(*) FROM sqlite_master",
                                &h->objects);
    return st;
}

static bool header_empty(const header *h)
{
    return h->application_id == 0 && h->user_version == 0 && h->objects == 0;
}

static phks_status check_header(phks_db *db, const header *h)
{
    if (h->application_id != DB_APPLICATION_ID)
        return phks__fail(PHKS_ERROR_CORRUPT,
                         "%s: not a libphks database (an SQLite database "
                         "with application_id %lld)",
                         db->path, (long long)h->application_id);
    if (h->user_version > DB_FORMAT)
        return phks__fail(PHKS_ERROR_UNSUPPORTED_VERSION,
                         "%s: database format %lld is newer than this "
                         "library's %d",
                         db->path, (long long)h->user_version, DB_FORMAT);
    if (h->user_version < 1)
        return phks__fail(PHKS_ERROR_CORRUPT, "%s: database format %lld",
                         db->path, (long long)h->user_version);
    return PHKS_OK;
}

/* Format 2's additions to format 1: the packed chunks, and the state
 * that tells whether they cover the rows (docs/formats.md). The triggers
 * count every change any program makes to the entries. */
#define SCHEMA_PACKS                                                      \
    "CREATE TABLE packs (start INTEGER PRIMARY KEY, entries INTEGER NOT"   \
    " NULL, vectors INTEGER NOT NULL, text INTEGER NOT NULL,"              \
    " data BLOB NOT NULL);"                                                \
    "CREATE TABLE pack_state (id INTEGER PRIMARY KEY CHECK (id = 1),"      \
    " rows INTEGER NOT NULL, changes INTEGER NOT NULL,"                    \
    " pack_changes INTEGER NOT NULL);"                                     \
    "CREATE TRIGGER entries_insert AFTER INSERT ON entries BEGIN"          \
    " UPDATE pack_state SET rows = rows + 1, changes = changes + 1; END;"  \
    "CREATE TRIGGER entries_delete AFTER DELETE ON entries BEGIN"          \
    " UPDATE pack_state SET rows = rows - 1, changes = changes + 1; END;"  \
    "CREATE TRIGGER entries_update AFTER UPDATE ON entries BEGIN"          \
    " UPDATE pack_state SET changes = changes + 1; END;"

static const char schema[] =
    "PRAGMA application_id = 1346915155;" /* DB_APPLICATION_ID */
    "PRAGMA user_version = 2;"            /* DB_FORMAT */
    "CREATE TABLE meta (key TEXT PRIMARY KEY NOT NULL, value);"
    "CREATE TABLE entries (id INTEGER PRIMARY KEY AUTOINCREMENT,"
    " name TEXT NOT NULL, label TEXT, signature BLOB NOT NULL);"
    SCHEMA_PACKS
    "INSERT INTO pack_state VALUES (1, 0, 0, 0);";

/* Format 1 to 2 in one write transaction: the packs table starts stale
 * (pack_changes -1), and the first load of a writable handle fills it. */
static const char upgrade_sql[] =
    SCHEMA_PACKS
    "INSERT INTO pack_state SELECT 1, count(*), 0, -1 FROM entries;"
    "UPDATE meta SET value = 2 WHERE key = 'format';"
    "PRAGMA user_version = 2;";

/* Writes the schema into an empty file, in one transaction; another
 * process may have done it since the file was seen empty. */
static phks_status create_schema(phks_db *db)
{
    header h;
    sqlite3_stmt *stmt = NULL;
    phks_status st = phks__db_begin(db, true);
    if (st != PHKS_OK)
        return st;
    st = read_header(db, &h);
    if (st == PHKS_OK && !header_empty(&h)) {
        phks__db_rollback(db);
        return check_header(db, &h);
    }
    if (st == PHKS_OK)
        st = phks__db_exec(db, schema, "cannot create the tables");
    if (st == PHKS_OK)
        st = phks__db_prepare(db,
                              "INSERT INTO meta (key, value) VALUES"
                              " ('format', ?1), ('library_version', ?2)",
                              &stmt);
    if (st == PHKS_OK) {
        sqlite3_bind_int(stmt, 1, DB_FORMAT);
        sqlite3_bind_text(stmt, 2, phks_version_string(), -1, SQLITE_STATIC);
        int rc = sqlite3_step(stmt);
        if (rc != SQLITE_DONE)
            st = phks__db_sql_fail(db, rc, "cannot write the meta table");
    }
    sqlite3_finalize(stmt);
    return phks__db_end(db, st);
}

/* A format 1 file opened writable becomes format 2, in one transaction
 * (another process may have done it since the header was read). */
static phks_status upgrade(phks_db *db)
{
    header h;
    phks_status st = phks__db_begin(db, true);
    if (st != PHKS_OK)
        return st;
    st = read_header(db, &h);
    if (st == PHKS_OK && (st = check_header(db, &h)) == PHKS_OK &&
        h.user_version == 1)
        st = phks__db_exec(db, upgrade_sql,
                           "cannot upgrade the file to format 2");
    return phks__db_end(db, st);
}

/* The meta format must match the header; the entries table (and in
 * format 2 the pack tables) must have our columns; the options are read
 * if set. */
static phks_status check_tables(phks_db *db)
{
    int64_t format;
    phks_status st = phks__db_query_int(
        db, "SELECT value FROM meta WHERE key = 'format'", &format);
    if (st == PHKS_OK && format != db->format)
        st = phks__fail(PHKS_ERROR_CORRUPT,
                       "%s: meta 'format' %lld does not match the header",
                       db->path, (long long)format);
    static const char *const columns[] = {
        "SELECT id, name, label, signature FROM entries",
        "SELECT start, entries, vectors, text, data FROM packs",
        "SELECT id, rows, changes, pack_changes FROM pack_state",
    };
    for (int i = 0; i < (db->format >= 2 ? 3 : 1) && st == PHKS_OK; i++) {
        sqlite3_stmt *stmt;
        st = phks__db_prepare(db, columns[i], &stmt);
        if (st == PHKS_OK)
            sqlite3_finalize(stmt);
    }
    if (st == PHKS_OK)
        st = phks__db_read_options(db);
    return st;
}

/* ---- the connection */

/* The connection's journal and durability; a new file's page size. */
static phks_status set_pragmas(phks_db *db, bool empty, bool memory)
{
    phks_status st = PHKS_OK;
    /* A new file gets 64 KB pages: the packed chunks are then read in a
     * sixteenth of the page reads 4 KB pages take (docs/benchmarks.md).
     * SQLite ignores this on a file that already has pages. */
    if (empty && !memory && !db->readonly)
        st = phks__db_exec(db, "PRAGMA page_size = 65536",
                           "cannot set the page size");
    /* Only a file known to be ours (or empty) is switched to WAL. The mode
     * is stored in the file; where WAL is impossible SQLite keeps its
     * rollback journal, which is as safe, only less concurrent. */
    if (st == PHKS_OK && !db->readonly && !memory)
        st = phks__db_exec(db, "PRAGMA journal_mode = WAL",
                           "cannot set WAL mode");
    if (st == PHKS_OK)
        st = phks__db_exec(db, "PRAGMA synchronous = FULL",
                           "cannot set synchronous");
    return st;
}

/* The file checked, given the schema when empty and upgraded when old. */
static phks_status setup(phks_db *db, bool memory)
{
    header h;
    phks_status st = read_header(db, &h);
    if (st != PHKS_OK)
        return st;
    bool empty = header_empty(&h);
    if (empty && db->readonly)
        return phks__fail(PHKS_ERROR_CORRUPT,
                          "%s: an empty file, not a libphks database (open it "
                          "writable to create one)",
                          db->path);
    if (!empty && (st = check_header(db, &h)) != PHKS_OK)
        return st;
    db->format = empty ? DB_FORMAT : (int)h.user_version;
    st = set_pragmas(db, empty, memory);
    if (st == PHKS_OK && empty && (st = create_schema(db)) == PHKS_OK &&
        (st = read_header(db, &h)) == PHKS_OK)
        db->format = (int)h.user_version; /* another process's, maybe */
    if (st == PHKS_OK && !db->readonly && db->format < DB_FORMAT) {
        st = upgrade(db);
        db->format = DB_FORMAT;
    }
    /* A private database in memory is loaded once from its rows and never
     * reopened: the chunks would only cost its writes. */
    db->use_pack = db->format >= 2 && !memory;
    if (st == PHKS_OK)
        st = check_tables(db);
    if (st == PHKS_OK)
        st = phks__db_prepare(db, "PRAGMA data_version", &db->version);
    return st;
}

static phks_status check_open(const char *path, unsigned flags,
                              phks_db **out)
{
    if (out)
        *out = NULL;
    if (!path || !out)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                          "phks_db_open: NULL argument");
    if (flags & ~(PHKS_DB_READONLY | PHKS_DB_CREATE))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                          "phks_db_open: unknown flags 0x%x",
                          flags & ~(PHKS_DB_READONLY | PHKS_DB_CREATE));
    bool readonly = flags & PHKS_DB_READONLY;
    if (readonly && (flags & PHKS_DB_CREATE))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                          "phks_db_open: PHKS_DB_READONLY with PHKS_DB_CREATE");
    if (!*path)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                          "phks_db_open: empty path");
    if (readonly && !strcmp(path, ":memory:"))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                          "phks_db_open: a database in memory cannot be "
                          "read-only");
    if (!sqlite3_threadsafe())
        return phks__fail(PHKS_ERROR_IO,
                          "phks_db_open: SQLite was built without threads");
    return PHKS_OK;
}

/* A handle for path, not connected; *name: the file name SQLite is to
 * open (phks__free). On failure *db, if set, is for phks_db_close. */
static phks_status new_handle(const char *path, bool readonly, phks_db **db,
                              char **name)
{
    size_t len = strlen(path);
    /* With URIs enabled in SQLite's global configuration, a relative path
     * "file:..." would be parsed as a URI: "./" keeps it a file name. */
    bool uri_like = !strncmp(path, "file:", 5);
    phks_db *h = phks__calloc(1, sizeof *h);
    *db = NULL;
    *name = h ? phks__malloc(len + 3) : NULL;
    if (!h || !*name || !(h->path = phks__malloc(len + 1))) {
        phks__free(*name);
        phks__free(h);
        *name = NULL;
        return phks__fail_oom("phks_db_open");
    }
    memcpy(h->path, path, len + 1);
    snprintf(*name, len + 3, "%s%s", uri_like ? "./" : "", path);
    h->readonly = readonly;
    phks__db_cache_init(&h->cache);
    h->lock_ready = pthread_mutex_init(&h->lock, NULL) == 0;
    h->cache_lock_ready =
        h->lock_ready && pthread_rwlock_init(&h->cache_lock, NULL) == 0;
    *db = h;
    return h->cache_lock_ready ? PHKS_OK
                               : phks__fail_oom("phks_db_open: locks");
}

/* Opens SQLite's connection to name for db. */
static phks_status open_connection(phks_db *db, const char *name,
                                   unsigned flags, bool memory)
{
    int mode = db->readonly ? SQLITE_OPEN_READONLY
                            : SQLITE_OPEN_READWRITE |
                                  (flags & PHKS_DB_CREATE || memory
                                       ? SQLITE_OPEN_CREATE
                                       : 0);
    int rc = sqlite3_open_v2(name, &db->conn, mode | SQLITE_OPEN_FULLMUTEX,
                             NULL);
    if (rc != SQLITE_OK)
        return phks__db_sql_fail(
            db, rc,
            flags & PHKS_DB_CREATE
                ? "cannot open or create"
                : "cannot open (missing? PHKS_DB_CREATE makes it)");
    sqlite3_busy_handler(db->conn, busy_wait, db);
#ifdef SQLITE_DBCONFIG_DEFENSIVE
    sqlite3_db_config(db->conn, SQLITE_DBCONFIG_DEFENSIVE, 1, (int *)NULL);
#endif
#ifdef SQLITE_DBCONFIG_TRUSTED_SCHEMA
    sqlite3_db_config(db->conn, SQLITE_DBCONFIG_TRUSTED_SCHEMA, 0,
                      (int *)NULL);
#endif
    return PHKS_OK;
}

phks_status phks_db_open(const char *path, unsigned flags, phks_db **out)
{
    phks_status st = check_open(path, flags, out);
    if (st != PHKS_OK)
        return st;
    bool memory = !strcmp(path, ":memory:");
    phks_db *db;
    char *name;
    st = new_handle(path, flags & PHKS_DB_READONLY, &db, &name);
    if (st == PHKS_OK)
        st = open_connection(db, name, flags, memory);
    phks__free(name);
    if (st == PHKS_OK)
        st = setup(db, memory);
    if (st != PHKS_OK) {
        phks_db_close(db);
        return st;
    }
    *out = db;
    return PHKS_OK;
}

void phks_db_close(phks_db *db)
{
    if (!db)
        return;
    sqlite3_finalize(db->version);
    sqlite3_close_v2(db->conn);
    phks__db_cache_release(&db->cache);
    if (db->cache_lock_ready)
        pthread_rwlock_destroy(&db->cache_lock);
    if (db->lock_ready)
        pthread_mutex_destroy(&db->lock);
    phks__free(db->path);
    phks__free(db);
}

