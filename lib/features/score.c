/*
 * score.c - phks_score and phks_match: the paper's nearest-L1 score
 * (PHKS_MATCHING_NEAREST), or the verified correspondences of verify.c,
 * with the nearest pairs listed beside them.
 */
#include "features/features.h"

#include <math.h>

static double l1(const double *a, const double *b, size_t n)
{
    double s = 0;
    for (size_t i = 0; i < n; i++)
        s += fabs(a[i] - b[i]);
    return s;
}

/* Nearest feature of `to` for feature i of `from` (lowest index on ties). */
static size_t nearest(const phks_signature *from, size_t i,
                      const phks_signature *to, double *distance)
{
    size_t best = 0;
    double d = INFINITY;
    for (size_t j = 0; j < to->count; j++) {
        double e = l1(from->vectors + i * from->length,
                      to->vectors + j * to->length, from->length);
        if (e < d) {
            d = e;
            best = j;
        }
    }
    *distance = d;
    return best;
}

static phks_status check_pair(const phks_signature *a, const phks_signature *b,
                              const char *fn)
{
    if (!a || !b)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT, "%s: NULL signature", fn);
    char detail[128];
    if (phks__options_difference(&a->options, &b->options, false, detail,
                                 sizeof detail))
        return phks__fail(PHKS_ERROR_INCOMPATIBLE,
                         "%s: the signatures were made with different options "
                         "(%s)",
                         fn, detail);
    if (a->options.matching == PHKS_MATCHING_VERIFIED &&
        ((!a->geodesic && a->count > 1) || (!b->geodesic && b->count > 1)))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "%s: a verified-matching signature without its "
                         "distances", fn);
    return PHKS_OK;
}

/* The paper's score, and into out (NULL: not wanted) its pairs: a row
 * per feature of a, then one per feature of b. */
static double nearest_pairs(const phks_signature *a, const phks_signature *b,
                            phks_correspondence *out)
{
    double total = 0;
    for (int side = 0; side < 2; side++) {
        const phks_signature *from = side ? b : a, *to = side ? a : b;
        for (size_t i = 0; i < from->count; i++) {
            double d;
            size_t j = nearest(from, i, to, &d);
            total += d;
            if (out)
                out[(side ? a->count : 0) + i] = (phks_correspondence){
                    (uint32_t)(side ? j : i), (uint32_t)(side ? i : j), d,
                    side == 0, 0};
        }
    }
    return total;
}

/* Marks the verified pairs of out, and names in a's rows each verified
 * feature's partner (pair_of, from phks__verify). */
static void mark_verified(const phks_signature *a, const phks_signature *b,
                          const uint32_t *pair_of, phks_correspondence *out)
{
    for (size_t r = 0; r < a->count + b->count; r++) {
        phks_correspondence *c = out + r;
        uint32_t partner = pair_of[c->feature_a];
        if (partner == UINT32_MAX)
            continue;
        if (c->from_a) {
            c->feature_b = partner;
            c->distance = l1(a->vectors + c->feature_a * a->length,
                             b->vectors + (size_t)partner * b->length,
                             a->length);
        }
        c->verified = partner == c->feature_b;
    }
}

phks_status phks_match(const phks_signature *a, const phks_signature *b,
                       phks_correspondence *out, size_t capacity, size_t *count,
                       double *score)
{
    phks_status st = check_pair(a, b, "phks_match");
    if (st != PHKS_OK)
        return st;
    size_t needed = a->count + b->count;
    if (count)
        *count = needed;
    if (out && capacity < needed)
        return phks__fail(PHKS_ERROR_BUFFER_TOO_SMALL,
                         "phks_match: room for %zu correspondences, %zu needed",
                         capacity, needed);
    double total = nearest_pairs(a, b, out);
    if (a->options.matching == PHKS_MATCHING_VERIFIED) {
        uint32_t *pair_of = phks__malloc_array(a->count + 1, sizeof *pair_of);
        if (!pair_of)
            return phks__fail_oom("phks_match");
        st = phks__verify(a, b, total, pair_of, &total);
        if (st == PHKS_OK && out)
            mark_verified(a, b, pair_of, out);
        phks__free(pair_of);
        if (st != PHKS_OK)
            return st;
    }
    if (score)
        *score = total;
    return PHKS_OK;
}

phks_status phks_score_nearest(const phks_signature *a,
                               const phks_signature *b, double *score)
{
    if (!score)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_score_nearest: NULL score");
    phks_status st = check_pair(a, b, "phks_score_nearest");
    if (st == PHKS_OK)
        *score = nearest_pairs(a, b, NULL);
    return st;
}

phks_status phks_score(const phks_signature *a, const phks_signature *b,
                       double *score)
{
    if (!score)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT, "phks_score: NULL score");
    return phks_match(a, b, NULL, 0, NULL, score);
}
