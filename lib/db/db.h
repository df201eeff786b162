/*
 * db.h - the database layer's own declarations, private to it (and its
 * tests). Its files, one concern each:
 *   db_open.c       opening and closing; the header, schema and upgrade
 *   db_sql.c        SQLite errors, statements and transactions
 *   db_options.c    the options every signature of a file shares
 *   db_read.c       count, list, get and query
 *   db_write.c      add and remove, each one write transaction
 *   db_load.c       loading the packed copy and keeping it the file's
 *   db_scan.c       the packed copy in memory and the top-k scan over it
 *   db_pack.c       a packed chunk's bytes
 *   db_pack_table.c the packs table those chunks live in
 *   db_rerank.c     the verified stage of a query
 */
#ifndef PHKS_DB_H
#define PHKS_DB_H

#include "features/features.h"

#include <pthread.h>
#include <sqlite3.h>

/* ---- the packed copy (db_scan.c) */
/* The packed copy of a database's entries that queries scan. Entries stay
 * in ascending id order. Entry e's feature vectors form one block at
 * vectors + vector_at[e]: `length` rows (one per scale) of
 * phks__db_padded(features[e]) values (one per feature), the padding lanes
 * +infinity. text + text_at[e] holds "name\0label\0", each cut to
 * PHKS_DB_TEXT_MAX bytes. Removed entries keep their slot with features 0
 * until more than half the slots are dead. Not locked by itself: the
 * handle guards it with a read-write lock. */
typedef struct phks__db_cache {
    size_t count, dead, capacity; /* slots used, removed, allocated     */
    size_t length;                /* vector length; 0 until the first   */
    uint32_t max_features;        /* largest features[e] ever added     */
    int64_t *ids;
    uint32_t *features;
    size_t *vector_at, *text_at;
    double *vectors;
    size_t vectors_used, vectors_capacity; /* in doubles                */
    char *text;
    size_t text_used, text_capacity;
} phks__db_cache;

/* Feature count rounded up to the scan's lane count. */
size_t phks__db_padded(size_t features);
/* An empty cache; release frees it and leaves it empty. */
void phks__db_cache_init(phks__db_cache *cache);
void phks__db_cache_release(phks__db_cache *cache);
/* Appends an entry whose id is above every id held, with vectors of the
 * same length as the others. Returns PHKS_ERROR_OUT_OF_MEMORY (the cache
 * is left as it was) or PHKS_ERROR_INVALID_ARGUMENT (id below 1 or out of
 * order, other length, no features) without setting a message: the caller,
 * whose own call may still succeed, decides what to report. */
phks_status phks__db_cache_append(phks__db_cache *cache, int64_t id,
                                 const char *name, const char *label,
                                 const phks_signature *signature);
/* Makes room for `slots` more entries, `doubles` more vector values and
 * `text` more text bytes (PHKS_ERROR_OUT_OF_MEMORY; nothing is lost). */
phks_status phks__db_cache_reserve(phks__db_cache *cache, size_t slots,
                                  size_t doubles, size_t text);
/* The slot holding id (removed or not), or cache->count. */
size_t phks__db_cache_find(const phks__db_cache *cache, int64_t id);
/* Marks entry id removed (no-op if absent); compacts in place. */
void phks__db_cache_remove(phks__db_cache *cache, int64_t id);
/* The k best entries for query, as phks_db_query documents; the query's
 * vector length must be the cache's. Safe from many threads at once. */
phks_status phks__db_cache_query(const phks__db_cache *cache,
                                const phks_signature *query, size_t k,
                                phks_hit *hits, size_t *count);

/* ---- the handle (db_open.c) */
/* Locking: `lock` serialises everything that touches the connection (one
 * SQLite connection cannot hold two transactions) and guards the options
 * and the cache's state; `cache_lock` lets many queries scan the cache at
 * once while a write or a reload changes it. Order: lock, then
 * cache_lock; a scan holds cache_lock alone. */
struct phks_db {
    sqlite3 *conn;
    char *path;          /* as given, for messages */
    bool readonly;
    int format;          /* the file's user_version: 1 (read-only) or 2 */
    bool use_pack;       /* format 2 and a file: keep the packs table    */
    pthread_mutex_t lock;
    pthread_rwlock_t cache_lock;
    bool lock_ready, cache_lock_ready;
    double busy_since;   /* when the busy handler's wait began (db_open.c) */
    sqlite3_stmt *version; /* PRAGMA data_version */
    bool has_options;    /* the options are set once and never change */
    phks_options options;
    bool cache_loaded;
    int64_t cache_version;
    phks__db_cache cache;
};

/* ---- SQLite (db_sql.c) */
/* The status of SQLite's result code rc. */
phks_status phks__db_sql_status(int rc);
/* Fails with rc's status and "path: what: SQLite's message". Must be
 * called right after the failing SQLite call, with lock held. */
phks_status phks__db_sql_fail(const phks_db *db, int rc, const char *what);
/* A statement for sql (*stmt NULL on failure: then the file lacks our
 * tables, or is no database, or memory ran out). */
phks_status phks__db_prepare(phks_db *db, const char *sql, sqlite3_stmt **stmt);
/* The integer in the first column of the one row sql gives. */
phks_status phks__db_query_int(phks_db *db, const char *sql, int64_t *value);
/* Runs sql (statements without parameters); what names it in messages. */
phks_status phks__db_exec(phks_db *db, const char *sql, const char *what);
/* Runs the statement sql, which yields no row, with value as ?1. */
phks_status phks__db_exec_id(phks_db *db, const char *sql, int64_t value,
                             const char *what);
/* Transactions: begin (a write transaction takes the write lock at
 * once), rollback (no-op outside a transaction), and end: commit when st
 * is PHKS_OK (rolled back if the commit fails), else roll back and
 * return st. */
phks_status phks__db_begin(phks_db *db, bool write);
void phks__db_rollback(phks_db *db);
phks_status phks__db_end(phks_db *db, phks_status st);
/* Decodes a stored signature blob, what naming it. A blob of a newer
 * format (written by a newer library) keeps its status; every other
 * failure but memory means a damaged file. */
phks_status phks__db_decode_stored(const phks_db *db, const void *blob,
                                   int size, const char *what,
                                   phks_signature **sig);
/* Ids start at 1: SQLite's AUTOINCREMENT never gives less, but another
 * program can write any id. Count, list (whose first page starts after
 * id 0) and query would disagree about such a row, so all three refuse
 * the file as damaged with this error; get and remove still reach the
 * row by its id. */
phks_status phks__db_id_below_one(const phks_db *db, int64_t id);

/* ---- options (db_options.c) */
/* Reads the meta 'options' into db if present (they never change once
 * committed, so keeping them is safe even if the caller rolls back). */
phks_status phks__db_read_options(phks_db *db);
/* PHKS_ERROR_INCOMPATIBLE, "fn: the what was made with other options
 * than the database's (detail)", when options differ from the ones db
 * knows of. */
phks_status phks__db_check_options(const phks_db *db, const char *fn,
                                   const char *what,
                                   const phks_options *options);
/* Inside the write transaction: the options of the file (another process
 * may have set them since) must be mine; the first entry ever added sets
 * them. *set tells the caller to adopt them on commit. */
phks_status phks__db_settle_options(phks_db *db, const char *fn,
                                    const phks_options *mine, bool *set);

/* ---- the loaded copy (db_load.c), called with lock held */
/* Brings the cache up to date with the file (takes cache_lock). */
phks_status phks__db_refresh(phks_db *db);
/* Empties the cache; the next refresh loads it. */
void phks__db_drop_cache(phks_db *db);
/* For the tests: how many loads of a handle's cache, since the process
 * started, read the packed chunks, and how many decoded the rows. */
void phks__db_load_counts(unsigned long *from_pack, unsigned long *from_rows);

/* ---- reads (db_read.c) */
/* Entry id's signature, as phks_db_get reads it (takes lock):
 * PHKS_ERROR_INVALID_ARGUMENT, *signature NULL, when there is none. */
phks_status phks__db_get_signature(phks_db *db, int64_t id,
                                   phks_signature **signature);

/* ---- the verified stage (db_rerank.c) */
/* Entries the packed scan hands to the verified score: re-ranking 100
 * instead changes no answer of the benchmark (docs/retrieval.md), and
 * each costs a verification (docs/benchmarks.md). */
#define PHKS__DB_SHORTLIST 32
/* Scores shortlist's m entries (read from db) by the verified score of
 * query, and returns the k best as phks_db_query does; entries removed
 * since the scan are left out. shortlist is reordered. */
phks_status phks__db_rerank(phks_db *db, const phks_signature *query,
                            phks_hit *shortlist, size_t m, size_t k,
                            phks_hit *hits, size_t *count);

/* ---- packed chunks (db_pack.c; docs/formats.md, "Packed chunks") */
/* The persisted form of a run of cache entries. */
/* Reads n bytes at offset of a chunk into dst; a status on failure. */
typedef phks_status (*phks__db_pack_read_fn)(void *ctx, void *dst, size_t n,
                                            size_t offset);
/* The chunk of the live entries of slots [begin, end) into a new *blob
 * (phks__free) of *size bytes holding *entries entries. Errors:
 * PHKS_ERROR_INVALID_ARGUMENT (no live entry), PHKS_ERROR_OUT_OF_MEMORY. */
phks_status phks__db_pack_encode(const phks__db_cache *cache, size_t begin,
                                size_t end, unsigned char **blob,
                                size_t *size, size_t *entries);
/* About the bytes the chunk of every slot of cache would take. */
size_t phks__db_pack_bytes(const phks__db_cache *cache);
/* Appends the entries of a chunk of `size` bytes, read through read, to
 * cache: their ids must be at least start and above every id held. On
 * PHKS_ERROR_CORRUPT (checksum, layout or order wrong; no message set),
 * PHKS_ERROR_OUT_OF_MEMORY (no message) or the reader's status, the
 * cache holds what it held. */
phks_status phks__db_pack_decode(phks__db_cache *cache, int64_t start,
                                size_t size, phks__db_pack_read_fn read,
                                void *ctx);

/* ---- the packs table (db_pack_table.c), with lock held */
/* The row of pack_state (present false in a file without one). */
typedef struct phks__db_pack_state {
    bool present;
    int64_t rows, changes, pack_changes;
} phks__db_pack_state;
phks_status phks__db_pack_state_read(phks_db *db, phks__db_pack_state *ps);
/* Whether the chunks cover every change pack_state counted. */
bool phks__db_pack_current(const phks__db_pack_state *ps);
/* Inside a read transaction, into the empty cache: every chunk, if they
 * cover the rows ps (current) counts. PHKS_ERROR_CORRUPT without a
 * message when they do not, or one is damaged: the caller rebuilds from
 * the rows. */
phks_status phks__db_pack_load(phks_db *db, const phks__db_pack_state *ps);
/* After a rebuild from the rows, on a writable handle: the chunks from
 * the new cache, in their own transaction, if no other connection
 * changed the rows since (changes is what pack_state counted then).
 * Failures only leave the chunks stale for the next load. */
void phks__db_pack_persist(phks_db *db, int64_t changes);
/* Inside the write transaction that added entries with ids (ascending,
 * above every other) to current chunks: appends them to the last chunk
 * while it is small, then to new chunks, and marks the chunks current.
 * Damaged chunks are left stale, to be rebuilt. */
phks_status phks__db_pack_append(phks_db *db, const phks_db_entry *entries,
                                 const int64_t *ids, size_t count);
/* Likewise inside the write transaction that removed entry id. */
phks_status phks__db_pack_remove(phks_db *db, int64_t id);

#endif /* PHKS_DB_H */
