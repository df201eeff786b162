/*
 * db_sql.c - the layer's few words of SQLite: statuses and messages for
 * its failures, statements, transactions, and the errors that say a
 * file's contents are damaged.
 *
 * Every failure names the file (db->path) and what was being done, then
 * SQLite's own message: read right after the failing call, with the
 * handle's lock held, it is that call's.
 */
#include "db/db.h"

#include <stdio.h>
#include <string.h>

/* ---- SQLite errors */

phks_status phks__db_sql_status(int rc)
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

/* The system's reason behind an I/O error, or 0: SQLite says "disk I/O
 * error" alike for a full disk (the WAL's shared-memory file cannot grow),
 * a missing permission or a failing device. */
static int system_errno(const phks_db *db, int rc)
{
    int primary = rc & 0xff;
    bool io = primary == SQLITE_IOERR || primary == SQLITE_CANTOPEN ||
              primary == SQLITE_FULL;
    return io && db->conn ? sqlite3_system_errno(db->conn) : 0;
}

phks_status phks__db_sql_fail(const phks_db *db, int rc, const char *what)
{
    const char *detail = db->conn ? sqlite3_errmsg(db->conn) : sqlite3_errstr(rc);
    int os = system_errno(db, rc);
    char reason[160] = "";
    /* strerror_r: handles are used from many threads. */
    if (os && strerror_r(os, reason + 2, sizeof reason - 3) == 0) {
        memcpy(reason, " (", 2);
        strcat(reason, ")");
    }
    return phks__fail(phks__db_sql_status(rc), "%s: %s: %s%s", db->path, what,
                      detail, reason);
}

/* ---- statements */

phks_status phks__db_prepare(phks_db *db, const char *sql, sqlite3_stmt **stmt)
{
    int rc = sqlite3_prepare_v2(db->conn, sql, -1, stmt, NULL);
    if (rc != SQLITE_OK) {
        *stmt = NULL;
        return phks__db_sql_fail(db, rc,
                                 phks__db_sql_status(rc) == PHKS_ERROR_CORRUPT
                                     ? "not a libphks database"
                                     : "cannot prepare a statement");
    }
    return PHKS_OK;
}

phks_status phks__db_query_int(phks_db *db, const char *sql, int64_t *value)
{
    sqlite3_stmt *stmt;
    phks_status st = phks__db_prepare(db, sql, &stmt);
    if (st != PHKS_OK)
        return st;
    int rc = sqlite3_step(stmt);
    if (rc == SQLITE_ROW)
        *value = sqlite3_column_int64(stmt, 0);
    else
        st = phks__db_sql_fail(db, rc == SQLITE_DONE ? SQLITE_CORRUPT : rc, sql);
    sqlite3_finalize(stmt);
    return st;
}

phks_status phks__db_exec(phks_db *db, const char *sql, const char *what)
{
    int rc = sqlite3_exec(db->conn, sql, NULL, NULL, NULL);
    return rc == SQLITE_OK ? PHKS_OK : phks__db_sql_fail(db, rc, what);
}

phks_status phks__db_exec_id(phks_db *db, const char *sql, int64_t value,
                             const char *what)
{
    sqlite3_stmt *stmt;
    phks_status st = phks__db_prepare(db, sql, &stmt);
    if (st != PHKS_OK)
        return st;
    sqlite3_bind_int64(stmt, 1, value);
    int rc = sqlite3_step(stmt);
    if (rc != SQLITE_DONE)
        st = phks__db_sql_fail(db, rc, what);
    sqlite3_finalize(stmt);
    return st;
}

/* ---- transactions */

void phks__db_rollback(phks_db *db)
{
    if (!sqlite3_get_autocommit(db->conn))
        sqlite3_exec(db->conn, "ROLLBACK", NULL, NULL, NULL);
}

/* A write transaction takes the write lock at once (IMMEDIATE), so two
 * writers queue in the busy handler instead of deadlocking later. */
phks_status phks__db_begin(phks_db *db, bool write)
{
    return phks__db_exec(db, write ? "BEGIN IMMEDIATE" : "BEGIN",
                         write ? "cannot start a write transaction"
                               : "cannot start a read transaction");
}

/* Rolls back when the commit fails. */
static phks_status commit(phks_db *db)
{
    phks_status st = phks__db_exec(db, "COMMIT", "commit failed");
    if (st != PHKS_OK)
        phks__db_rollback(db);
    return st;
}

phks_status phks__db_end(phks_db *db, phks_status st)
{
    if (st == PHKS_OK)
        return commit(db);
    phks__db_rollback(db);
    return st;
}

/* ---- damaged contents */

phks_status phks__db_decode_stored(const phks_db *db, const void *blob,
                                   int size, const char *what,
                                   phks_signature **sig)
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

phks_status phks__db_id_below_one(const phks_db *db, int64_t id)
{
    return phks__fail(PHKS_ERROR_CORRUPT,
                      "%s: entry id %lld: ids start at 1 (the row was "
                      "written by another program)",
                      db->path, (long long)id);
}
