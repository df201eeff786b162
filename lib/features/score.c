/*
 * score.c - phks_score and phks_match: the paper's nearest-L1 score
 * (PHKS_MATCHING_NEAREST), or the verified correspondences of verify.c,
 * with the nearest pairs listed beside them.
 */
#include "features/features.h"
#include "features/nearest_kernel.h"

#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

static double l1(const double *a, const double *b, size_t n)
{
    double s = 0;
    for (size_t i = 0; i < n; i++)
        s += fabs(a[i] - b[i]);
    return s;
}

/* The L1 distances from x to four vectors at once, each a sum of its own:
 * the additions of one sum wait on each other, but not on the other
 * sums', which one sum at a time would (it is bound by an addition's
 * latency). Each sum still adds its terms in l1's order, so the bits are
 * l1's, and those of the db's scan (db_scan.c). */
static void l1_four(const double *x, const double *to, size_t length,
                    double d[4])
{
    const double *p0 = to, *p1 = to + length, *p2 = p1 + length,
                 *p3 = p2 + length;
    double s0 = 0, s1 = 0, s2 = 0, s3 = 0;
    for (size_t s = 0; s < length; s++) {
        s0 += fabs(x[s] - p0[s]);
        s1 += fabs(x[s] - p1[s]);
        s2 += fabs(x[s] - p2[s]);
        s3 += fabs(x[s] - p3[s]);
    }
    d[0] = s0;
    d[1] = s1;
    d[2] = s2;
    d[3] = s3;
}

/* Below this many vectors in b, one pass over the distances gives both
 * sides' minima (b's kept in an array on the stack); above, each side is
 * a pass of its own. Both give the same numbers: each distance is
 * computed the same way, and the minima and the sum are taken in the
 * same order. */
#define ONE_PASS_MAX 256

typedef struct nearest_out {
    double d;  /* distance to the nearest vector of the other set */
    size_t at; /* its index there, the lowest on ties */
} nearest_out;

/* Folds the distance e from vector i of a to vector j of b into row's
 * nearest (i's) and, where col is not NULL, into column j's. */
static void fold(double e, size_t i, size_t j, nearest_out *row,
                 nearest_out *col)
{
    if (e < row->d)
        *row = (nearest_out){e, j};
    if (col && e < col[j].d)
        col[j] = (nearest_out){e, i};
}

/* Vector i of a, x, against every vector of b (row-major, `length`
 * each). */
static nearest_out row_against(const double *x, size_t i, const double *b,
                               size_t nb, size_t length, nearest_out *col)
{
    nearest_out row = {INFINITY, 0};
    size_t j = 0;
    for (; j + 4 <= nb; j += 4) {
        double e[4];
        l1_four(x, b + j * length, length, e);
        for (size_t u = 0; u < 4; u++)
            fold(e[u], i, j + u, &row, col);
    }
    for (; j < nb; j++)
        fold(l1(x, b + j * length, length), i, j, &row, col);
    return row;
}

static void put_pair(phks_correspondence *out, size_t at, size_t fa,
                     size_t fb, double d, bool from_a)
{
    if (out)
        out[at] = (phks_correspondence){(uint32_t)fa, (uint32_t)fb, d,
                                        from_a, 0};
}

/* Doubles of a and of b, padded, that the lanes of nearest_kernel.h take
 * on the stack (15 x 15 features pad to 16 x 15). */
#define LANE_DOUBLES 1024

static size_t round_up(size_t n, size_t m)
{
    return (n + m - 1) / m * m;
}

/* The score of small sets through the SIMD lanes of nearest_kernel.h: a
 * copied with rows of +infinity to whole groups of rows, b transposed into
 * lanes. False, with nothing done, where the sets do not fit. */
PHKS__NEAREST_CLONES
static bool nearest_in_lanes(const double *a, size_t na, const double *b,
                             size_t nb, size_t length, double *total)
{
    size_t rows = round_up(na, PHKS__NEAREST_ROWS);
    size_t lanes = round_up(nb, PHKS__NEAREST_LANES);
    if (rows > LANE_DOUBLES / length || lanes > LANE_DOUBLES / length)
        return false;
    double q[LANE_DOUBLES], e[LANE_DOUBLES], colmin[LANE_DOUBLES];
    memcpy(q, a, na * length * sizeof *q);
    for (size_t k = na * length; k < rows * length; k++)
        q[k] = INFINITY;
    for (size_t s = 0; s < length; s++)
        for (size_t j = 0; j < lanes; j++)
            e[s * lanes + j] = j < nb ? b[j * length + s] : INFINITY;
    *total = phks__nearest_block(q, na, length, e, nb, lanes, colmin, false,
                                 0);
    return true;
}

/* The paper's score of two sets of row-major vectors, and into out (NULL:
 * not wanted) its pairs: a row per vector of a, then one per vector of b. */
static double nearest_sum(const double *a, size_t na, const double *b,
                          size_t nb, size_t length, phks_correspondence *out)
{
    double lanes_total;
    if (!out && nearest_in_lanes(a, na, b, nb, length, &lanes_total))
        return lanes_total;
    nearest_out col[ONE_PASS_MAX];
    bool one_pass = nb <= ONE_PASS_MAX;
    for (size_t j = 0; one_pass && j < nb; j++)
        col[j] = (nearest_out){INFINITY, 0};
    double total = 0;
    for (size_t i = 0; i < na; i++) {
        nearest_out r = row_against(a + i * length, i, b, nb, length,
                                    one_pass ? col : NULL);
        total += r.d;
        put_pair(out, i, i, r.at, r.d, true);
    }
    for (size_t j = 0; j < nb; j++) {
        nearest_out c = one_pass ? col[j]
                                 : row_against(b + j * length, j, a, na,
                                               length, NULL);
        total += c.d;
        put_pair(out, na + j, c.at, j, c.d, false);
    }
    return total;
}

static phks_status check_pair(const phks_signature *a, const phks_signature *b,
                              const char *fn)
{
    if (!a || !b)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT, "%s: NULL signature",
                         fn);
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

/* The paper's score of two signatures' features, and into out (NULL: not
 * wanted) its pairs. */
static double nearest_pairs(const phks_signature *a, const phks_signature *b,
                            phks_correspondence *out)
{
    return nearest_sum(a->vectors, a->count, b->vectors, b->count, a->length,
                       out);
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

/* A double is not finite where its exponent bits are all ones; or-ing
 * the tests of integers lets the compiler take them in vectors. */
static bool all_finite(const double *v, size_t n)
{
    const uint64_t exponent = UINT64_C(0x7ff0000000000000);
    uint64_t bad = 0;
    for (size_t i = 0; i < n; i++) {
        uint64_t bits;
        memcpy(&bits, v + i, sizeof bits);
        bad |= (uint64_t)((bits & exponent) == exponent);
    }
    return bad == 0;
}

phks_status phks_score_nearest_vectors(const double *a, size_t a_count,
                                       const double *b, size_t b_count,
                                       size_t length, double *score)
{
    static const char fn[] = "phks_score_nearest_vectors";
    if (!a || !b || !score)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT, "%s: NULL argument", fn);
    if (a_count == 0 || b_count == 0 || length == 0)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "%s: %zu and %zu vectors of length %zu (none may "
                         "be 0)",
                         fn, a_count, b_count, length);
    if (a_count > SIZE_MAX / length || b_count > SIZE_MAX / length)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT, "%s: too many vectors",
                         fn);
    if (!all_finite(a, a_count * length) || !all_finite(b, b_count * length))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "%s: a vector entry is not finite", fn);
    *score = nearest_sum(a, a_count, b, b_count, length, NULL);
    return PHKS_OK;
}

phks_status phks_score(const phks_signature *a, const phks_signature *b,
                       double *score)
{
    if (!score)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT, "phks_score: NULL score");
    return phks_match(a, b, NULL, 0, NULL, score);
}

/* Q of docs/method.md section 14 read back from the two scores: score =
 * nearest (1 - Q), the score taken without its global factor (the share
 * is the feature points'). Rounding may take the quotient a hair outside
 * [0, 1]. */
static double verified_share(double score, double nearest)
{
    if (nearest <= 0)
        return 1;  /* identical vectors: nothing is left to explain */
    double q = 1 - score / nearest;
    return q < 0 ? 0 : q > 1 ? 1 : q;
}

/* exp(-(mean L1 distance per time scale) / PHKS__VECTOR_SIGMA): the mean
 * is over the n_a + n_b nearest distances the score sums and the L
 * entries of a vector, so a mean step of 0.15 costs a factor e, as a
 * verified proposal's affinity (docs/method.md section 14, "What a score
 * means"). */
static double nearest_similarity(const phks_signature *a,
                                 const phks_signature *b, double nearest)
{
    double terms = (double)(a->count + b->count) * (double)a->length;
    if (nearest <= 0 || terms <= 0)
        return 1;
    return exp(-nearest / (terms * PHKS__VECTOR_SIGMA));
}

/* How many of a's features the verification paired (pair_of), beside the
 * verified score. */
static phks_status verified_count(const phks_signature *a,
                                  const phks_signature *b, double nearest,
                                  double *score, size_t *verified)
{
    uint32_t *pair_of = phks__malloc_array(a->count + 1, sizeof *pair_of);
    if (!pair_of)
        return phks__fail_oom("phks_similarity");
    phks_status st = phks__verify(a, b, nearest, pair_of, score);
    *verified = 0;
    for (size_t i = 0; st == PHKS_OK && i < a->count; i++)
        *verified += pair_of[i] != UINT32_MAX;
    phks__free(pair_of);
    return st;
}

phks_status phks_similarity(const phks_signature *query,
                            const phks_signature *entry, double *similarity,
                            size_t *verified)
{
    if (!similarity)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_similarity: NULL similarity");
    phks_status st = check_pair(query, entry, "phks_similarity");
    if (st != PHKS_OK)
        return st;
    double nearest = nearest_pairs(query, entry, NULL), score = nearest;
    size_t paired = 0;
    if (query->options.matching != PHKS_MATCHING_VERIFIED)
        *similarity = nearest_similarity(query, entry, nearest);
    else if ((st = verified_count(query, entry, nearest, &score, &paired)) ==
             PHKS_OK)
        *similarity = verified_share(score / phks__global_factor(query, entry),
                                     nearest);
    if (st == PHKS_OK && verified)
        *verified = paired;
    return st;
}

phks_status phks_candidates(const phks_signature *a, size_t feature,
                            const phks_signature *b, size_t k,
                            phks_candidate *out, size_t *count)
{
    static const char fn[] = "phks_candidates";
    if (!out || !count)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT, "%s: NULL argument", fn);
    *count = 0;
    phks_status st = check_pair(a, b, fn);
    if (st != PHKS_OK)
        return st;
    if (a->options.matching != PHKS_MATCHING_VERIFIED)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                          "%s: signatures made with matching nearest have "
                          "no proposals (verified needed)", fn);
    if (feature >= a->count || k == 0)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                          "%s: feature %zu of %zu, k %zu (k may not be 0)", fn,
                          feature, a->count, k);
    size_t points = phks__signature_points(b);
    return phks__candidates(a, feature, b, k < points ? k : points, out,
                            count);
}
