/*
 * db_scan.c - the packed in-memory copy of a shape database and the
 * top-k scan over it.
 *
 * Each entry's vectors are stored transposed, as the lanes of
 * features/nearest_kernel.h take them (one row per scale, one lane per
 * feature, padded with +infinity), and scored there: every score is bit
 * for bit phks_score_nearest(query, entry).
 *
 * Scores are sums of non-negative terms and rounding is monotonic, so a
 * partial sum never exceeds the final one: an entry is dropped as soon as
 * its partial sum reaches the worst score a full top-k list holds (an
 * equal score loses too, as later entries have higher ids).
 */
#if defined(__linux__) && !defined(_DEFAULT_SOURCE)
#define _DEFAULT_SOURCE /* madvise's MADV_HUGEPAGE */
#endif
#include "db/db.h"
#include "features/nearest_kernel.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#if defined(__linux__)
#include <sys/mman.h>
#endif

/* Below this many entries one thread does the scan: starting threads would
 * cost more than it saves. */
#define PARALLEL_MIN 4096

size_t phks__db_padded(size_t features)
{
    return (features + PHKS__NEAREST_LANES - 1) / PHKS__NEAREST_LANES *
           PHKS__NEAREST_LANES;
}

void phks__db_cache_init(phks__db_cache *cache)
{
    memset(cache, 0, sizeof *cache);
}

void phks__db_cache_release(phks__db_cache *cache)
{
    phks__free(cache->ids);
    phks__free(cache->features);
    phks__free(cache->vector_at);
    phks__free(cache->text_at);
    phks__free(cache->vectors);
    phks__free(cache->text);
    phks__db_cache_init(cache);
}

/* Bytes of s kept in a hit: at most PHKS_DB_TEXT_MAX, never splitting a
 * UTF-8 sequence. */
static size_t text_cut(const char *s)
{
    size_t n = strnlen(s, PHKS_DB_TEXT_MAX + 1);
    if (n <= PHKS_DB_TEXT_MAX)
        return n;
    n = PHKS_DB_TEXT_MAX;
    while (n > 0 && ((unsigned char)s[n] & 0xC0) == 0x80)
        n--;
    return n;
}

/* The capacity for `more` items beyond `used` of `capacity`, each of
 * `item` bytes: at least twice the old one (appends stay amortised O(1))
 * and 64, and exactly what is asked beyond that (a bulk load is sized
 * once). 0 when it would overflow. */
static size_t capacity_for(size_t capacity, size_t used, size_t more,
                           size_t item)
{
    if (more > SIZE_MAX / item - used)
        return 0;
    size_t want = used + more;
    if (capacity <= SIZE_MAX / item / 2 && want < 2 * capacity)
        want = 2 * capacity;
    return want < 64 && 64 <= SIZE_MAX / item ? 64 : want;
}

/* Makes room for `more` items in *array of *capacity items. On failure the
 * array is unchanged. */
static bool grow(void **array, size_t *capacity, size_t used, size_t more,
                 size_t item)
{
    if (more <= *capacity - used)
        return true;
    size_t want = capacity_for(*capacity, used, more, item);
    void *p = want ? phks__realloc_array(*array, want, item) : NULL;
    if (!p)
        return false;
    *array = p;
    *capacity = want;
    return true;
}

/* The same for the four per-entry arrays, which share one capacity: an
 * array that grew before another failed is only larger, and the capacity
 * moves on only when all four have grown. */
static bool grow_slots(phks__db_cache *c, size_t more)
{
    if (more <= c->capacity - c->count)
        return true;
    size_t want = capacity_for(c->capacity, c->count, more, sizeof(int64_t));
    if (!want)
        return false;
    void *p;
    if (!(p = phks__realloc_array(c->ids, want, sizeof *c->ids)))
        return false;
    c->ids = p;
    if (!(p = phks__realloc_array(c->features, want, sizeof *c->features)))
        return false;
    c->features = p;
    if (!(p = phks__realloc_array(c->vector_at, want, sizeof *c->vector_at)))
        return false;
    c->vector_at = p;
    if (!(p = phks__realloc_array(c->text_at, want, sizeof *c->text_at)))
        return false;
    c->text_at = p;
    c->capacity = want;
    return true;
}

/* The vectors of a large cache are written once, page by page, as a
 * database's chunks are read: on Linux, transparent huge pages take that
 * from half a million page faults (a third of the load, for a million
 * entries) to a thousand. Only a hint; failures are ignored. */
static void advise_huge(void *p, size_t bytes)
{
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    const uintptr_t huge = (uintptr_t)2 << 20;
    if (bytes < 16 * huge)
        return;
    uintptr_t a = ((uintptr_t)p + huge - 1) & ~(huge - 1),
              e = ((uintptr_t)p + bytes) & ~(huge - 1);
    if (e > a)
        (void)madvise((void *)a, e - a, MADV_HUGEPAGE);
#else
    (void)p;
    (void)bytes;
#endif
}

phks_status phks__db_cache_reserve(phks__db_cache *c, size_t slots,
                                   size_t doubles, size_t text)
{
    double *before = c->vectors;
    if (!grow_slots(c, slots) ||
        !grow((void **)&c->vectors, &c->vectors_capacity, c->vectors_used,
              doubles, sizeof *c->vectors) ||
        !grow((void **)&c->text, &c->text_capacity, c->text_used, text, 1))
        return PHKS_ERROR_OUT_OF_MEMORY;
    if (c->vectors != before)
        advise_huge(c->vectors + c->vectors_used,
                    (c->vectors_capacity - c->vectors_used) *
                        sizeof *c->vectors);
    return PHKS_OK;
}

phks_status phks__db_cache_append(phks__db_cache *c, int64_t id,
                                 const char *name, const char *label,
                                 const phks_signature *sig)
{
    size_t length = c->count ? c->length : sig->length;
    if (id < 1 || (c->count && id <= c->ids[c->count - 1]) ||
        sig->count == 0 || sig->count > UINT32_MAX || sig->length != length)
        return PHKS_ERROR_INVALID_ARGUMENT;
    size_t lanes = phks__db_padded(sig->count);
    if (length && lanes > SIZE_MAX / length)
        return PHKS_ERROR_OUT_OF_MEMORY;
    size_t block = lanes * length;
    if (!label)
        label = "";
    size_t name_len = text_cut(name), label_len = text_cut(label);
    if (phks__db_cache_reserve(c, 1, block, name_len + label_len + 2) !=
        PHKS_OK)
        return PHKS_ERROR_OUT_OF_MEMORY;

    size_t e = c->count++;
    c->length = length;
    c->ids[e] = id;
    c->features[e] = (uint32_t)sig->count;
    if (sig->count > c->max_features)
        c->max_features = (uint32_t)sig->count;
    c->vector_at[e] = c->vectors_used;
    double *v = c->vectors + c->vectors_used;
    for (size_t s = 0; s < length; s++)
        for (size_t j = 0; j < lanes; j++)
            v[s * lanes + j] =
                j < sig->count ? sig->vectors[j * length + s] : INFINITY;
    c->vectors_used += block;
    c->text_at[e] = c->text_used;
    char *t = c->text + c->text_used;
    memcpy(t, name, name_len);
    t[name_len] = '\0';
    memcpy(t + name_len + 1, label, label_len);
    t[name_len + 1 + label_len] = '\0';
    c->text_used += name_len + label_len + 2;
    return PHKS_OK;
}

/* Moves the live entries down over the removed ones, in order. */
static void compact(phks__db_cache *c)
{
    size_t out = 0, vec = 0, text = 0;
    for (size_t e = 0; e < c->count; e++) {
        if (c->features[e] == 0)
            continue;
        size_t block = phks__db_padded(c->features[e]) * c->length;
        const char *t = c->text + c->text_at[e];
        size_t tlen = strlen(t) + 1;
        tlen += strlen(t + tlen) + 1;
        memmove(c->vectors + vec, c->vectors + c->vector_at[e],
                block * sizeof *c->vectors);
        memmove(c->text + text, t, tlen);
        c->ids[out] = c->ids[e];
        c->features[out] = c->features[e];
        c->vector_at[out] = vec;
        c->text_at[out] = text;
        vec += block;
        text += tlen;
        out++;
    }
    c->count = out;
    c->dead = 0;
    c->vectors_used = vec;
    c->text_used = text;
}

size_t phks__db_cache_find(const phks__db_cache *c, int64_t id)
{
    size_t lo = 0, hi = c->count;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (c->ids[mid] < id)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < c->count && c->ids[lo] == id ? lo : c->count;
}

void phks__db_cache_remove(phks__db_cache *c, int64_t id)
{
    size_t e = phks__db_cache_find(c, id);
    if (e == c->count || c->features[e] == 0)
        return;
    c->features[e] = 0;
    c->dead++;
    if (c->dead * 2 > c->count)
        compact(c);
}

/* ---- the scan */

typedef struct candidate {
    double score;
    int64_t id;
    size_t slot;
} candidate;

static bool worse(const candidate *a, const candidate *b)
{
    return a->score > b->score || (a->score == b->score && a->id > b->id);
}

typedef struct scan_part {
    candidate *heap; /* max-heap: the worst kept candidate on top */
    size_t size;
    double *colmin;  /* one per lane of the widest entry */
} scan_part;

typedef struct scan_job {
    const phks__db_cache *cache;
    const phks_signature *query;
    const double *rows; /* the query's vectors, padded to whole passes */
    size_t keep;     /* heap capacity: min(k, live entries) */
    unsigned parts;
    scan_part *part;
} scan_job;

static void heap_push(scan_part *p, size_t keep, candidate c)
{
    candidate *h = p->heap;
    size_t i;
    if (p->size < keep) {
        i = p->size++;
        while (i > 0 && worse(&c, &h[(i - 1) / 2])) {
            h[i] = h[(i - 1) / 2];
            i = (i - 1) / 2;
        }
        h[i] = c;
        return;
    }
    if (!worse(&h[0], &c))
        return;
    i = 0;
    for (;;) {
        size_t l = 2 * i + 1, r = l + 1, big = i;
        const candidate *top = &c;
        if (l < keep && worse(&h[l], top)) {
            big = l;
            top = &h[l];
        }
        if (r < keep && worse(&h[r], top))
            big = r;
        if (big == i)
            break;
        h[i] = h[big];
        i = big;
    }
    h[i] = c;
}

PHKS__NEAREST_CLONES
static void scan_slots(const scan_job *job, scan_part *p, size_t begin,
                       size_t end)
{
    const phks__db_cache *c = job->cache;
    const double *q = job->rows;
    size_t nq = job->query->count, L = c->length, keep = job->keep;
    for (size_t e = begin; e < end; e++) {
        size_t ne = c->features[e];
        if (ne == 0)
            continue;
        bool full = p->size == keep;
        double limit = full ? p->heap[0].score : INFINITY;
        double score = phks__nearest_block(q, nq, L,
                                           c->vectors + c->vector_at[e], ne,
                                   phks__db_padded(ne), p->colmin, full, limit);
        if (!full || score < limit)
            heap_push(p, keep, (candidate){score, c->ids[e], e});
    }
}

static void scan_range(void *ctx, size_t begin, size_t end)
{
    const scan_job *job = ctx;
    size_t n = job->cache->count;
    for (size_t t = begin; t < end; t++)
        scan_slots(job, &job->part[t], n * t / job->parts,
                   n * (t + 1) / job->parts);
}

static int by_score_then_id(const void *a, const void *b)
{
    const candidate *x = a, *y = b;
    return worse(x, y) ? 1 : worse(y, x) ? -1 : 0;
}

phks_status phks__db_cache_query(const phks__db_cache *c,
                                const phks_signature *query, size_t k,
                                phks_hit *hits, size_t *count)
{
    *count = 0;
    size_t live = c->count - c->dead;
    if (live == 0)
        return PHKS_OK;
    size_t keep = k < live ? k : live;
    unsigned parts = live < PARALLEL_MIN ? 1 : phks__thread_count(NULL);
    scan_job job = {c, query, NULL, keep, parts, NULL};
    candidate *all = NULL;
    phks_status st = PHKS_OK;
    size_t L = c->length, padded = (query->count + PHKS__NEAREST_ROWS - 1) /
                                   PHKS__NEAREST_ROWS * PHKS__NEAREST_ROWS;
    double *rows = phks__malloc_array(padded, L * sizeof *rows);
    job.rows = rows;
    job.part = phks__calloc(parts, sizeof *job.part);
    if (!rows || !job.part) {
        st = phks__fail_oom("database query");
        goto done;
    }
    for (size_t i = 0; i < padded * L; i++)
        rows[i] = i < query->count * L ? query->vectors[i] : INFINITY;
    for (unsigned t = 0; t < parts; t++) {
        job.part[t].heap = phks__malloc_array(keep, sizeof(candidate));
        job.part[t].colmin =
            phks__malloc_array(phks__db_padded(c->max_features), sizeof(double));
        if (!job.part[t].heap || !job.part[t].colmin) {
            st = phks__fail_oom("database query");
            goto done;
        }
    }
    phks__parallel_for(parts, parts, scan_range, &job);

    /* The best `keep` of all parts' lists. */
    candidate *best = job.part[0].heap;
    size_t total = job.part[0].size;
    if (parts > 1) {
        all = phks__malloc_array(parts, keep * sizeof *all);
        if (!all) {
            st = phks__fail_oom("database query");
            goto done;
        }
        total = 0;
        for (unsigned t = 0; t < parts; t++) {
            memcpy(all + total, job.part[t].heap,
                   job.part[t].size * sizeof *all);
            total += job.part[t].size;
        }
        best = all;
    }
    qsort(best, total, sizeof *best, by_score_then_id);
    if (total > keep)
        total = keep;
    for (size_t i = 0; i < total; i++) {
        const char *t = c->text + c->text_at[best[i].slot];
        size_t name_len = strlen(t);
        hits[i].id = best[i].id;
        hits[i].score = best[i].score;
        memcpy(hits[i].name, t, name_len + 1);
        memcpy(hits[i].label, t + name_len + 1, strlen(t + name_len + 1) + 1);
    }
    *count = total;
done:
    if (job.part)
        for (unsigned t = 0; t < parts; t++) {
            phks__free(job.part[t].heap);
            phks__free(job.part[t].colmin);
        }
    phks__free(job.part);
    phks__free(all);
    phks__free(rows);
    return st;
}
