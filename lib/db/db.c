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
 * Locking: `lock` serialises everything that touches the connection (one
 * SQLite connection cannot hold two transactions) and guards the options
 * and the cache's state; `cache_lock` lets many queries scan the cache at
 * once while a write or a reload changes it. Order: lock, then
 * cache_lock; a scan holds cache_lock alone.
 *
 * Cache refresh: PRAGMA data_version changes when another connection (this
 * process or another) commits. Each query compares it with the value read
 * when the cache was loaded and reloads on a change. This handle's own
 * writes leave data_version as it is and update the cache in place.
 */
#include "db/db_cache.h"

#include <limits.h>
#include <pthread.h>
#include <sqlite3.h>
#include <stdio.h>
#include <string.h>

#define DB_APPLICATION_ID 0x50484B53 /* "PHKS" */
#define DB_FORMAT 1
#define DB_BUSY_MS 5000

struct phks_db {
    sqlite3 *conn;
    char *path;          /* as given, for messages */
    bool readonly;
    pthread_mutex_t lock;
    pthread_rwlock_t cache_lock;
    bool lock_ready, cache_lock_ready;
    sqlite3_stmt *version; /* PRAGMA data_version */
    bool has_options;    /* the options are set once and never change */
    phks_options options;
    bool cache_loaded;
    int64_t cache_version;
    phks__db_cache cache;
};

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
    phks_status st = phks__signature_alloc(1, options->scale_count, &sig);
    if (st != PHKS_OK)
        return st;
    sig->options = *options;
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

static const char schema[] =
    "PRAGMA application_id = 1346915155;" /* DB_APPLICATION_ID */
    "PRAGMA user_version = 1;"            /* DB_FORMAT */
    "CREATE TABLE meta (key TEXT PRIMARY KEY NOT NULL, value);"
    "CREATE TABLE entries (id INTEGER PRIMARY KEY AUTOINCREMENT,"
    " name TEXT NOT NULL, label TEXT, signature BLOB NOT NULL);";

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

/* The meta format must match the header; the entries table must have our
 * columns; the options are read if set. */
static phks_status check_tables(phks_db *db)
{
    int64_t format;
    phks_status st =
        query_int(db, "SELECT value FROM meta WHERE key = 'format'", &format);
    if (st == PHKS_OK && format != DB_FORMAT)
        st = phks__fail(PHKS_ERROR_CORRUPT,
                       "%s: meta 'format' %lld does not match the header",
                       db->path, (long long)format);
    sqlite3_stmt *stmt;
    if (st == PHKS_OK)
        st = prepare(db, "SELECT id, name, label, signature FROM entries",
                     &stmt);
    if (st == PHKS_OK)
        sqlite3_finalize(stmt);
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
    /* Only a file known to be ours (or empty) is switched to WAL. The mode
     * is stored in the file; where WAL is impossible SQLite keeps its
     * rollback journal, which is as safe, only less concurrent. */
    if (!db->readonly && !memory)
        st = exec(db, "PRAGMA journal_mode = WAL", "cannot set WAL mode");
    if (st == PHKS_OK)
        st = exec(db, "PRAGMA synchronous = FULL", "cannot set synchronous");
    if (st == PHKS_OK && empty)
        st = create_schema(db);
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

/* Reads every entry into a new cache in one read transaction. Called with
 * lock held; takes cache_lock. */
static phks_status reload(phks_db *db)
{
    pthread_rwlock_wrlock(&db->cache_lock);
    drop_cache(db);
    sqlite3_stmt *stmt = NULL;
    int64_t version = 0;
    phks_status st = begin(db, false);
    if (st == PHKS_OK && !db->has_options)
        st = read_options(db);
    if (st == PHKS_OK)
        st = prepare(db,
                     "SELECT id, name, label, signature FROM entries "
                     "ORDER BY id",
                     &stmt);
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
    /* Read inside the transaction: the version of the state just read. */
    if (st == PHKS_OK)
        st = data_version(db, &version);
    if (st == PHKS_OK)
        st = commit(db);
    if (st == PHKS_OK) {
        db->cache_loaded = true;
        db->cache_version = version;
    } else {
        rollback(db);
        drop_cache(db);
    }
    pthread_rwlock_unlock(&db->cache_lock);
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
        st = settle_options(db, fn, mine, &set);
        if (st == PHKS_OK)
            st = insert_all(db, fn, batch, entries, count, new_ids);
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
    /* One statement in autocommit mode: one transaction. */
    phks_status st = prepare(db, "DELETE FROM entries WHERE id = ?1", &stmt);
    if (st == PHKS_OK) {
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
        if (st != PHKS_OK)
            return st;
        pthread_rwlock_rdlock(&db->cache_lock);
        if (db->cache_loaded) {
            st = phks__db_cache_query(&db->cache, query, k, hits, count);
            pthread_rwlock_unlock(&db->cache_lock);
            return st;
        }
        pthread_rwlock_unlock(&db->cache_lock);
    }
}
