/*
 * fuzz_db.c - a shape database file made of any bytes: phks_db_open
 * (writable, so the header checks, the switch to WAL and the table checks
 * all run), then every read the API offers and one write of each kind,
 * each checked against the others:
 *   - list pages through ascending ids, no more than count says (on
 *     damaged files, see below);
 *   - get on every listed id gives a signature, or an error and a message;
 *   - a query returns at most k hits, of listed ids, best first;
 *   - an add either fails cleanly or makes the count grow by one, and a
 *     remove of what was added brings it back.
 * The file lives in /dev/shm (else $TMPDIR or /tmp) and is removed, with
 * SQLite's -wal, -shm and -journal files, after each input.
 */
#include "fuzz_common.h"

#include <sqlite3.h>
#include <unistd.h>

static char path[512];

static void remove_files(void)
{
    static const char *suffix[] = {"", "-wal", "-shm", "-journal"};
    char name[sizeof path + 16];
    for (int i = 0; i < 4; i++) {
        snprintf(name, sizeof name, "%s%s", path, suffix[i]);
        unlink(name);
    }
}

/* Whether SQLite's own integrity check finds the file damaged. A file
 * whose pages are linked twice passes every check a read makes, and then
 * a write through one table can change another (found by this target: an
 * add that did not grow the count). Nothing can be promised for such a
 * file beyond a clean status and no crash, so the count invariants are
 * waived when, and only when, this says so. */
static bool damaged(void)
{
    sqlite3 *s = NULL;
    sqlite3_stmt *st = NULL;
    bool bad = true;
    if (sqlite3_open_v2(path, &s, SQLITE_OPEN_READONLY, NULL) == SQLITE_OK &&
        sqlite3_prepare_v2(s, "PRAGMA integrity_check", -1, &st, NULL) ==
            SQLITE_OK &&
        sqlite3_step(st) == SQLITE_ROW) {
        const unsigned char *text = sqlite3_column_text(st, 0);
        bad = !text || strcmp((const char *)text, "ok") != 0;
    }
    sqlite3_finalize(st);
    sqlite3_close(s);
    return bad;
}

/* A compatible query signature: two features with the default options. */
static phks_signature *query_signature(void)
{
    phks_signature *sig = NULL;
    FUZZ_CHECK(phks__signature_alloc(2, 0, 15, &sig) == PHKS_OK);
    FUZZ_CHECK(phks_options_init(&sig->options) == PHKS_OK);
    FUZZ_CHECK(phks__signature_alloc_layout(sig) == PHKS_OK);
    sig->geodesic[0] = 1;
    for (size_t i = 0; i < 2; i++) {
        sig->vertex[i] = (uint32_t)i;
        for (int d = 0; d < 3; d++)
            sig->position[3 * i + d] = (double)(i + d);
        sig->persistence[i] = i ? 0.25 : INFINITY;
        sig->boundary[i] = INFINITY;
        for (size_t s = 0; s < 15; s++)
            sig->vectors[15 * i + s] = 1.0 / (double)(1 + i + s);
    }
    return sig;
}

static size_t count_of(phks_db *db)
{
    size_t count = (size_t)-1;
    phks_status st = phks_db_count(db, &count);
    if (st != PHKS_OK) {
        fuzz_check_failure(st);
        return (size_t)-1;
    }
    return count;
}

static void exercise(phks_db *db, const phks_signature *query)
{
    size_t count = count_of(db);
    if (count == (size_t)-1)
        return;

    /* every id, a page of 4 at a time. In a file whose table is damaged
     * (rowids out of order, which SQLite does not check on reading), the
     * ids come out of order: a caller paging with the last id it got
     * would loop forever, so the loop stops there. */
    int64_t ids[64], page[4], after = 0;
    size_t listed = 0, got = 0;
    bool in_order = true;
    while (in_order) {
        phks_status st = phks_db_list(db, after, page, 4, &got);
        if (st != PHKS_OK) {
            fuzz_check_failure(st);
            return;
        }
        FUZZ_CHECK(got <= 4);
        for (size_t i = 0; i < got && in_order; i++) {
            in_order = page[i] > after;
            after = page[i];
            if (listed < 64)
                ids[listed] = page[i];
            listed++;
        }
        if (got < 4)
            break;
    }
    /* A damaged file can also hold ids <= 0, which count sees and list,
     * which starts after id 0, never reaches. */
    FUZZ_CHECK(!in_order || listed <= count);

    phks_status st;
    for (size_t i = 0; i < listed && i < 64; i++) {
        phks_signature *sig = NULL;
        char name[PHKS_DB_TEXT_MAX + 1], label[8];
        st = phks_db_get(db, ids[i], &sig, name, sizeof name, label,
                         sizeof label);
        if (st == PHKS_OK) {
            FUZZ_CHECK(sig != NULL && phks_signature_feature_count(sig) >= 1);
            FUZZ_CHECK(memchr(name, '\0', sizeof name) != NULL);
            FUZZ_CHECK(memchr(label, '\0', sizeof label) != NULL);
        } else {
            fuzz_check_failure(st);
            FUZZ_CHECK(sig == NULL);
        }
        phks_signature_free(sig);
    }
    st = phks_db_get(db, -1, NULL, NULL, 0, NULL, 0); /* most likely absent */
    if (st != PHKS_OK)
        fuzz_check_failure(st);

    phks_hit hits[3];
    size_t found = (size_t)-1;
    st = phks_db_query(db, query, 3, hits, &found);
    if (st == PHKS_OK) {
        FUZZ_CHECK(found <= (count < 3 ? count : 3));
        for (size_t i = 0; i < found; i++) {
            FUZZ_CHECK(!isnan(hits[i].score) && hits[i].score >= 0);
            FUZZ_CHECK(i == 0 || hits[i - 1].score <= hits[i].score);
            FUZZ_CHECK(memchr(hits[i].name, '\0', sizeof hits[i].name));
            FUZZ_CHECK(memchr(hits[i].label, '\0', sizeof hits[i].label));
            bool known = listed > 64 || hits[i].id <= 0;
            for (size_t j = 0; j < listed && j < 64 && !known; j++)
                known = ids[j] == hits[i].id;
            FUZZ_CHECK(known);
        }
    } else {
        fuzz_check_failure(st);
    }

    int64_t id = 0;
    st = phks_db_add(db, "fuzz", "label", query, &id);
    if (st != PHKS_OK) {
        fuzz_check_failure(st);
        return;
    }
    FUZZ_CHECK(id > 0);
    size_t more = count_of(db);
    FUZZ_CHECK(more == count + 1 || more == (size_t)-1 || damaged());
    st = phks_db_remove(db, id);
    if (st == PHKS_OK) {
        size_t back = count_of(db);
        FUZZ_CHECK(back == count || back == (size_t)-1 || damaged());
    } else {
        fuzz_check_failure(st);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static phks_signature *query;
    if (!path[0]) {
        const char *dir = access("/dev/shm", W_OK) == 0 ? "/dev/shm"
                          : getenv("TMPDIR")             ? getenv("TMPDIR")
                                                         : "/tmp";
        snprintf(path, sizeof path, "%s/phks-fuzz-db-%ld.sqlite", dir,
                 (long)getpid());
        query = query_signature();
    }
    remove_files();
    FILE *f = fopen(path, "wb");
    FUZZ_CHECK(f != NULL);
    FUZZ_CHECK(fwrite(data, 1, size, f) == size);
    FUZZ_CHECK(fclose(f) == 0);

    phks_db *db = (phks_db *)&db; /* must be reset */
    fuzz_clear_message();
    phks_status st = phks_db_open(path, 0, &db);
    if (st == PHKS_OK) {
        FUZZ_CHECK(db != NULL);
        exercise(db, query);
    } else {
        fuzz_check_failure(st);
        FUZZ_CHECK(db == NULL);
    }
    phks_db_close(st == PHKS_OK ? db : NULL);
    remove_files();
    return 0;
}
