/*
 * db_rerank.c - the second stage of a query with PHKS_MATCHING_VERIFIED:
 * the packed scan ranks every entry by the paper's nearest-L1 score,
 * which needs only the vectors kept in memory; the best of them are read
 * back whole, with their distances, and ranked by the verified score.
 */
#include "db/db_cache.h"

#include <stdlib.h>

static int by_score_then_id(const void *x, const void *y)
{
    const phks_hit *a = x, *b = y;
    if (a->score != b->score)
        return a->score < b->score ? -1 : 1;
    return (a->id > b->id) - (a->id < b->id);
}

phks_status phks__db_rerank(phks_db *db, const phks_signature *query,
                            phks_hit *shortlist, size_t m, size_t k,
                            phks_hit *hits, size_t *count)
{
    size_t kept = 0;
    for (size_t h = 0; h < m; h++) {
        phks_signature *entry;
        phks_status st = phks_db_get(db, shortlist[h].id, &entry, NULL, 0,
                                     NULL, 0);
        /* Removed since the scan: as if the query had come after. */
        if (st == PHKS_ERROR_INVALID_ARGUMENT)
            continue;
        /* The scan's score is the paper's, the verified score's first
         * factor. */
        if (st == PHKS_OK)
            st = phks__verify(query, entry, shortlist[h].score, NULL,
                              &shortlist[h].score);
        phks_signature_free(entry);
        if (st != PHKS_OK)
            return st;
        shortlist[kept++] = shortlist[h];
    }
    qsort(shortlist, kept, sizeof *shortlist, by_score_then_id);
    *count = kept < k ? kept : k;
    for (size_t h = 0; h < *count; h++)
        hits[h] = shortlist[h];
    return PHKS_OK;
}
