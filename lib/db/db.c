/*
 * db.c - shape databases: the SQLite file, its schema and meta checks,
 * transactions, and the locks around the packed copy that queries scan
 * (db_scan.c). The file format is in docs/formats.md.
 *
 * Durability: WAL journal (readers never block the writer nor the writer
 * them) with synchronous=FULL, so a write is on disk when its call
 * returns: a killed process, a crash or a power loss keeps every
 * committed write. NORMAL would also survive a killed process, but an OS
 * crash or power loss could roll back the last commits; FULL costs one
 * fsync per transaction, little beside the seconds a signature takes to
 * compute. A busy timeout makes a process wait for another's write to
 * finish instead of failing.
 *
 * Locking: see struct phks_db in db.h.
 *
 * Cache refresh: PRAGMA data_version changes when another connection (this
 * process or another) commits. Each query compares it with the value read
 * when the cache was loaded (one prepared statement, no work per entry)
 * and reloads on a change. This handle's own writes leave data_version as
 * it is and update the cache in place.
 *
 * Format 2 keeps the packed copy in the file too (table packs, chunks
 * laid out by db_pack.c): a reload reads it, and every write updates it
 * in its own transaction; see "the packed chunks" below.
 */
#include "db/db.h"

#include <limits.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>

#define DB_APPLICATION_ID 0x50484B53 /* "PHKS" */
#define DB_FORMAT 2
#define DB_BUSY_MS 5000
/* A chunk of the packs table closes at this many bytes: an add rewrites
 * at most one chunk below it, a removal one chunk. */
#define PACK_CHUNK_BYTES (512 * 1024)

/* ---- SQLite errors */

static phks_status sql_status(int rc)
{
    switch (rc & 0xff) {
    case SQLITE_NOMEM:
        return PHKS_ERROR_OUT_OF_MEMORY;
    case SQLITE_TOOBIG:
        return PHKS_ERROR_TOO_LARGE;
    /* A file that is not a database, is damaged, or lacks our tables and
     * columns (SQLITE_ERROR: "no such table"). */
    case SQLITE_CORRUPT:
    case SQLITE_NOTADB:
    case SQLITE_ERROR:
    case SQLITE_SCHEMA:
    case SQLITE_MISMATCH:
    case SQLITE_CONSTRAINT:
        return PHKS_ERROR_CORRUPT;
    default: /* FULL, IOERR, CANTOPEN, READONLY, BUSY, LOCKED, PERM, ... */
        return PHKS_ERROR_IO;
    }
}

/* Must be called right after the failing SQLite call, with lock held. */
static phks_status sql_fail(const phks_db *db, int rc, const char *what)
{
    const char *detail = db->conn ? sqlite3_errmsg(db->conn) : sqlite3_errstr(rc);
    return phks__fail(sql_status(rc), "%s: %s: %s", db->path, what, detail);
}

static phks_status prepare(phks_db *db, const char *sql, sqlite3_stmt **stmt)
{
    int rc = sqlite3_prepare_v2(db->conn, sql, -1, stmt, NULL);
    if (rc != SQLITE_OK) {
        *stmt = NULL;
        return sql_fail(db, rc,
                        sql_status(rc) == PHKS_ERROR_CORRUPT
                            ? "not a libphks database"
                            : "cannot prepare a statement");
    }
    return PHKS_OK;
}

/* The integer in the first column of the one row sql gives. */
static phks_status query_int(phks_db *db, const char *sql, int64_t *value)
{
    sqlite3_stmt *stmt;
    phks_status st = prepare(db, sql, &stmt);
    if (st != PHKS_OK)
        return st;
    int rc = sqlite3_step(stmt);
    if (rc == SQLITE_ROW)
        *value = sqlite3_column_int64(stmt, 0);
    else
        st = sql_fail(db, rc == SQLITE_DONE ? SQLITE_CORRUPT : rc, sql);
    sqlite3_finalize(stmt);
    return st;
}

static phks_status exec(phks_db *db, const char *sql, const char *what)
{
    int rc = sqlite3_exec(db->conn, sql, NULL, NULL, NULL);
    return rc == SQLITE_OK ? PHKS_OK : sql_fail(db, rc, what);
}

static void rollback(phks_db *db)
{
    if (!sqlite3_get_autocommit(db->conn))
        sqlite3_exec(db->conn, "ROLLBACK", NULL, NULL, NULL);
}

/* A write transaction takes the write lock at once (IMMEDIATE), so two
 * writers queue in the busy handler instead of deadlocking later. */
static phks_status begin(phks_db *db, bool write)
{
    return exec(db, write ? "BEGIN IMMEDIATE" : "BEGIN",
                write ? "cannot start a write transaction"
                      : "cannot start a read transaction");
}

static phks_status commit(phks_db *db)
{
    phks_status st = exec(db, "COMMIT", "commit failed");
    if (st != PHKS_OK)
        rollback(db);
    return st;
}

/* ---- text and options */

/* Strict UTF-8: no overlong forms, surrogates or values above U+10FFFF. */
static bool valid_utf8(const char *s)
{
    const unsigned char *p = (const unsigned char *)s;
    while (*p) {
        uint32_t c = *p, min;
        size_t more;
        if (c < 0x80) {
            p++;
            continue;
        } else if ((c & 0xE0) == 0xC0) {
            more = 1, min = 0x80, c &= 0x1F;
        } else if ((c & 0xF0) == 0xE0) {
            more = 2, min = 0x800, c &= 0x0F;
        } else if ((c & 0xF8) == 0xF0) {
            more = 3, min = 0x10000, c &= 0x07;
        } else {
            return false;
        }
        for (size_t i = 1; i <= more; i++) {
            if ((p[i] & 0xC0) != 0x80) /* also stops at the NUL */
                return false;
            c = c << 6 | (p[i] & 0x3Fu);
        }
        if (c < min || c > 0x10FFFF || (c >= 0xD800 && c <= 0xDFFF))
            return false;
        p += more + 1;
    }
    return true;
}

/* The meta 'options' value: a signature blob with one all-zero feature
 * that carries the options, so the signature codec (versioned, checked)
 * stores and validates them. */
static phks_status options_blob(const phks_options *options, void **blob,
                                size_t *size)
{
    phks_signature *sig;
    phks_status st = phks__signature_alloc(1, 0, options->scale_count, &sig);
    if (st != PHKS_OK)
        return st;
    sig->options = *options;
    if (options->matching == PHKS_MATCHING_VERIFIED) {
        st = phks__signature_alloc_layout(sig);
        if (st != PHKS_OK) {
            phks_signature_free(sig);
            return st;
        }
        sig->boundary[0] = 0;
    }
    sig->vertex[0] = 0;
    memset(sig->position, 0, 3 * sizeof *sig->position);
    sig->persistence[0] = 0;
    memset(sig->vectors, 0, sig->length * sizeof *sig->vectors);
    *size = phks_signature_encoded_size(sig);
    *blob = phks__malloc(*size);
    if (!*blob)
        st = phks__fail_oom("database options");
    else
        st = phks_signature_encode(sig, *blob, *size, size);
    phks_signature_free(sig);
    return st;
}

/* Decodes a stored blob. A blob of a newer format (written by a newer
 * library) keeps its status; every other failure but memory means a
 * damaged file. */
static phks_status decode_stored(phks_db *db, const void *blob, int size,
                                 const char *what, phks_signature **sig)
{
    *sig = NULL;
    if (!blob || size <= 0)
        return phks__fail(PHKS_ERROR_CORRUPT, "%s: %s: no signature blob",
                         db->path, what);
    phks_status st = phks_signature_decode(blob, (size_t)size, sig);
    if (st == PHKS_OK || st == PHKS_ERROR_OUT_OF_MEMORY)
        return st;
    char prefix[512];
    snprintf(prefix, sizeof prefix, "%s: %s", db->path, what);
    phks__error_prefix(prefix);
    return st == PHKS_ERROR_UNSUPPORTED_VERSION ? st : PHKS_ERROR_CORRUPT;
}

/* Reads the meta 'options' into db if present (they never change once
 * committed, so keeping them is safe even if the caller rolls back). */
static phks_status read_options(phks_db *db)
{
    sqlite3_stmt *stmt;
    phks_status st =
        prepare(db, "SELECT value FROM meta WHERE key = 'options'", &stmt);
    if (st != PHKS_OK)
        return st;
    int rc = sqlite3_step(stmt);
    if (rc == SQLITE_ROW) {
        phks_signature *sig;
        st = decode_stored(db, sqlite3_column_blob(stmt, 0),
                           sqlite3_column_bytes(stmt, 0), "meta 'options'",
                           &sig);
        if (st == PHKS_OK) {
            db->options = sig->options;
            db->has_options = true;
            phks_signature_free(sig);
        }
    } else if (rc != SQLITE_DONE) {
        st = sql_fail(db, rc, "cannot read the meta table");
    }
    sqlite3_finalize(stmt);
    return st;
}

/* ---- opening */

typedef struct header {
    int64_t application_id, user_version, objects;
} header;

static phks_status read_header(phks_db *db, header *h)
{
    phks_status st = query_int(db, "PRAGMA application_id", &h->application_id);
    if (st == PHKS_OK)
        st = query_int(db, "PRAGMA user_version", &h->user_version);
    if (st == PHKS_OK)
        st = query_int(db, "SELECT count(*) FROM sqlite_master", &h->objects);
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
    phks_status st = begin(db, true);
    if (st != PHKS_OK)
        return st;
    st = read_header(db, &h);
    if (st == PHKS_OK && !header_empty(&h)) {
        rollback(db);
        return check_header(db, &h);
    }
    if (st == PHKS_OK)
        st = exec(db, schema, "cannot create the tables");
    if (st == PHKS_OK)
        st = prepare(db,
                     "INSERT INTO meta (key, value) VALUES ('format', ?1),"
                     " ('library_version', ?2)",
                     &stmt);
    if (st == PHKS_OK) {
        sqlite3_bind_int(stmt, 1, DB_FORMAT);
        sqlite3_bind_text(stmt, 2, phks_version_string(), -1, SQLITE_STATIC);
        int rc = sqlite3_step(stmt);
        if (rc != SQLITE_DONE)
            st = sql_fail(db, rc, "cannot write the meta table");
    }
    sqlite3_finalize(stmt);
    if (st == PHKS_OK)
        return commit(db);
    rollback(db);
    return st;
}

/* A format 1 file opened writable becomes format 2, in one transaction
 * (another process may have done it since the header was read). */
static phks_status upgrade(phks_db *db)
{
    header h;
    phks_status st = begin(db, true);
    if (st != PHKS_OK)
        return st;
    st = read_header(db, &h);
    if (st == PHKS_OK && (st = check_header(db, &h)) == PHKS_OK &&
        h.user_version == 1)
        st = exec(db, upgrade_sql, "cannot upgrade the file to format 2");
    if (st == PHKS_OK)
        return commit(db);
    rollback(db);
    return st;
}

/* The meta format must match the header; the entries table (and in
 * format 2 the pack tables) must have our columns; the options are read
 * if set. */
static phks_status check_tables(phks_db *db)
{
    int64_t format;
    phks_status st =
        query_int(db, "SELECT value FROM meta WHERE key = 'format'", &format);
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
        st = prepare(db, columns[i], &stmt);
        if (st == PHKS_OK)
            sqlite3_finalize(stmt);
    }
    if (st == PHKS_OK)
        st = read_options(db);
    return st;
}

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
    /* A new file gets 64 KB pages: the packed chunks are then read in a
     * sixteenth of the page reads 4 KB pages take (docs/benchmarks.md).
     * SQLite ignores this on a file that already has pages. */
    if (empty && !memory && !db->readonly)
        st = exec(db, "PRAGMA page_size = 65536", "cannot set the page size");
    /* Only a file known to be ours (or empty) is switched to WAL. The mode
     * is stored in the file; where WAL is impossible SQLite keeps its
     * rollback journal, which is as safe, only less concurrent. */
    if (st == PHKS_OK && !db->readonly && !memory)
        st = exec(db, "PRAGMA journal_mode = WAL", "cannot set WAL mode");
    if (st == PHKS_OK)
        st = exec(db, "PRAGMA synchronous = FULL", "cannot set synchronous");
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
        st = prepare(db, "PRAGMA data_version", &db->version);
    return st;
}

phks_status phks_db_open(const char *path, unsigned flags, phks_db **out)
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
    bool readonly = flags & PHKS_DB_READONLY, memory = !strcmp(path, ":memory:");
    if (readonly && (flags & PHKS_DB_CREATE))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_db_open: PHKS_DB_READONLY with PHKS_DB_CREATE");
    if (!*path)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT, "phks_db_open: empty path");
    if (memory && readonly)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_db_open: a database in memory cannot be "
                         "read-only");
    if (!sqlite3_threadsafe())
        return phks__fail(PHKS_ERROR_IO,
                         "phks_db_open: SQLite was built without threads");

    phks_db *db = phks__calloc(1, sizeof *db);
    size_t len = strlen(path);
    /* With URIs enabled in SQLite's global configuration, a relative path
     * "file:..." would be parsed as a URI: "./" keeps it a file name. */
    bool uri_like = !strncmp(path, "file:", 5);
    char *name = db ? phks__malloc(len + 3) : NULL;
    if (!db || !name || !(db->path = phks__malloc(len + 1))) {
        phks__free(name);
        phks__free(db);
        return phks__fail_oom("phks_db_open");
    }
    memcpy(db->path, path, len + 1);
    snprintf(name, len + 3, "%s%s", uri_like ? "./" : "", path);
    db->readonly = readonly;
    phks__db_cache_init(&db->cache);
    phks_status st = PHKS_OK;
    db->lock_ready = pthread_mutex_init(&db->lock, NULL) == 0;
    db->cache_lock_ready =
        db->lock_ready && pthread_rwlock_init(&db->cache_lock, NULL) == 0;
    if (!db->cache_lock_ready)
        st = phks__fail_oom("phks_db_open: locks");
    if (st == PHKS_OK) {
        int mode = readonly ? SQLITE_OPEN_READONLY
                            : SQLITE_OPEN_READWRITE |
                                  (flags & PHKS_DB_CREATE || memory
                                       ? SQLITE_OPEN_CREATE
                                       : 0);
        int rc = sqlite3_open_v2(name, &db->conn, mode | SQLITE_OPEN_FULLMUTEX,
                                 NULL);
        if (rc != SQLITE_OK)
            st = sql_fail(db, rc,
                          flags & PHKS_DB_CREATE
                              ? "cannot open or create"
                              : "cannot open (missing? PHKS_DB_CREATE makes it)");
    }
    phks__free(name);
    if (st == PHKS_OK) {
        sqlite3_busy_timeout(db->conn, DB_BUSY_MS);
#ifdef SQLITE_DBCONFIG_DEFENSIVE
        sqlite3_db_config(db->conn, SQLITE_DBCONFIG_DEFENSIVE, 1, (int *)NULL);
#endif
#ifdef SQLITE_DBCONFIG_TRUSTED_SCHEMA
        sqlite3_db_config(db->conn, SQLITE_DBCONFIG_TRUSTED_SCHEMA, 0,
                          (int *)NULL);
#endif
        st = setup(db, memory);
    }
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

/* ---- the cache */

/* Ids start at 1: SQLite's AUTOINCREMENT never gives less, but another
 * program can write any id. Count, list (whose first page starts after
 * id 0) and query would disagree about such a row, so all three refuse
 * the file as damaged; get and remove still reach the row by its id. */
static phks_status id_below_one(const phks_db *db, int64_t id)
{
    return phks__fail(PHKS_ERROR_CORRUPT,
                     "%s: entry id %lld: ids start at 1 (the row was "
                     "written by another program)",
                     db->path, (long long)id);
}

static phks_status data_version(phks_db *db, int64_t *version)
{
    int rc = sqlite3_step(db->version);
    if (rc == SQLITE_ROW)
        *version = sqlite3_column_int64(db->version, 0);
    phks_status st = rc == SQLITE_ROW
                         ? PHKS_OK
                         : sql_fail(db, rc, "cannot read data_version");
    sqlite3_reset(db->version);
    return st;
}

static void drop_cache(phks_db *db)
{
    phks__db_cache_release(&db->cache);
    db->cache_loaded = false;
}

/* ---- the packed chunks (format 2; docs/formats.md)
 *
 * The packs table holds the cache's entries in chunks, each covering the
 * ids from its start up to the next chunk's start. pack_state counts the
 * rows and every change made to them (by triggers, whoever writes), and
 * records in pack_changes the count of changes the chunks cover: they
 * are used only when it equals changes and every chunk's checksum and
 * layout hold, else the cache is rebuilt from the rows and, on a
 * writable handle, the chunks rewritten from it. Each write of this
 * library updates the chunks in its own transaction. */

typedef struct pack_state {
    bool present;
    int64_t rows, changes, pack_changes;
} pack_state;

static phks_status read_pack_state(phks_db *db, pack_state *ps)
{
    memset(ps, 0, sizeof *ps);
    sqlite3_stmt *stmt;
    phks_status st = prepare(
        db, "SELECT rows, changes, pack_changes FROM pack_state WHERE id = 1",
        &stmt);
    if (st != PHKS_OK)
        return st;
    int rc = sqlite3_step(stmt);
    if (rc == SQLITE_ROW) {
        ps->present = true;
        ps->rows = sqlite3_column_int64(stmt, 0);
        ps->changes = sqlite3_column_int64(stmt, 1);
        ps->pack_changes = sqlite3_column_int64(stmt, 2);
    } else if (rc != SQLITE_DONE) {
        st = sql_fail(db, rc, "cannot read pack_state");
    }
    sqlite3_finalize(stmt);
    return st;
}

static bool pack_current(const pack_state *ps)
{
    return ps->present && ps->pack_changes == ps->changes && ps->rows >= 0;
}

/* Inside a write transaction, after the chunks were brought up to date:
 * they now cover every change counted. */
static phks_status mark_pack_current(phks_db *db, int64_t rows, bool set_rows)
{
    sqlite3_stmt *stmt;
    phks_status st = prepare(
        db,
        set_rows ? "INSERT OR REPLACE INTO pack_state (id, rows, changes,"
                   " pack_changes) SELECT 1, ?1, coalesce(max(changes), 0),"
                   " coalesce(max(changes), 0) FROM pack_state"
                 : "UPDATE pack_state SET pack_changes = changes",
        &stmt);
    if (st != PHKS_OK)
        return st;
    sqlite3_bind_int64(stmt, 1, rows);
    int rc = sqlite3_step(stmt);
    if (rc != SQLITE_DONE)
        st = sql_fail(db, rc, "cannot write pack_state");
    sqlite3_finalize(stmt);
    return st;
}

/* Writes the live entries of slots [begin, end) of c as the chunk that
 * starts at id start (replacing one that did). */
static phks_status write_chunk(phks_db *db, int64_t start,
                               const phks__db_cache *c, size_t begin,
                               size_t end)
{
    unsigned char *blob;
    size_t size, entries;
    phks_status st = phks__db_pack_encode(c, begin, end, &blob, &size, &entries);
    if (st == PHKS_ERROR_OUT_OF_MEMORY)
        return phks__fail_oom("database pack");
    if (st != PHKS_OK) /* no live entry: no chunk */
        return PHKS_OK;
    if (size > INT_MAX) {
        phks__free(blob);
        return phks__fail(PHKS_ERROR_TOO_LARGE, "%s: a pack chunk of %zu bytes",
                         db->path, size);
    }
    size_t vectors = 0, text = 0;
    for (size_t e = begin; e < end; e++)
        if (c->features[e]) {
            vectors += phks__db_padded(c->features[e]) * c->length;
            const char *t = c->text + c->text_at[e];
            size_t n = strlen(t) + 1;
            text += n + strlen(t + n) + 1;
        }
    sqlite3_stmt *stmt;
    st = prepare(db,
                 "INSERT OR REPLACE INTO packs (start, entries, vectors, text,"
                 " data) VALUES (?1, ?2, ?3, ?4, ?5)",
                 &stmt);
    if (st == PHKS_OK) {
        sqlite3_bind_int64(stmt, 1, start);
        sqlite3_bind_int64(stmt, 2, (int64_t)entries);
        sqlite3_bind_int64(stmt, 3, (int64_t)vectors);
        sqlite3_bind_int64(stmt, 4, (int64_t)text);
        int rc = sqlite3_bind_blob(stmt, 5, blob, (int)size, SQLITE_STATIC);
        if (rc == SQLITE_OK)
            rc = sqlite3_step(stmt);
        if (rc != SQLITE_DONE)
            st = sql_fail(db, rc, "cannot write a pack chunk");
        sqlite3_finalize(stmt);
    }
    phks__free(blob);
    return st;
}

/* Every live entry of c as chunks of about PACK_CHUNK_BYTES, replacing
 * all chunks. */
static phks_status write_all_chunks(phks_db *db, const phks__db_cache *c)
{
    phks_status st = exec(db, "DELETE FROM packs", "cannot clear the packs");
    size_t begin = 0, bytes = 0;
    for (size_t e = 0; e <= c->count && st == PHKS_OK; e++) {
        if (e < c->count && !c->features[e])
            continue;
        if (e < c->count)
            bytes += 12 + 8 * phks__db_padded(c->features[e]) * c->length + 32;
        if (bytes && (bytes >= PACK_CHUNK_BYTES || e == c->count)) {
            size_t end = e < c->count ? e + 1 : e;
            while (!c->features[begin]) /* a live slot lies below end */
                begin++;
            st = write_chunk(db, c->ids[begin], c, begin, end);
            begin = end;
            bytes = 0;
        }
    }
    return st;
}

static phks_status read_memory(void *ctx, void *dst, size_t n, size_t offset)
{
    memcpy(dst, (const unsigned char *)ctx + offset, n);
    return PHKS_OK;
}

/* The chunk holding id (the one with the highest start at most id) into
 * the empty cache t. *found false when there is none; PHKS_ERROR_CORRUPT
 * without a message when it is damaged. */
static phks_status read_chunk(phks_db *db, int64_t id, phks__db_cache *t,
                              int64_t *start, bool *found)
{
    *found = false;
    sqlite3_stmt *stmt;
    phks_status st = prepare(db,
                             "SELECT start, data FROM packs WHERE start <= ?1"
                             " ORDER BY start DESC LIMIT 1",
                             &stmt);
    if (st != PHKS_OK)
        return st;
    sqlite3_bind_int64(stmt, 1, id);
    int rc = sqlite3_step(stmt);
    if (rc == SQLITE_ROW) {
        *found = true;
        *start = sqlite3_column_int64(stmt, 0);
        const void *blob = sqlite3_column_blob(stmt, 1);
        int size = sqlite3_column_bytes(stmt, 1);
        if (!blob && sqlite3_errcode(db->conn) == SQLITE_NOMEM)
            st = phks__fail_oom("database pack");
        else if (!blob || size <= 0)
            st = PHKS_ERROR_CORRUPT;
        else
            st = phks__db_pack_decode(t, *start, (size_t)size, read_memory,
                                     (void *)blob);
        if (st == PHKS_ERROR_OUT_OF_MEMORY)
            st = phks__fail_oom("database pack");
    } else if (rc != SQLITE_DONE) {
        st = sql_fail(db, rc, "cannot read a pack chunk");
    }
    sqlite3_finalize(stmt);
    return st;
}

/* Inside the write transaction that added entries with ids (ascending,
 * above every other): appends them to the last chunk while it is small,
 * then to new chunks. *kept false when the chunks turn out damaged: they
 * are then left stale, to be rebuilt. */
static phks_status pack_append(phks_db *db, const phks_db_entry *entries,
                               const int64_t *ids, size_t count, bool *kept)
{
    phks__db_cache t;
    phks__db_cache_init(&t);
    int64_t start = 0;
    bool found;
    *kept = true;
    phks_status st = read_chunk(db, INT64_MAX, &t, &start, &found);
    if (st == PHKS_ERROR_CORRUPT) {
        *kept = false;
        st = PHKS_OK;
    }
    if (st != PHKS_OK || !*kept) {
        phks__db_cache_release(&t);
        return st;
    }
    if (!found || phks__db_pack_bytes(&t) >= PACK_CHUNK_BYTES) {
        phks__db_cache_release(&t);
        start = ids[0];
    }
    for (size_t i = 0; i < count && st == PHKS_OK; i++) {
        if (t.count && phks__db_pack_bytes(&t) >= PACK_CHUNK_BYTES) {
            st = write_chunk(db, start, &t, 0, t.count);
            phks__db_cache_release(&t);
            start = ids[i];
        }
        if (st != PHKS_OK)
            break;
        st = phks__db_cache_append(&t, ids[i], entries[i].name,
                                  entries[i].label, entries[i].signature);
        if (st == PHKS_ERROR_OUT_OF_MEMORY)
            st = phks__fail_oom("database pack");
        else if (st != PHKS_OK) { /* out of order or another length */
            *kept = false;
            st = PHKS_OK;
            break;
        }
    }
    if (st == PHKS_OK && *kept && t.count)
        st = write_chunk(db, start, &t, 0, t.count);
    phks__db_cache_release(&t);
    return st;
}

/* Inside the write transaction that removed entry id. */
static phks_status pack_remove(phks_db *db, int64_t id, bool *kept)
{
    phks__db_cache t;
    phks__db_cache_init(&t);
    int64_t start = 0;
    bool found;
    phks_status st = read_chunk(db, id, &t, &start, &found);
    size_t lo = 0, hi = t.count;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (t.ids[mid] < id)
            lo = mid + 1;
        else
            hi = mid;
    }
    *kept = st == PHKS_OK && found && lo < t.count && t.ids[lo] == id;
    if (st == PHKS_ERROR_CORRUPT)
        st = PHKS_OK;
    if (st == PHKS_OK && *kept) {
        phks__db_cache_remove(&t, id);
        if (t.count > t.dead) {
            st = write_chunk(db, start, &t, 0, t.count);
        } else {
            sqlite3_stmt *stmt;
            st = prepare(db, "DELETE FROM packs WHERE start = ?1", &stmt);
            if (st == PHKS_OK) {
                sqlite3_bind_int64(stmt, 1, start);
                int rc = sqlite3_step(stmt);
                if (rc != SQLITE_DONE)
                    st = sql_fail(db, rc, "cannot remove a pack chunk");
                sqlite3_finalize(stmt);
            }
        }
    }
    phks__db_cache_release(&t);
    return st;
}

typedef struct blob_reader {
    phks_db *db;
    sqlite3_blob *blob;
} blob_reader;

static phks_status read_blob(void *ctx, void *dst, size_t n, size_t offset)
{
    blob_reader *r = ctx;
    if (n == 0)
        return PHKS_OK;
    if (n > INT_MAX || offset > INT_MAX)
        return PHKS_ERROR_CORRUPT;
    int rc = sqlite3_blob_read(r->blob, dst, (int)n, (int)offset);
    return rc == SQLITE_OK ? PHKS_OK
                           : sql_fail(r->db, rc, "cannot read a pack chunk");
}

/* Inside a read transaction, into the empty cache: every chunk, if they
 * cover the rows pack_state counts (ps, current). PHKS_ERROR_CORRUPT
 * without a message when they do not, or one is damaged: the caller
 * rebuilds from the rows. */
static phks_status load_pack(phks_db *db, const pack_state *ps)
{
    sqlite3_stmt *stmt;
    phks_status st = prepare(db,
                             "SELECT count(*), total(entries), total(vectors),"
                             " total(text), (SELECT max(id) FROM entries)"
                             " FROM packs",
                             &stmt);
    if (st != PHKS_OK)
        return st;
    int rc = sqlite3_step(stmt);
    double entries = 0, vectors = 0, text = 0;
    int64_t max_id = 0;
    if (rc == SQLITE_ROW) {
        entries = sqlite3_column_double(stmt, 1);
        vectors = sqlite3_column_double(stmt, 2);
        text = sqlite3_column_double(stmt, 3);
        max_id = sqlite3_column_int64(stmt, 4);
    } else {
        st = sql_fail(db, rc == SQLITE_DONE ? SQLITE_CORRUPT : rc,
                      "cannot read the packs");
    }
    sqlite3_finalize(stmt);
    if (st != PHKS_OK)
        return st;
    /* The totals only size the cache (the chunks are checked one by one):
     * when that much memory is not there, the chunks' reads find out
     * whether it was needed. */
    if (entries != (double)ps->rows || (ps->rows && !db->has_options))
        return PHKS_ERROR_CORRUPT;
    if (vectors >= 0 && text >= 0 && vectors < 1e15 && text < 1e15)
        (void)phks__db_cache_reserve(&db->cache, (size_t)entries,
                                    (size_t)vectors, (size_t)text);
    if ((st = prepare(db, "SELECT start, entries FROM packs ORDER BY start",
                      &stmt)) != PHKS_OK)
        return st;
    blob_reader r = {db, NULL};
    while (st == PHKS_OK && (rc = sqlite3_step(stmt)) == SQLITE_ROW) {
        int64_t start = sqlite3_column_int64(stmt, 0);
        size_t before = db->cache.count;
        rc = r.blob ? sqlite3_blob_reopen(r.blob, start)
                    : sqlite3_blob_open(db->conn, "main", "packs", "data",
                                        start, 0, &r.blob);
        if (rc != SQLITE_OK) {
            st = sql_status(rc) == PHKS_ERROR_CORRUPT
                     ? PHKS_ERROR_CORRUPT
                     : sql_fail(db, rc, "cannot open a pack chunk");
            break;
        }
        st = phks__db_pack_decode(&db->cache, start,
                                 (size_t)sqlite3_blob_bytes(r.blob), read_blob,
                                 &r);
        if (st == PHKS_ERROR_OUT_OF_MEMORY)
            st = phks__fail_oom("database cache");
        else if (st == PHKS_OK &&
                 (db->cache.count - before !=
                      (size_t)sqlite3_column_int64(stmt, 1) ||
                  db->cache.length != (size_t)db->options.scale_count))
            st = PHKS_ERROR_CORRUPT;
    }
    if (st == PHKS_OK && rc != SQLITE_DONE)
        st = sql_status(rc) == PHKS_ERROR_CORRUPT
                 ? PHKS_ERROR_CORRUPT
                 : sql_fail(db, rc, "cannot read the packs");
    sqlite3_blob_close(r.blob);
    sqlite3_finalize(stmt);
    /* Every row, and no other: as many entries as rows counted, and the
     * last id the highest row's. */
    if (st == PHKS_OK &&
        (db->cache.count != (size_t)ps->rows ||
         (db->cache.count ? db->cache.ids[db->cache.count - 1] : 0) != max_id))
        st = PHKS_ERROR_CORRUPT;
    return st;
}

/* After a rebuild from the rows, on a writable handle: the chunks from
 * the new cache, if no other connection changed the rows since (changes
 * is what pack_state counted then). Failures only leave the chunks stale
 * for the next load. Called with lock held. */
static void persist_pack(phks_db *db, int64_t changes)
{
    if (begin(db, true) != PHKS_OK)
        return;
    pack_state ps;
    phks_status st = read_pack_state(db, &ps);
    if (st == PHKS_OK && ps.changes == changes)
        st = write_all_chunks(db, &db->cache);
    else
        st = PHKS_ERROR_IO;
    if (st == PHKS_OK)
        st = mark_pack_current(db, (int64_t)(db->cache.count - db->cache.dead),
                               true);
    if (st == PHKS_OK)
        commit(db);
    else
        rollback(db);
}

/* Inside a read transaction, into the empty cache: every row, decoded. */
static phks_status load_rows(phks_db *db)
{
    sqlite3_stmt *stmt;
    phks_status st = prepare(db,
                             "SELECT id, name, label, signature FROM entries "
                             "ORDER BY id",
                             &stmt);
    if (st != PHKS_OK)
        return st;
    while (st == PHKS_OK) {
        int rc = sqlite3_step(stmt);
        if (rc == SQLITE_DONE)
            break;
        if (rc != SQLITE_ROW) {
            st = sql_fail(db, rc, "cannot read the entries");
            break;
        }
        int64_t id = sqlite3_column_int64(stmt, 0);
        char what[64];
        snprintf(what, sizeof what, "entry %lld", (long long)id);
        phks_signature *sig;
        st = decode_stored(db, sqlite3_column_blob(stmt, 3),
                           sqlite3_column_bytes(stmt, 3), what, &sig);
        if (st != PHKS_OK)
            break;
        const char *name = (const char *)sqlite3_column_text(stmt, 1);
        const char *label = (const char *)sqlite3_column_text(stmt, 2);
        if (!db->has_options ||
            !phks__options_comparable(&sig->options, &db->options))
            st = phks__fail(PHKS_ERROR_CORRUPT,
                           "%s: %s was made with other options than the "
                           "database's",
                           db->path, what);
        else if (!name && sqlite3_errcode(db->conn) == SQLITE_NOMEM)
            st = phks__fail_oom("database cache");
        else
            st = phks__db_cache_append(&db->cache, id, name ? name : "", label,
                                      sig);
        if (st == PHKS_ERROR_OUT_OF_MEMORY)
            st = phks__fail_oom("database cache");
        else if (st == PHKS_ERROR_INVALID_ARGUMENT)
            st = id < 1 ? id_below_one(db, id)
                        : phks__fail(PHKS_ERROR_CORRUPT,
                                    "%s: %s is out of place", db->path, what);
        phks_signature_free(sig);
    }
    sqlite3_finalize(stmt);
    return st;
}

/* Loads that read the chunks, and loads that decoded the rows. */
static atomic_ulong loads_from_pack, loads_from_rows;

void phks__db_load_counts(unsigned long *from_pack, unsigned long *from_rows)
{
    *from_pack = atomic_load(&loads_from_pack);
    *from_rows = atomic_load(&loads_from_rows);
}

/* Reads every entry into a new cache in one read transaction: from the
 * packed chunks when they are current, else from the rows. Called with
 * lock held; takes cache_lock. */
static phks_status reload(phks_db *db)
{
    pthread_rwlock_wrlock(&db->cache_lock);
    drop_cache(db);
    int64_t version = 0;
    pack_state ps = {0};
    bool from_rows = true, rebuilt = false;
    phks_status st = begin(db, false);
    if (st == PHKS_OK && !db->has_options)
        st = read_options(db);
    if (st == PHKS_OK && db->use_pack)
        st = read_pack_state(db, &ps);
    if (st == PHKS_OK && db->use_pack && pack_current(&ps)) {
        st = load_pack(db, &ps);
        from_rows = st == PHKS_ERROR_CORRUPT;
        if (from_rows) {
            drop_cache(db);
            st = PHKS_OK;
        }
    }
    if (st == PHKS_OK && from_rows) {
        rebuilt = db->use_pack && !db->readonly;
        st = load_rows(db);
    }
    /* Read inside the transaction: the version of the state just read. */
    if (st == PHKS_OK)
        st = data_version(db, &version);
    if (st == PHKS_OK)
        st = commit(db);
    if (st == PHKS_OK) {
        db->cache_loaded = true;
        db->cache_version = version;
        atomic_fetch_add(from_rows ? &loads_from_rows : &loads_from_pack, 1);
    } else {
        rollback(db);
        drop_cache(db);
    }
    pthread_rwlock_unlock(&db->cache_lock);
    /* No writer can change the cache while lock is held: it is read
     * without cache_lock, and queries may scan it meanwhile. */
    if (st == PHKS_OK && rebuilt)
        persist_pack(db, ps.changes);
    return st;
}

/* Brings the cache up to date with the file. Called with lock held. */
static phks_status refresh(phks_db *db)
{
    int64_t version = 0;
    phks_status st = data_version(db, &version);
    if (st != PHKS_OK || (db->cache_loaded && version == db->cache_version))
        return st;
    return reload(db);
}

/* ---- writes */

static phks_status check_entry(const char *where, const phks_db_entry *e)
{
    if (!e->name || !e->signature)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT, "%s: NULL %s", where,
                         e->name ? "signature" : "name");
    if (!valid_utf8(e->name))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "%s: the name is not valid UTF-8", where);
    if (e->label && !valid_utf8(e->label))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "%s: the label is not valid UTF-8", where);
    if (e->signature->count == 0)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "%s: the signature has no features", where);
    return PHKS_OK;
}

static void where_of(char *where, size_t size, const char *fn, bool batch,
                     size_t i)
{
    if (batch)
        snprintf(where, size, "%s: entry %zu", fn, i);
    else
        snprintf(where, size, "%s", fn);
}

/* Inserts the entries inside the open write transaction. */
static phks_status insert_all(phks_db *db, const char *fn, bool batch,
                              const phks_db_entry *entries, size_t count,
                              int64_t *ids)
{
    sqlite3_stmt *stmt;
    phks_status st = prepare(db,
                             "INSERT INTO entries (name, label, signature) "
                             "VALUES (?1, ?2, ?3)",
                             &stmt);
    unsigned char *blob = NULL;
    size_t room = 0;
    for (size_t i = 0; st == PHKS_OK && i < count; i++) {
        const phks_db_entry *e = &entries[i];
        size_t size = phks_signature_encoded_size(e->signature);
        if (size > room) {
            phks__free(blob);
            room = size;
            if (!(blob = phks__malloc(room))) {
                st = phks__fail_oom("database entry");
                break;
            }
        }
        if ((st = phks_signature_encode(e->signature, blob, room, &size)) !=
            PHKS_OK)
            break;
        if (size > INT_MAX) {
            st = phks__fail(PHKS_ERROR_TOO_LARGE, "%s: signature of %zu bytes",
                           fn, size);
            break;
        }
        bool no_label = !e->label || !*e->label;
        int rc = sqlite3_bind_text(stmt, 1, e->name, -1, SQLITE_STATIC);
        if (rc == SQLITE_OK)
            rc = no_label ? sqlite3_bind_null(stmt, 2)
                          : sqlite3_bind_text(stmt, 2, e->label, -1,
                                              SQLITE_STATIC);
        if (rc == SQLITE_OK)
            rc = sqlite3_bind_blob(stmt, 3, blob, (int)size, SQLITE_STATIC);
        if (rc == SQLITE_OK)
            rc = sqlite3_step(stmt);
        if (rc != SQLITE_DONE) {
            char where[64];
            where_of(where, sizeof where, fn, batch, i);
            st = sql_fail(db, rc, where);
            break;
        }
        ids[i] = sqlite3_last_insert_rowid(db->conn);
        sqlite3_reset(stmt);
        sqlite3_clear_bindings(stmt);
    }
    sqlite3_finalize(stmt);
    phks__free(blob);
    return st;
}

/* Inside the write transaction: the options of the file (another process
 * may have set them since) must be those of the entries; the first entry
 * ever added sets them. *set tells the caller to adopt them on commit. */
static phks_status settle_options(phks_db *db, const char *fn,
                                  const phks_options *mine, bool *set)
{
    *set = false;
    phks_status st = db->has_options ? PHKS_OK : read_options(db);
    if (st != PHKS_OK)
        return st;
    if (db->has_options)
        return phks__options_comparable(mine, &db->options)
                   ? PHKS_OK
                   : phks__fail(PHKS_ERROR_INCOMPATIBLE,
                               "%s: the signature was made with other "
                               "options than the database's",
                               fn);
    void *blob;
    size_t size;
    if ((st = options_blob(mine, &blob, &size)) != PHKS_OK)
        return st;
    sqlite3_stmt *stmt;
    st = prepare(db, "INSERT INTO meta (key, value) VALUES ('options', ?1)",
                 &stmt);
    if (st == PHKS_OK) {
        int rc = sqlite3_bind_blob(stmt, 1, blob, (int)size, SQLITE_STATIC);
        if (rc == SQLITE_OK)
            rc = sqlite3_step(stmt);
        if (rc != SQLITE_DONE)
            st = sql_fail(db, rc, "cannot record the options");
        sqlite3_finalize(stmt);
    }
    phks__free(blob);
    *set = st == PHKS_OK;
    return st;
}

static phks_status add_entries(phks_db *db, const char *fn, bool batch,
                               const phks_db_entry *entries, size_t count,
                               int64_t *ids)
{
    char where[64];
    if (!db || (count && !entries))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT, "%s: NULL argument", fn);
    if (db->readonly)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT, "%s: %s is open read-only",
                         fn, db->path);
    for (size_t i = 0; i < count; i++) {
        where_of(where, sizeof where, fn, batch, i);
        phks_status st = check_entry(where, &entries[i]);
        if (st != PHKS_OK)
            return st;
        char detail[128];
        if (phks__options_difference(&entries[i].signature->options,
                                     &entries[0].signature->options, false,
                                     detail, sizeof detail))
            return phks__fail(PHKS_ERROR_INCOMPATIBLE,
                             "%s: made with other options than entry 0 (%s)",
                             where, detail);
    }
    if (count == 0)
        return PHKS_OK;
    int64_t *new_ids = phks__malloc_array(count, sizeof *new_ids);
    if (!new_ids)
        return phks__fail_oom(fn);

    pthread_mutex_lock(&db->lock);
    const phks_options *mine = &entries[0].signature->options;
    bool set = false;
    phks_status st = PHKS_OK;
    char detail[128];
    if (db->has_options &&
        phks__options_difference(mine, &db->options, false, detail,
                                 sizeof detail))
        st = phks__fail(PHKS_ERROR_INCOMPATIBLE,
                       "%s: the signature was made with other options than "
                       "the database's (%s)",
                       fn, detail);
    if (st == PHKS_OK && (st = begin(db, true)) == PHKS_OK) {
        pack_state ps = {0};
        st = settle_options(db, fn, mine, &set);
        if (st == PHKS_OK && db->use_pack)
            st = read_pack_state(db, &ps);
        if (st == PHKS_OK)
            st = insert_all(db, fn, batch, entries, count, new_ids);
        /* Chunks that were current before stay so; stale ones stay
         * stale (the triggers counted these rows). */
        bool kept = false;
        if (st == PHKS_OK && db->use_pack && pack_current(&ps))
            st = pack_append(db, entries, new_ids, count, &kept);
        if (st == PHKS_OK && kept)
            st = mark_pack_current(db, 0, false);
        st = st == PHKS_OK ? commit(db) : (rollback(db), st);
    }
    if (st == PHKS_OK) {
        if (set) {
            db->options = *mine;
            db->has_options = true;
        }
        if (db->cache_loaded) {
            pthread_rwlock_wrlock(&db->cache_lock);
            for (size_t i = 0; i < count && db->cache_loaded; i++)
                if (phks__db_cache_append(&db->cache, new_ids[i],
                                         entries[i].name, entries[i].label,
                                         entries[i].signature) != PHKS_OK)
                    drop_cache(db); /* the next query reloads */
            pthread_rwlock_unlock(&db->cache_lock);
        }
        if (ids)
            memcpy(ids, new_ids, count * sizeof *ids);
    }
    pthread_mutex_unlock(&db->lock);
    phks__free(new_ids);
    return st;
}

phks_status phks_db_add(phks_db *db, const char *name, const char *label,
                        const phks_signature *signature, int64_t *id)
{
    phks_db_entry e = {name, label, signature};
    return add_entries(db, "phks_db_add", false, &e, 1, id);
}

phks_status phks_db_add_batch(phks_db *db, const phks_db_entry *entries,
                              size_t count, int64_t *ids)
{
    return add_entries(db, "phks_db_add_batch", true, entries, count, ids);
}

phks_status phks_db_remove(phks_db *db, int64_t id)
{
    if (!db)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_db_remove: NULL database");
    if (db->readonly)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_db_remove: %s is open read-only", db->path);
    pthread_mutex_lock(&db->lock);
    sqlite3_stmt *stmt;
    pack_state ps = {0};
    /* The row and its chunk in one transaction. */
    phks_status st = begin(db, true);
    if (st == PHKS_OK && db->use_pack)
        st = read_pack_state(db, &ps);
    if (st == PHKS_OK &&
        (st = prepare(db, "DELETE FROM entries WHERE id = ?1", &stmt)) ==
            PHKS_OK) {
        sqlite3_bind_int64(stmt, 1, id);
        int rc = sqlite3_step(stmt);
        if (rc != SQLITE_DONE)
            st = sql_fail(db, rc, "phks_db_remove");
        else if (sqlite3_changes(db->conn) == 0)
            st = phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                           "phks_db_remove: no entry with id %lld",
                           (long long)id);
        sqlite3_finalize(stmt);
    }
    bool kept = false;
    if (st == PHKS_OK && db->use_pack && pack_current(&ps))
        st = pack_remove(db, id, &kept);
    if (st == PHKS_OK && kept)
        st = mark_pack_current(db, 0, false);
    if (st == PHKS_OK)
        st = commit(db);
    else if (db->conn)
        rollback(db);
    if (st == PHKS_OK && db->cache_loaded) {
        pthread_rwlock_wrlock(&db->cache_lock);
        phks__db_cache_remove(&db->cache, id);
        pthread_rwlock_unlock(&db->cache_lock);
    }
    pthread_mutex_unlock(&db->lock);
    return st;
}

/* ---- reads */

phks_status phks_db_count(phks_db *db, size_t *count)
{
    if (count)
        *count = 0;
    if (!db || !count)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_db_count: NULL argument");
    int64_t n = 0;
    pthread_mutex_lock(&db->lock);
    sqlite3_stmt *stmt;
    /* One statement, one snapshot; each subquery is a single b-tree
     * operation (count, and the first rowid). */
    phks_status st = prepare(db,
                             "SELECT (SELECT count(*) FROM entries),"
                             " (SELECT min(id) FROM entries)",
                             &stmt);
    if (st == PHKS_OK) {
        int rc = sqlite3_step(stmt);
        if (rc != SQLITE_ROW)
            st = sql_fail(db, rc == SQLITE_DONE ? SQLITE_CORRUPT : rc,
                          "phks_db_count");
        else if (sqlite3_column_type(stmt, 1) != SQLITE_NULL &&
                 sqlite3_column_int64(stmt, 1) < 1)
            st = id_below_one(db, sqlite3_column_int64(stmt, 1));
        else
            n = sqlite3_column_int64(stmt, 0);
        sqlite3_finalize(stmt);
    }
    pthread_mutex_unlock(&db->lock);
    if (st == PHKS_OK)
        *count = (size_t)n;
    return st;
}

phks_status phks_db_list(phks_db *db, int64_t after_id, int64_t *ids,
                         size_t capacity, size_t *count)
{
    if (count)
        *count = 0;
    if (!db || !count || (!ids && capacity))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_db_list: NULL argument");
    if (capacity == 0)
        return PHKS_OK;
    pthread_mutex_lock(&db->lock);
    sqlite3_stmt *stmt;
    size_t n = 0;
    /* A first page (after_id below 1) starts at the very first row, so
     * that it meets any id below 1. */
    phks_status st = prepare(db,
                             after_id < 1
                                 ? "SELECT id FROM entries ORDER BY id LIMIT ?2"
                                 : "SELECT id FROM entries WHERE id > ?1 "
                                   "ORDER BY id LIMIT ?2",
                             &stmt);
    if (st == PHKS_OK) {
        sqlite3_bind_int64(stmt, 1, after_id);
        sqlite3_bind_int64(stmt, 2,
                           capacity > INT64_MAX ? INT64_MAX : (int64_t)capacity);
        int rc = SQLITE_DONE;
        /* A damaged b-tree can return rowids out of order; a caller
         * paging from the last id would then loop for ever. */
        while (st == PHKS_OK && n < capacity &&
               (rc = sqlite3_step(stmt)) == SQLITE_ROW) {
            int64_t id = sqlite3_column_int64(stmt, 0);
            if (id < 1)
                st = id_below_one(db, id);
            else if (id <= (n ? ids[n - 1] : after_id))
                st = phks__fail(PHKS_ERROR_CORRUPT,
                               "phks_db_list: ids out of order, the file is "
                               "damaged");
            else
                ids[n++] = id;
        }
        if (st == PHKS_OK && n < capacity && rc != SQLITE_DONE)
            st = sql_fail(db, rc, "phks_db_list");
        sqlite3_finalize(stmt);
    }
    pthread_mutex_unlock(&db->lock);
    if (st == PHKS_OK)
        *count = n;
    return st;
}

/* Column i as text ("" for NULL) and its length; NULL when SQLite runs
 * out of memory converting it. */
static const char *column_text(sqlite3_stmt *stmt, int i, size_t *len)
{
    if (sqlite3_column_type(stmt, i) == SQLITE_NULL) {
        *len = 0;
        return "";
    }
    const char *s = (const char *)sqlite3_column_text(stmt, i);
    *len = (size_t)sqlite3_column_bytes(stmt, i);
    return s;
}

phks_status phks_db_get(phks_db *db, int64_t id, phks_signature **signature,
                        char *name, size_t name_capacity, char *label,
                        size_t label_capacity)
{
    if (signature)
        *signature = NULL;
    if (!db || (!name && name_capacity) || (!label && label_capacity))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_db_get: NULL argument");
    pthread_mutex_lock(&db->lock);
    sqlite3_stmt *stmt;
    phks_signature *sig = NULL;
    phks_status st = prepare(
        db, "SELECT name, label, signature FROM entries WHERE id = ?1", &stmt);
    if (st != PHKS_OK) {
        pthread_mutex_unlock(&db->lock);
        return st;
    }
    sqlite3_bind_int64(stmt, 1, id);
    int rc = sqlite3_step(stmt);
    if (rc == SQLITE_DONE)
        st = phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                       "phks_db_get: no entry with id %lld", (long long)id);
    else if (rc != SQLITE_ROW)
        st = sql_fail(db, rc, "phks_db_get");
    size_t name_len = 0, label_len = 0;
    const char *n = NULL, *l = NULL;
    if (st == PHKS_OK) {
        n = column_text(stmt, 0, &name_len);
        l = column_text(stmt, 1, &label_len);
        if (!n || !l)
            st = phks__fail_oom("phks_db_get");
        else if (name && name_len >= name_capacity)
            st = phks__fail(PHKS_ERROR_BUFFER_TOO_SMALL,
                           "phks_db_get: the name needs %zu bytes, room for %zu",
                           name_len + 1, name_capacity);
        else if (label && label_len >= label_capacity)
            st = phks__fail(PHKS_ERROR_BUFFER_TOO_SMALL,
                           "phks_db_get: the label needs %zu bytes, room for "
                           "%zu",
                           label_len + 1, label_capacity);
    }
    if (st == PHKS_OK && signature) {
        char what[64];
        snprintf(what, sizeof what, "entry %lld", (long long)id);
        st = decode_stored(db, sqlite3_column_blob(stmt, 2),
                           sqlite3_column_bytes(stmt, 2), what, &sig);
    }
    if (st == PHKS_OK) {
        if (name) {
            memcpy(name, n, name_len);
            name[name_len] = '\0';
        }
        if (label) {
            memcpy(label, l, label_len);
            label[label_len] = '\0';
        }
        if (signature)
            *signature = sig;
    }
    sqlite3_finalize(stmt);
    pthread_mutex_unlock(&db->lock);
    return st;
}

phks_status phks_db_query(phks_db *db, const phks_signature *query, size_t k,
                          phks_hit *hits, size_t *count)
{
    if (count)
        *count = 0;
    if (!db || !query || !hits || !count)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_db_query: NULL argument");
    if (k == 0)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT, "phks_db_query: k is 0");
    /* Verified matching: the scan shortlists, db_rerank.c decides. */
    bool verified = query->options.matching == PHKS_MATCHING_VERIFIED;
    size_t m = k > PHKS__DB_SHORTLIST ? k : PHKS__DB_SHORTLIST, listed = 0;
    phks_hit *shortlist = verified ? phks__malloc_array(m, sizeof *shortlist)
                                   : NULL;
    if (verified && !shortlist)
        return phks__fail_oom("phks_db_query");
    /* A writer that runs out of memory updating the cache drops it; the
     * scan then finds it unloaded and refreshes again. */
    for (;;) {
        pthread_mutex_lock(&db->lock);
        phks_status st = refresh(db);
        char detail[128];
        if (st == PHKS_OK && db->has_options &&
            phks__options_difference(&query->options, &db->options, false,
                                     detail, sizeof detail))
            st = phks__fail(PHKS_ERROR_INCOMPATIBLE,
                           "phks_db_query: the query was made with other "
                           "options than the database's (%s)",
                           detail);
        pthread_mutex_unlock(&db->lock);
        if (st != PHKS_OK) {
            phks__free(shortlist);
            return st;
        }
        pthread_rwlock_rdlock(&db->cache_lock);
        if (db->cache_loaded) {
            st = verified ? phks__db_cache_query(&db->cache, query, m,
                                                 shortlist, &listed)
                          : phks__db_cache_query(&db->cache, query, k, hits,
                                                 count);
            pthread_rwlock_unlock(&db->cache_lock);
            if (st == PHKS_OK && verified)
                st = phks__db_rerank(db, query, shortlist, listed, k, hits,
                                     count);
            phks__free(shortlist);
            return st;
        }
        pthread_rwlock_unlock(&db->cache_lock);
    }
}
