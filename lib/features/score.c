/*
 * score.c - the paper's matching score: for each feature vector its
 * nearest L1 neighbour in the other signature, summed both ways.
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
    double total = 0;
    for (int side = 0; side < 2; side++) {
        const phks_signature *from = side ? b : a, *to = side ? a : b;
        for (size_t i = 0; i < from->count; i++) {
            double d;
            size_t j = nearest(from, i, to, &d);
            total += d;
            if (!out)
                continue;
            phks_correspondence *c = out + (side ? a->count : 0) + i;
            c->feature_a = (uint32_t)(side ? j : i);
            c->feature_b = (uint32_t)(side ? i : j);
            c->distance = d;
            c->from_a = side == 0;
            c->reserved = 0;
        }
    }
    if (score)
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
