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
    bool verified = a->options.matching == PHKS_MATCHING_VERIFIED;
    uint32_t *pair_of = NULL;
    double total = 0;
    if (verified) {
        pair_of = phks__malloc_array(a->count, sizeof *pair_of);
        if (!pair_of)
            return phks__fail_oom("phks_match");
        st = phks__verify(a, b, pair_of, &total);
        if (st != PHKS_OK) {
            phks__free(pair_of);
            return st;
        }
    }
    double nearest_total = 0;
    for (int side = 0; side < 2 && (out || !verified); side++) {
        const phks_signature *from = side ? b : a, *to = side ? a : b;
        for (size_t i = 0; i < from->count; i++) {
            double d;
            size_t j = nearest(from, i, to, &d);
            nearest_total += d;
            if (!out)
                continue;
            phks_correspondence *c = out + (side ? a->count : 0) + i;
            size_t fa = side ? j : i, fb = side ? i : j;
            c->verified = 0;
            if (pair_of && pair_of[fa] != UINT32_MAX) {
                c->verified = pair_of[fa] == fb || side == 0;
                /* A's own row names its verified partner. */
                if (side == 0) {
                    fb = pair_of[fa];
                    d = l1(a->vectors + fa * a->length,
                           b->vectors + fb * b->length, a->length);
                }
            }
            c->feature_a = (uint32_t)fa;
            c->feature_b = (uint32_t)fb;
            c->distance = d;
            c->from_a = side == 0;
        }
    }
    phks__free(pair_of);
    if (score)
        *score = verified ? total : nearest_total;
    return PHKS_OK;
}

phks_status phks_score_nearest(const phks_signature *a,
                               const phks_signature *b, double *score)
{
    if (!score)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_score_nearest: NULL score");
    phks_status st = check_pair(a, b, "phks_score_nearest");
    if (st != PHKS_OK)
        return st;
    double total = 0, d;
    for (size_t i = 0; i < a->count; i++) {
        nearest(a, i, b, &d);
        total += d;
    }
    for (size_t j = 0; j < b->count; j++) {
        nearest(b, j, a, &d);
        total += d;
    }
    *score = total;
    return PHKS_OK;
}

phks_status phks_score(const phks_signature *a, const phks_signature *b,
                       double *score)
{
    if (!score)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT, "phks_score: NULL score");
    return phks_match(a, b, NULL, 0, NULL, score);
}
