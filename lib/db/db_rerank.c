/*
 * db_rerank.c - the second stage of a query with PHKS_MATCHING_VERIFIED:
 * the packed scan ranks every entry by the paper's nearest-L1 score,
 * which needs only the vectors kept in memory; the best of them are read
 * back whole, with their distances, and ranked by the verified score.
 *
 * The entries are read one after another (the handle's connection is
 * one), then verified on several threads, each with its own verifier
 * made beforehand on this thread: each entry's score is its own, so the
 * ranking does not depend on which thread computed what, and nothing is
 * allocated off this thread: the allocator is called in an order that
 * does not depend on the threads' timing.
 */
#include "db/db.h"

#include <stdlib.h>

typedef struct rerank_job {
    phks__verifier **verifier; /* one per part                          */
    size_t parts, m;
    phks_signature **entry;    /* NULL: removed since the scan          */
    phks_hit *shortlist;
} rerank_job;

static int by_score_then_id(const void *x, const void *y)
{
    const phks_hit *a = x, *b = y;
    if (a->score != b->score)
        return a->score < b->score ? -1 : 1;
    return (a->id > b->id) - (a->id < b->id);
}

/* Parts [begin, end) of the shortlist, in equal runs of consecutive
 * entries. The scan's score is the paper's, the verified score's first
 * factor. */
static void verify_parts(void *ctx, size_t begin, size_t end)
{
    rerank_job *job = ctx;
    for (size_t t = begin; t < end; t++)
        for (size_t h = job->m * t / job->parts;
             h < job->m * (t + 1) / job->parts; h++)
            if (job->entry[h])
                phks__verifier_run(job->verifier[t], job->entry[h],
                                   job->shortlist[h].score, NULL,
                                   &job->shortlist[h].score);
}

/* Reads the shortlist's entries; an entry removed since the scan is left
 * NULL, as if the query had come after. *points: the most any has. */
static phks_status read_entries(phks_db *db, const phks_hit *shortlist,
                                size_t m, phks_signature **entry,
                                size_t *points)
{
    *points = 0;
    for (size_t h = 0; h < m; h++) {
        phks_status st = phks__db_get_signature(db, shortlist[h].id, &entry[h]);
        if (st == PHKS_ERROR_INVALID_ARGUMENT)
            entry[h] = NULL;
        else if (st != PHKS_OK)
            return st;
        else if (phks__signature_points(entry[h]) > *points)
            *points = phks__signature_points(entry[h]);
    }
    return PHKS_OK;
}

/* Scores the entries read, in place, and drops those removed. */
static phks_status verify_all(const phks_signature *query, phks_hit *shortlist,
                              phks_signature **entry, size_t points,
                              size_t *m)
{
    unsigned threads = phks__thread_count(NULL);
    size_t parts = *m < threads ? *m : threads;
    phks__verifier **verifier = phks__calloc(parts ? parts : 1,
                                             sizeof *verifier);
    phks_status st = verifier ? PHKS_OK : phks__fail_oom("verified matching");
    for (size_t t = 0; st == PHKS_OK && t < parts; t++)
        st = phks__verifier_new(query, points, &verifier[t]);
    if (st == PHKS_OK) {
        rerank_job job = {verifier, parts, *m, entry, shortlist};
        phks__parallel_for(parts, (unsigned)parts, verify_parts, &job);
        size_t kept = 0;
        for (size_t h = 0; h < *m; h++)
            if (entry[h])
                shortlist[kept++] = shortlist[h];
        *m = kept;
    }
    for (size_t t = 0; verifier && t < parts; t++)
        phks__verifier_free(verifier[t]);
    phks__free(verifier);
    return st;
}

phks_status phks__db_rerank(phks_db *db, const phks_signature *query,
                            phks_hit *shortlist, size_t m, size_t k,
                            phks_hit *hits, size_t *count)
{
    phks_signature **entry = phks__calloc(m ? m : 1, sizeof *entry);
    size_t points = 0, kept = m;
    phks_status st = entry ? read_entries(db, shortlist, m, entry, &points)
                           : phks__fail_oom("verified matching");
    if (st == PHKS_OK)
        st = verify_all(query, shortlist, entry, points, &kept);
    for (size_t h = 0; entry && h < m; h++)
        phks_signature_free(entry[h]);
    phks__free(entry);
    if (st != PHKS_OK)
        return st;
    qsort(shortlist, kept, sizeof *shortlist, by_score_then_id);
    *count = kept < k ? kept : k;
    for (size_t h = 0; h < *count; h++)
        hits[h] = shortlist[h];
    return PHKS_OK;
}
