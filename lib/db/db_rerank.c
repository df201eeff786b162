/*
 * db_rerank.c - the second stage of a query with PHKS_MATCHING_VERIFIED:
 * the packed scan ranks every entry by the paper's nearest-L1 score,
 * which needs only the vectors kept in memory; the best of them are read
 * back whole, with their distances, and ranked by the verified score.
 *
 * The entries are read one after another (the handle's connection is
 * one), then verified on several threads: each entry's score is its own
 * unit, so the ranking does not depend on which thread computed what.
 */
#include "db/db_cache.h"

#include <stdlib.h>

typedef struct rerank_job {
    const phks_signature *query;
    phks_signature **entry; /* NULL: removed since the scan            */
    phks_hit *shortlist;
    phks_status *status;
} rerank_job;

static int by_score_then_id(const void *x, const void *y)
{
    const phks_hit *a = x, *b = y;
    if (a->score != b->score)
        return a->score < b->score ? -1 : 1;
    return (a->id > b->id) - (a->id < b->id);
}

/* The scan's score is the paper's, the verified score's first factor. */
static void verify_range(void *ctx, size_t begin, size_t end)
{
    rerank_job *job = ctx;
    for (size_t h = begin; h < end; h++)
        if (job->entry[h])
            job->status[h] =
                phks__verify(job->query, job->entry[h],
                             job->shortlist[h].score, NULL,
                             &job->shortlist[h].score);
}

/* Reads the shortlist's entries; an entry removed since the scan is left
 * NULL, as if the query had come after. */
static phks_status read_entries(phks_db *db, const phks_hit *shortlist,
                                size_t m, phks_signature **entry)
{
    for (size_t h = 0; h < m; h++) {
        phks_status st = phks_db_get(db, shortlist[h].id, &entry[h], NULL, 0,
                                     NULL, 0);
        if (st == PHKS_ERROR_INVALID_ARGUMENT)
            entry[h] = NULL;
        else if (st != PHKS_OK)
            return st;
    }
    return PHKS_OK;
}

/* Scores the entries read, in place; the entries removed are dropped.
 * A verification fails only for want of memory, and the message it set
 * is its worker thread's: it is set again on this one. */
static phks_status verify_all(const phks_signature *query, phks_hit *shortlist,
                              phks_signature **entry, phks_status *status,
                              size_t *m)
{
    rerank_job job = {query, entry, shortlist, status};
    phks__parallel_for(*m, phks__thread_count(NULL), verify_range, &job);
    size_t kept = 0;
    for (size_t h = 0; h < *m; h++) {
        if (status[h] != PHKS_OK)
            return phks__fail_oom("verified matching");
        if (entry[h])
            shortlist[kept++] = shortlist[h];
    }
    *m = kept;
    return PHKS_OK;
}

phks_status phks__db_rerank(phks_db *db, const phks_signature *query,
                            phks_hit *shortlist, size_t m, size_t k,
                            phks_hit *hits, size_t *count)
{
    phks_signature **entry = phks__calloc(m ? m : 1, sizeof *entry);
    phks_status *status = phks__calloc(m ? m : 1, sizeof *status);
    phks_status st = entry && status ? read_entries(db, shortlist, m, entry)
                                     : phks__fail_oom("verified matching");
    size_t kept = m;
    if (st == PHKS_OK)
        st = verify_all(query, shortlist, entry, status, &kept);
    for (size_t h = 0; entry && h < m; h++)
        phks_signature_free(entry[h]);
    phks__free(entry);
    phks__free(status);
    if (st != PHKS_OK)
        return st;
    qsort(shortlist, kept, sizeof *shortlist, by_score_then_id);
    *count = kept < k ? kept : k;
    for (size_t h = 0; h < *count; h++)
        hits[h] = shortlist[h];
    return PHKS_OK;
}
