/*
 * verify.c - PHKS_MATCHING_VERIFIED: descriptors propose, geometry
 * decides (docs/method.md sections 14 and 15).
 *
 * Each feature of the query a proposes the CANDIDATES points of the
 * entry b (features and samples) whose vectors are nearest, and with
 * spin images those whose images are nearest too. Two proposals (i, j)
 * and (i', j') agree when the distance along a's surface between i and
 * i' is that along b's between j and j', times the scale s of a's unit
 * box against b's (with spin images, or when their straight-line
 * distances do). The largest mutually agreeing set
 * is found as Leordeanu and Hebert's spectral matching does: the leading
 * eigenvector of the proposals' affinity matrix, read greedily into a
 * one-to-one set whose members each agree with most of those taken
 * before them. Its affinity over the most a query of its size can reach
 * is the share Q of the query that b explains, and the score is the
 * paper's nearest-L1 score times 1 - Q (and, with the shape distribution
 * D2, times how far apart the two whole shapes' distributions are:
 * docs/method.md section 16).
 *
 * The scale is not known: the unit box of a cut shape enlarges what is
 * left of it. Every s = 2^(k/4), |k| <= SCALE_STEPS, is tried and the
 * best set kept. With the local-area scaling a shape scaled by s has at
 * time t the vector its unscaled self has at t / s^2 (docs/method.md
 * section 9), so b's vectors are read at the shifted times.
 */
#include "features/features.h"

#include "core/simd.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* SSE2 for disagreements and AVX2, where the processor has it, for
 * add_columns, the loops that run longest (the compiler puts
 * add_columns' portable loop in SSE2's lanes itself); PHKS_NO_SIMD
 * builds the portable loops alone (core/simd.h, meson's
 * -Dsimd=disabled). */
#if defined(__SSE2__) && !defined(PHKS_NO_SIMD)
#include <emmintrin.h>
#define VERIFY_SSE2 1
#else
#define VERIFY_SSE2 0
#endif

typedef struct proposal {
    uint32_t i, j;
    double affinity, root; /* and its square root */
} proposal;

/* ---- The scoring rule
 *
 * Everything a score depends on is written once, in this section: the
 * constants that tune it, a proposal's affinity, the agreement of a pair
 * of proposals and their matrix entry, the rule that admits a proposal
 * into the verified set, the set's affinity, its bound and the score.
 * The rest of the file finds the proposals, the matrix and the set that
 * these ask for, and calls them; its SIMD and portable loops must give
 * the same bits (-Dsimd=disabled builds the portable ones, and
 * tests/test_score_bits.c holds both builds to the same scores). */

/* What the scores depend on. */

/* Proposals per query feature: about as many of b's 35 points as 3 of
 * its 15 features. */
#define CANDIDATES 6
/* Vector distance at which a proposal's own affinity falls to 1/e, per
 * time scale (features.h says why 0.15; phks_similarity's NEAREST formula
 * reads the same width). */
#define VECTOR_SIGMA PHKS__VECTOR_SIGMA
/* Relative disagreement of two distances at which a pair's affinity
 * falls to 1/e. A query's own distance may be longer: a cut or a scan
 * can only lengthen a path, so its excess counts half. */
#define DISTANCE_SIGMA 0.2
/* A member of the verified set agrees, on average, at least this well
 * with those taken before it. */
#define AGREEMENT 0.5
/* Scales tried: 2^(k/4) for |k| <= SCALE_STEPS, an octave either way in
 * steps whose half (9%) is well inside DISTANCE_SIGMA. */
#define SCALE_STEPS 4
/* Power iterations, which decide the order the set is read in: the
 * leading eigenvector of a non-negative matrix of a few dozen rows
 * settles well within them. */
#define ITERATIONS 10

/* What only the speed depends on. */

/* Rows of the matrix the power iteration sums side by side, in
 * registers; its columns are padded to a multiple of them. Each row's
 * sum still runs over the columns in order. */
#define BLOCK 16
/* Relative error allowed for in comparing a bound with a set's affinity,
 * both sums of at most a few hundred terms in [0, 1]: far above their
 * rounding, far below any difference that matters. A scale is passed
 * over only when its set could not be the best. */
#define BOUND_MARGIN 1e-9

/* Hellinger distance of two points' spin images at which a proposal's
 * own affinity falls to 1/e (PHKS_LOCAL_DESCRIPTOR_SPIN). */
#define SPIN_SIGMA 0.1

/* The exponent of a proposal's own affinity exp(-x), from the distance
 * of its descriptors: the mean Hellinger distance of the spin images, or
 * the distance of its vectors over `length` time scales. 0 for equal
 * descriptors. */
static double affinity_exponent(double distance, bool spin, size_t length)
{
    if (spin)
        return distance / SPIN_SIGMA;
    return distance / (VECTOR_SIGMA * (double)length);
}

/* The disagreement of two distances below is written once, for a lane
 * of either kind: a double, or SSE2's two (disagreements), on which GCC
 * and Clang apply + - * / lane by lane, a scalar operand to every lane.
 * LANE_OP picks the lane's form of the two operations that are not
 * arithmetic; both forms compute the same thing, so both kinds of lane
 * give the same bits. */
static inline double larger(double a, double b)
{
    return a > b ? a : b;
}

/* Halving by multiplying by 0.5, as SSE2 does: the same bits as e / 2. */
static inline double halved_if_positive(double e)
{
    return e > 0 ? e * 0.5 : e;
}

#if VERIFY_SSE2
/* maxpd is a > b ? a : b, lane by lane. */
static inline __m128d larger_sse2(__m128d a, __m128d b)
{
    return _mm_max_pd(a, b);
}

static inline __m128d halved_if_positive_sse2(__m128d e)
{
    __m128d positive = _mm_cmpgt_pd(e, _mm_setzero_pd());
    return _mm_or_pd(_mm_and_pd(positive, e * 0.5),
                     _mm_andnot_pd(positive, e));
}

#define LANE_OP(op, lane) _Generic((lane), __m128d: op##_sse2, default: op)
#else
#define LANE_OP(op, lane) op
#endif

/* How far two finite distances along the surfaces, a's ga and b's gb,
 * disagree, in DISTANCE_SIGMA: their difference over the larger plus
 * slack, the positional uncertainty of a point; a's excess counts half
 * (see DISTANCE_SIGMA). The larger by comparison rather than fmax, a
 * call: the two differ only in the sign of a zero, which adding slack >
 * 0 takes away. */
#define DISAGREEMENT(ga, gb, slack)                                         \
    (LANE_OP(halved_if_positive, ga)(                                       \
         ((ga) - (gb)) / (LANE_OP(larger, ga)(ga, gb) + (slack))) /         \
     DISTANCE_SIGMA)

static inline double disagreement(double ga, double gb, double slack)
{
    return DISAGREEMENT(ga, gb, slack);
}

/* How far two straight-line distances disagree, in DISTANCE_SIGMA: as
 * DISAGREEMENT, but either's excess counts in full (a cut leaves a
 * straight line as it was). */
#define STRAIGHT_DISAGREEMENT(sa, sb, slack)                                \
    (((sa) - (sb)) / (LANE_OP(larger, sa)(sa, sb) + (slack)) /              \
     DISTANCE_SIGMA)

static inline double straight_disagreement(double sa, double sb,
                                           double slack)
{
    return STRAIGHT_DISAGREEMENT(sa, sb, slack);
}

/* How well two distances agree given their disagreement e, 1 at equality
 * (see DISTANCE_SIGMA); 0 beyond 3 sigma, where exp(-9) is nothing to a
 * set's affinity. */
static inline double agreement(double ga, double gb, double e)
{
    if (!isfinite(ga) || !isfinite(gb))
        return 0;
    return fabs(e) < 3 ? exp(-e * e) : 0;
}

/* The better of two agreements, agreement(ga, gb, e) and
 * agreement(sa, sb, es), with one exponential: exp(-e^2) falls as |e|
 * grows, so the better is that of the smaller |e| among those that
 * count; the same bits as taking the larger of both. */
static inline double better_agreement(double ga, double gb, double e,
                                      double sa, double sb, double es)
{
    bool first = isfinite(ga) && isfinite(gb) && fabs(e) < 3;
    bool second = isfinite(sa) && isfinite(sb) && fabs(es) < 3;
    if (!first && !second)
        return 0;
    double x = !second || (first && fabs(e) <= fabs(es)) ? e : es;
    return exp(-x * x);
}

/* The matrix entry of proposals x and y that share no point, given how
 * well their distances agree: at most the geometric mean of their own
 * affinities. The product runs in the order of the arguments. */
static inline double pair_weight(double agreed, const proposal *x,
                                 const proposal *y)
{
    return agreed * x->root * y->root;
}

/* Whether proposal x, whose pair weights with the `taken` members of the
 * set sum to `with`, agrees too little with them to join: less, on
 * average, than AGREEMENT times what it would with the first member
 * were they to agree fully. taken is at least 1. */
static bool agrees_too_little(double with, size_t taken, const proposal *x,
                              const proposal *first)
{
    return with / (double)taken < AGREEMENT * x->root * first->root;
}

/* What proposal x adds to the affinity of the set it joins: its own
 * affinity and its pairs' with the members, counted both ways as the
 * symmetric matrix holds them. */
static double member_affinity(const proposal *x, double with)
{
    return x->affinity + 2 * with;
}

/* At most the affinity of any set the proposals can give: a set takes
 * one proposal per query feature and pairs that agree at most fully, so
 * its sum of member_affinity, u + 2 w sqrt(u u'), is at most the square
 * of the sum, over the features, of their largest sqrt(u). The proposals
 * of a feature are consecutive. */
static double affinity_bound(const proposal *p, size_t count)
{
    double sum = 0;
    for (size_t k = 0; k < count;) {
        double most = 0;
        size_t i = p[k].i;
        for (; k < count && p[k].i == i; k++)
            most = fmax(most, p[k].root);
        sum += most;
    }
    return sum * sum;
}

/* The score of a query of `features` features whose best verified set
 * has affinity `best`: the nearest-L1 score times 1 - Q, Q the share of
 * the most a query of its size can reach (its bound with every u = 1). */
static double verified_score(double nearest, double best, size_t features)
{
    double n = (double)features;
    return nearest * (1 - fmin(best / (n * n), 1));
}

/* The Hellinger distance two shape distributions of one surface keep
 * from where their points fall alone (docs/method.md section 16): the
 * least the global factor below can be, so that two shapes of the same
 * proportions are told apart by their points, not by sampling noise. */
#define SHAPE_FLOOR 0.01

double phks__global_factor(const phks_signature *a, const phks_signature *b)
{
    if (!a->has_shape || !b->has_shape)
        return 1;
    double sum = 0;
    for (size_t k = 0; k < PHKS__SHAPE_BINS; k++) {
        double d = ((double)a->shape[k] - (double)b->shape[k]) / 255;
        sum += d * d;
    }
    return SHAPE_FLOOR + sqrt(sum / 2);
}

/* ---- Finding the verified set */

/* A pair of proposals p < q. */
typedef struct pair_ref {
    uint32_t p, q;
} pair_ref;

/* A proposal's place in the reading order of the leading vector. */
typedef struct ranked {
    double x;
    size_t p;
} ranked;

struct phks__verifier {
    const phks_signature *a, *b;
    size_t na, nb;    /* a's features, b's points                         */
    size_t length, steps;
    double slack;     /* positional uncertainty of a feature point        */
    double log_times[PHKS_MAX_SCALES]; /* log of b's time scales          */
    double *va, *vb;  /* vectors as compared (logarithms); b's by time
                         scale, length x nb, so that distances runs
                         along b's points                               */
    double *wa, *wb;  /* per point and scale: how far the heat stays
                         from the boundary (1: all of it)               */
    double *vb_shift; /* vb read at the times shifted by scale            */
    double *step_weight; /* na x steps x nb: wa * wb of each step, which
                            no scale changes                           */
    double *sum, *last; /* nb each: distances' running sums and steps   */
    double *weight_sum;  /* na x nb: the step weights' sum                */
    double *dist;     /* na x nb descriptor distances                     */
    bool spin;        /* both carry spin images, which then propose
                         beside the vectors                              */
    double *dist_image; /* na x nb image distances (spin)                 */
    double *image_distance; /* na x nb x radii x radii: the Hellinger
                               distance of a's image k and b's image m   */
    double *ga, *gb;  /* a's features' and b's points' distances, square  */
    double *gb_scaled; /* gb times the scale being tried                  */
    proposal *p;
    size_t count;
    pair_ref *pair;    /* the pairs whose matrix entry is computed        */
    double *pair_ga, *pair_gb, *pair_e; /* their distances, disagreement */
    bool straight;    /* both know their unit boxes: pairs agree in
                         straight-line distance too                       */
    double *sa, *sb, *sb_scaled; /* as ga, gb, gb_scaled in straight lines */
    double *pair_sa, *pair_sb, *pair_es; /* and their disagreement      */
    size_t pair_count;
    double *matrix;    /* count x stride, symmetric in its first count
                          columns, zero in the padding                   */
    size_t stride;
    double *x, *y;
    ranked *order;
    size_t *set;
    uint32_t *trial;   /* the set of the scale being tried, per feature   */
    double scale;      /* of the set being read                           */
    bool avx2;         /* the power iteration in AVX2's lanes             */
};

/* The distances between s's first `points` points as a square table,
 * read from the packed floats once rather than at every scale. */
static void square_distances(const phks_signature *s, size_t points,
                             double *out)
{
    for (size_t j = 0; j < points; j++) {
        out[j * points + j] = 0;
        for (size_t i = 0; i < j; i++)
            out[i * points + j] = out[j * points + i] =
                s->geodesic[phks__pair_index(i, j)];
    }
}

/* The straight-line distances between s's first `points` points in its
 * unit box, as a square table. */
static void straight_distances(const phks_signature *s, size_t points,
                               double *out)
{
    for (size_t j = 0; j < points; j++) {
        out[j * points + j] = 0;
        for (size_t i = 0; i < j; i++) {
            const double *p = s->position + 3 * i, *q = s->position + 3 * j;
            double d2 = 0;
            for (int k = 0; k < 3; k++)
                d2 += (p[k] - q[k]) * (p[k] - q[k]);
            out[i * points + j] = out[j * points + i] =
                sqrt(d2) * s->unit_scale;
        }
    }
}

/* The vectors in a form where a ratio is a difference: the local-area
 * scaling's values already are logarithms. */
static void compared_vectors(const phks_signature *s, size_t points,
                             double *out)
{
    bool logs = s->options.hks_scaling == PHKS_HKS_SCALING_LOCAL_AREA;
    for (size_t k = 0; k < points * s->length; k++)
        out[k] = logs ? s->vectors[k] : log(fmax(s->vectors[k], DBL_MIN));
}

/* How much of a point's value at each time scale is its own shape's:
 * heat at time t has spread over about sqrt(4 t), and what reached a cut
 * tells of the cut, not of the shape: 1 - exp(-(d / sqrt(4 t))^2) for a
 * point d from the boundary, the profile of the boundary taper
 * (docs/method.md section 8). */
static void boundary_weights(const phks_signature *s, size_t points,
                             double *out)
{
    const phks_options *o = &s->options;
    for (size_t i = 0; i < points; i++)
        for (size_t k = 0; k < s->length; k++) {
            double d = s->boundary[i] / sqrt(4 * o->scales[k] * o->tau);
            out[i * s->length + k] = isinf(d) ? 1 : -expm1(-d * d);
        }
}

/* b's vectors read at times t / s^2 by linear interpolation in log t,
 * held at the first and last scale outside them. */
static void shift_times(const phks__verifier *c, double scale, double *out)
{
    const double *lt = c->log_times;
    size_t L = c->length;
    double shift = 2 * log(scale);
    for (size_t s = 0; s < L; s++) {
        double t = lt[s] - shift;
        size_t k = 0;
        while (k + 2 < L && lt[k + 1] < t)
            k++;
        double w = 0;
        if (L > 1)
            w = fmin(fmax((t - lt[k]) / (lt[k + 1] - lt[k]), 0), 1);
        const double *v = c->vb + k * c->nb;
        for (size_t f = 0; f < c->nb; f++)
            out[s * c->nb + f] =
                L > 1 ? (1 - w) * v[f] + w * v[c->nb + f] : v[f];
    }
}

/* What of dist(i, j) no scale changes: each step's weight, how much of
 * both points' values there are their shapes', and the weights' sum. */
static void step_weights(phks__verifier *c)
{
    size_t L = c->length, steps = c->steps, nb = c->nb;
    for (size_t i = 0; i < c->na; i++)
        for (size_t j = 0; j < nb; j++) {
            double *sw = c->step_weight + i * steps * nb + j, w = 0;
            for (size_t k = 0; k < steps; k++) {
                sw[k * nb] = c->wa[i * L + k] * c->wb[j * L + k];
                w += sw[k * nb];
            }
            c->weight_sum[i * nb + j] = w;
        }
}

/* One step of distances for all of b's points at once: a loop the
 * compiler runs on vectors. */
static void add_step(size_t nb, double x, const double *restrict y,
                     const double *restrict weight, double *restrict sum,
                     double *restrict last)
{
    for (size_t j = 0; j < nb; j++) {
        double d = x - y[j];
        sum[j] += weight[j] * fabs(d - last[j]);
        last[j] = d;
    }
}

/* dist(i, j): the L1 distance of the vectors' steps from one time scale
 * to the next, each weighted by its step weight, scaled back to the full
 * length (a vector of one value: the distance of the values). Steps
 * rather than values: a part of a shape differs from its whole by a
 * factor in HKS A_t that hardly changes over the larger scales (its mass
 * spreads over a different total), which the steps cancel. Each sum runs
 * over the steps in order. */
static void distances(phks__verifier *c, const double *vb)
{
    size_t L = c->length, steps = c->steps, nb = c->nb, first = L > 1;
    for (size_t i = 0; i < c->na; i++) {
        const double *x = c->va + i * L;
        for (size_t j = 0; j < nb; j++) {
            c->sum[j] = 0;
            c->last[j] = first ? x[0] - vb[j] : 0;
        }
        for (size_t k = 0; k < steps; k++)
            add_step(nb, x[k + first], vb + (k + first) * nb,
                     c->step_weight + (i * steps + k) * nb, c->sum, c->last);
        for (size_t j = 0; j < nb; j++) {
            double w = c->weight_sum[i * nb + j];
            c->dist[i * nb + j] = w > 0 ? c->sum[j] / w * (double)L : INFINITY;
        }
    }
}

/* Radii apart that a scale shifts an image by at most (see
 * image_distances_at): SCALE_STEPS halved, rounded up. */
#define RADIUS_SHIFT ((SCALE_STEPS + 1) / 2)

/* The Hellinger distance of two images of PHKS__SPIN_IMAGE bytes: the
 * bytes over 255 are unit vectors. The squares of the bytes' differences
 * sum exactly in integers, in any order, so every build and machine
 * gets the same bits. */
static double hellinger_distance(const uint8_t *x, const uint8_t *y)
{
    uint32_t sum = 0;
    for (size_t b = 0; b < PHKS__SPIN_IMAGE; b++) {
        int32_t d = (int32_t)x[b] - (int32_t)y[b];
        sum += (uint32_t)(d * d);
    }
    return sqrt((double)sum / (2.0 * 255 * 255));
}

/* Every radius of every feature of a against each radius of every point
 * of b that some scale pairs it with, once per entry. */
static void image_distances(phks__verifier *c)
{
    const int R = PHKS__SPIN_RADII, I = PHKS__SPIN_IMAGE;
    for (size_t i = 0; i < c->na; i++)
        for (size_t j = 0; j < c->nb; j++)
            for (int k = 0; k < R; k++) {
                int low = k > RADIUS_SHIFT ? k - RADIUS_SHIFT : 0;
                int high = k + RADIUS_SHIFT < R ? k + RADIUS_SHIFT : R - 1;
                for (int m = low; m <= high; m++)
                    c->image_distance[((i * c->nb + j) * R + k) * R + m] =
                        hellinger_distance(
                            c->a->spin + i * PHKS__SPIN_BYTES + k * I,
                            c->b->spin + j * PHKS__SPIN_BYTES + m * I);
            }
}

/* dist(i, j) from the images at the scale 2^(steps/4) of a's unit box
 * over b's: a's radius k is b's k - steps/2 on the ladder of steps
 * sqrt(2), between two of b's radii at an odd step (the mean of both
 * distances). The mean over a's radii that b has; INFINITY when none. */
static void image_distances_at(phks__verifier *c, int steps)
{
    const int R = PHKS__SPIN_RADII;
    for (size_t i = 0; i < c->na; i++)
        for (size_t j = 0; j < c->nb; j++) {
            const double *h =
                c->image_distance + (i * c->nb + j) * (size_t)(R * R);
            double sum = 0;
            int used = 0;
            for (int k = 0; k < R; k++) {
                int twice = 2 * k - steps, odd = twice & 1;
                int low = (twice - odd) / 2, high = low + odd;
                if (low < 0 || high >= R)
                    continue;
                sum += (h[k * R + low] + h[k * R + high]) / 2;
                used++;
            }
            c->dist_image[i * c->nb + j] = used ? sum / used : INFINITY;
        }
}

/* The `per` of b's points smallest in row, smallest first (lower index
 * on ties), appended to the first `given` of mine, where a point already
 * among them is not repeated; returns how many of mine are taken, given
 * included. */
static size_t nearest_points(const double *row, size_t nb, size_t per,
                             proposal *mine, size_t given)
{
    size_t have = 0;
    proposal *fresh = mine + given;
    for (size_t j = 0; j < nb; j++) {
        if (have == per && row[j] >= row[fresh[per - 1].j])
            continue;
        size_t at = have < per ? have++ : per - 1;
        for (; at > 0 && row[fresh[at - 1].j] > row[j]; at--)
            fresh[at] = fresh[at - 1];
        fresh[at].j = (uint32_t)j;
    }
    size_t kept = given;
    for (size_t f = 0; f < have; f++) {
        bool repeated = false;
        for (size_t g = 0; g < given; g++)
            repeated = repeated || mine[g].j == fresh[f].j;
        if (!repeated)
            mine[kept++] = fresh[f];
    }
    return kept;
}

/* The own affinity of feature i of a and point j of b at the scale
 * proposed: with spin images the better of the two descriptors', that of
 * the smaller exponent. */
static double own_affinity(const phks__verifier *c, size_t i, size_t j)
{
    size_t at = i * c->nb + j;
    double x = affinity_exponent(c->dist[at], false, c->length);
    if (c->spin)
        x = fmin(x, affinity_exponent(c->dist_image[at], true, c->length));
    return exp(-x);
}

/* Each query feature's CANDIDATES nearest entry points by vector (lower
 * index first on ties); with spin images, half as many nearest by image
 * and as many nearest by vector, a point both find proposed once: the
 * images find a point's own counterpart, the vectors one of its class
 * (docs/method.md section 15). A proposal's affinity is the better of
 * the two descriptors'. The boundary weights have their say once, inside
 * dist: a proposal's affinity was also multiplied by the share of weight
 * left, which on a partial scan, where the heat of most points reaches
 * the silhouette, silenced the geometry (docs/retrieval.md, "Every
 * direction on the whole benchmark"). */
static void propose(phks__verifier *c)
{
    size_t nb = c->nb, per = nb < CANDIDATES ? nb : CANDIDATES;
    if (c->spin)
        per = (per + 1) / 2;
    c->count = 0;
    for (size_t i = 0; i < c->na; i++) {
        proposal *mine = c->p + c->count;
        size_t have = 0;
        if (c->spin)
            have = nearest_points(c->dist_image + i * nb, nb, per, mine, 0);
        have = nearest_points(c->dist + i * nb, nb, per, mine, have);
        for (size_t m = 0; m < have; m++) {
            uint32_t j = mine[m].j;
            double u = own_affinity(c, i, j);
            mine[m] = (proposal){(uint32_t)i, j, u, sqrt(u)};
        }
        c->count += have;
    }
}

/* The matrix entry of two proposals that share no point, at c->scale,
 * for select_set: the set's members are few, and the matrix holds the
 * product of the roots in the order of the proposals' indices, where
 * select_set takes the new proposal first. */
static double set_pair_weight(const phks__verifier *c, const proposal *x,
                              const proposal *y)
{
    double ga = c->ga[x->i * c->na + y->i];
    double gb = c->gb_scaled[x->j * c->nb + y->j];
    double e = disagreement(ga, gb, c->slack), agreed;
    if (c->straight) {
        double sa = c->sa[x->i * c->na + y->i];
        double sb = c->sb_scaled[x->j * c->nb + y->j];
        agreed = better_agreement(ga, gb, e, sa, sb,
                                  straight_disagreement(sa, sb, c->slack));
    } else {
        agreed = agreement(ga, gb, e);
    }
    return pair_weight(agreed, x, y);
}

/* The pairs of proposals that share no point, with both distances:
 * the matrix entries to compute. A feature's proposals are consecutive:
 * p's partners start after the last of its feature's. */
static void candidate_pairs(phks__verifier *c)
{
    size_t n = c->count, k = 0, next = 0;
    for (size_t p = 0; p < n; p++) {
        const proposal *x = c->p + p;
        while (next < n && c->p[next].i == x->i)
            next++;
        const double *ga = c->ga + x->i * c->na;
        const double *gb = c->gb_scaled + x->j * c->nb;
        for (size_t q = next; q < n; q++) {
            const proposal *y = c->p + q;
            if (x->j == y->j || !(x->root * y->root > 0))
                continue;
            c->pair[k] = (pair_ref){(uint32_t)p, (uint32_t)q};
            c->pair_ga[k] = ga[y->i];
            c->pair_gb[k] = gb[y->j];
            if (c->straight) {
                c->pair_sa[k] = c->sa[x->i * c->na + y->i];
                c->pair_sb[k] = c->sb_scaled[x->j * c->nb + y->j];
            }
            k++;
        }
    }
    c->pair_count = k;
}

/* disagreement() of each pair, or straight_disagreement() with
 * `straight`, two at a time where SSE2 is (every x86-64): the same
 * arithmetic on lanes of two, so the same bits. The compiler does not
 * vectorise the loop itself while floating-point traps must stay as
 * written. */
static void disagreements(const double *ga, const double *gb, size_t n,
                          double slack, bool straight, double *e)
{
    size_t k = 0;
#if VERIFY_SSE2
    for (; k + 2 <= n; k += 2) {
        __m128d a = _mm_loadu_pd(ga + k), b = _mm_loadu_pd(gb + k);
        _mm_storeu_pd(e + k, straight ? STRAIGHT_DISAGREEMENT(a, b, slack)
                                      : DISAGREEMENT(a, b, slack));
    }
#endif
    for (; k < n; k++)
        e[k] = straight ? straight_disagreement(ga[k], gb[k], slack)
                        : disagreement(ga[k], gb[k], slack);
}

/* The affinity matrix off its diagonal, dense (on real shapes most pairs
 * of proposals agree somewhat, and the power iteration then runs down
 * whole rows), 0 where two proposals share a point or do not agree. The
 * entries are pair_weight's, computed in passes: the disagreements
 * first, in loops of arithmetic alone, then the agreements. */
static void affinities(phks__verifier *c)
{
    size_t n = c->count, m = c->stride = (n + BLOCK - 1) / BLOCK * BLOCK;
    memset(c->matrix, 0, n * m * sizeof *c->matrix);
    candidate_pairs(c);
    disagreements(c->pair_ga, c->pair_gb, c->pair_count, c->slack, false,
                  c->pair_e);
    if (c->straight)
        disagreements(c->pair_sa, c->pair_sb, c->pair_count, c->slack, true,
                      c->pair_es);
    for (size_t k = 0; k < c->pair_count; k++) {
        size_t p = c->pair[k].p, q = c->pair[k].q;
        double agreed;
        if (c->straight)
            agreed = better_agreement(c->pair_ga[k], c->pair_gb[k],
                                      c->pair_e[k], c->pair_sa[k],
                                      c->pair_sb[k], c->pair_es[k]);
        else
            agreed = agreement(c->pair_ga[k], c->pair_gb[k], c->pair_e[k]);
        double w = pair_weight(agreed, c->p + p, c->p + q);
        if (w > 0)
            c->matrix[p * m + q] = c->matrix[q * m + p] = w;
    }
}

/* The columns of rows p0 .. p0 + BLOCK times x, added to sum: for each
 * row, columns ascending, one product and one sum at a time, in AVX2's
 * lanes of four or the rows one by one: the same bits. Row q holds
 * column q: the matrix is symmetric. */
#if PHKS__HAVE_AVX2
__attribute__((target("avx2"))) static void
add_columns_avx2(const phks__verifier *c, size_t p0, double *sum)
{
    __m256d acc[BLOCK / 4];
    for (size_t r = 0; r < BLOCK / 4; r++)
        acc[r] = _mm256_loadu_pd(sum + 4 * r);
    for (size_t q = 0; q < c->count; q++) {
        const double *column = c->matrix + q * c->stride + p0;
        __m256d xq = _mm256_set1_pd(c->x[q]);
        for (size_t r = 0; r < BLOCK / 4; r++)
            acc[r] = _mm256_add_pd(
                acc[r], _mm256_mul_pd(_mm256_loadu_pd(column + 4 * r), xq));
    }
    for (size_t r = 0; r < BLOCK / 4; r++)
        _mm256_storeu_pd(sum + 4 * r, acc[r]);
}
#endif

static void add_columns(const phks__verifier *c, size_t p0, double *sum)
{
    for (size_t q = 0; q < c->count; q++) {
        const double *column = c->matrix + q * c->stride + p0;
        double xq = c->x[q];
        for (size_t r = 0; r < BLOCK; r++)
            sum[r] += column[r] * xq;
    }
}

/* y[p0 .. p0 + BLOCK) of y = A x: each its diagonal term plus the
 * matrix's row, columns ascending (the zeros add nothing: x >= 0), the
 * rows' sums side by side. Rows past count are left out. */
static void multiply_block(const phks__verifier *c, size_t p0)
{
    size_t n = c->count;
    double sum[BLOCK];
    for (size_t r = 0; r < BLOCK; r++)
        sum[r] = p0 + r < n ? c->p[p0 + r].affinity * c->x[p0 + r] : 0;
#if PHKS__HAVE_AVX2
    if (c->avx2)
        add_columns_avx2(c, p0, sum);
    else
#endif
        add_columns(c, p0, sum);
    for (size_t r = 0; r < BLOCK && p0 + r < n; r++)
        c->y[p0 + r] = sum[r];
}

static void leading_vector(phks__verifier *c)
{
    size_t n = c->count;
    for (size_t p = 0; p < n; p++)
        c->x[p] = 1 / sqrt((double)n);
    for (int it = 0; it < ITERATIONS; it++) {
        for (size_t p0 = 0; p0 < n; p0 += BLOCK)
            multiply_block(c, p0);
        double norm = 0;
        for (size_t p = 0; p < n; p++)
            norm += c->y[p] * c->y[p];
        if (!(norm > 0))
            return;
        norm = sqrt(norm);
        for (size_t p = 0; p < n; p++)
            c->x[p] = c->y[p] / norm;
    }
}

/* Largest entry first, the lower index on ties. */
static int by_reading_order(const void *x, const void *y)
{
    const ranked *a = x, *b = y;
    if (a->x != b->x)
        return a->x > b->x ? -1 : 1;
    return (a->p > b->p) - (a->p < b->p);
}

/* Reads the eigenvector greedily, from its largest entry down, into a
 * one-to-one set and returns its affinity; pair_of as phks__verify's. */
static double select_set(phks__verifier *c, uint32_t *pair_of)
{
    size_t ranks = 0, taken = 0;
    for (size_t p = 0; p < c->count; p++)
        if (c->x[p] > 0)
            c->order[ranks++] = (ranked){c->x[p], p};
    qsort(c->order, ranks, sizeof *c->order, by_reading_order);
    double total = 0;
    for (size_t r = 0; r < ranks; r++) {
        size_t best = c->order[r].p;
        const proposal *x = c->p + best;
        double with = 0;
        bool clash = false;
        for (size_t k = 0; k < taken && !clash; k++) {
            const proposal *y = c->p + c->set[k];
            clash = x->i == y->i || x->j == y->j;
            if (!clash)
                with += set_pair_weight(c, x, y);
        }
        if (clash || (taken && agrees_too_little(with, taken, x,
                                                    c->p + c->set[0])))
            continue;
        c->set[taken++] = best;
        total += member_affinity(x, with);
        if (pair_of)
            pair_of[x->i] = x->j;
    }
    return total;
}

/* The proposals at the scale 2^(steps/4). */
static void propose_at(phks__verifier *c, int steps)
{
    double scale = exp2(steps / 4.0);
    const double *vb = c->vb;
    if (scale != 1 &&
        c->a->options.hks_scaling == PHKS_HKS_SCALING_LOCAL_AREA) {
        shift_times(c, scale, c->vb_shift);
        vb = c->vb_shift;
    }
    c->scale = scale;
    for (size_t k = 0; k < c->nb * c->nb; k++)
        c->gb_scaled[k] = scale * c->gb[k];
    if (c->straight)
        for (size_t k = 0; k < c->nb * c->nb; k++)
            c->sb_scaled[k] = scale * c->sb[k];
    if (c->spin)
        image_distances_at(c, steps);
    distances(c, vb);
    propose(c);
}

/* The verified set's affinity at the scale proposed. */
static double verified_set(phks__verifier *c, uint32_t *pair_of)
{
    affinities(c);
    leading_vector(c);
    for (size_t i = 0; i < c->na; i++)
        pair_of[i] = UINT32_MAX;
    return select_set(c, pair_of);
}

/* The largest verified affinity over the scales, and its set in pair_of
 * (may be NULL): the first scale's on ties, from the smallest up. The
 * scales are tried from 1 outwards, the likeliest first, and one whose
 * bound is below the best so far is passed over: its set could not be
 * the best. The bound is the exact sum's; BOUND_MARGIN covers both sums'
 * rounding. */
static double best_affinity(phks__verifier *c, uint32_t *pair_of)
{
    double best = -1;
    int best_k = 0;
    for (int t = 0; t <= 2 * SCALE_STEPS; t++) {
        int k = (t + 1) / 2 * (t % 2 ? -1 : 1);
        propose_at(c, k);
        if (best >= 0 && affinity_bound(c->p, c->count) * (1 + BOUND_MARGIN) < best)
            continue;
        double e = verified_set(c, c->trial);
        if (e > best || (e == best && k < best_k)) {
            best = e;
            best_k = k;
            if (pair_of)
                memcpy(pair_of, c->trial, c->na * sizeof *pair_of);
        }
    }
    return best;
}

/* The verifier's arrays, for allocate and phks__verifier_free. */
#define OWNED(c)                                                            \
    {(c)->va, (c)->vb, (c)->wa, (c)->wb, (c)->vb_shift, (c)->step_weight,   \
     (c)->sum, (c)->last, (c)->weight_sum, (c)->dist, (c)->ga,              \
     (c)->gb, (c)->gb_scaled, (c)->p, (c)->pair, (c)->pair_ga,              \
     (c)->pair_gb, (c)->pair_e, (c)->matrix, (c)->x, (c)->y, (c)->order,    \
     (c)->set, (c)->trial, SPIN_OWNED(c)}
/* ... of which these, last, only with spin images (NULL without). */
#define SPIN_OWNED(c)                                                       \
    (c)->dist_image, (c)->sa, (c)->sb, (c)->sb_scaled, (c)->pair_sa,        \
        (c)->pair_sb, (c)->pair_es, (c)->image_distance

void phks__verifier_free(phks__verifier *c)
{
    if (!c)
        return;
    void *owned[] = OWNED(c);
    for (size_t k = 0; k < sizeof owned / sizeof owned[0]; k++)
        phks__free(owned[k]);
    phks__free(c);
}

/* Room for entries of up to nb points; an entry's arrays are laid out
 * by its own count within them. */
static bool allocate(phks__verifier *c, size_t nb)
{
    size_t na = c->na, L = c->length;
    bool spin = c->a->spin;
    size_t per = nb < CANDIDATES ? nb : CANDIDATES;
    size_t most = na * per + 1;
    c->va = phks__malloc_array(na, L * sizeof *c->va);
    c->vb = phks__malloc_array(nb, L * sizeof *c->vb);
    c->wa = phks__malloc_array(na, L * sizeof *c->wa);
    c->wb = phks__malloc_array(nb, L * sizeof *c->wb);
    c->vb_shift = phks__malloc_array(nb, L * sizeof *c->vb_shift);
    c->step_weight =
        phks__malloc_array(na * nb, c->steps * sizeof *c->step_weight);
    c->sum = phks__malloc_array(nb, sizeof *c->sum);
    c->last = phks__malloc_array(nb, sizeof *c->last);
    c->weight_sum = phks__malloc_array(na, nb * sizeof *c->weight_sum);
    c->dist = phks__malloc_array(na, nb * sizeof *c->dist);
    c->ga = phks__malloc_array(na, na * sizeof *c->ga);
    c->gb = phks__malloc_array(nb, nb * sizeof *c->gb);
    c->gb_scaled = phks__malloc_array(nb, nb * sizeof *c->gb_scaled);
    c->p = phks__malloc_array(most, sizeof *c->p);
    c->pair = phks__malloc_array(most, most / 2 * sizeof *c->pair);
    c->pair_ga = phks__malloc_array(most, most / 2 * sizeof *c->pair_ga);
    c->pair_gb = phks__malloc_array(most, most / 2 * sizeof *c->pair_gb);
    c->pair_e = phks__malloc_array(most, most / 2 * sizeof *c->pair_e);
    c->matrix = phks__malloc_array(most, (most + BLOCK) * sizeof *c->matrix);
    c->x = phks__malloc_array(most, sizeof *c->x);
    c->y = phks__malloc_array(most, sizeof *c->y);
    c->order = phks__malloc_array(most, sizeof *c->order);
    c->set = phks__malloc_array(most, sizeof *c->set);
    c->trial = phks__malloc_array(na + 1, sizeof *c->trial);
    if (spin) {
        size_t R = PHKS__SPIN_RADII;
        c->dist_image = phks__malloc_array(na, nb * sizeof *c->dist_image);
        c->sa = phks__malloc_array(na, na * sizeof *c->sa);
        c->sb = phks__malloc_array(nb, nb * sizeof *c->sb);
        c->sb_scaled = phks__malloc_array(nb, nb * sizeof *c->sb_scaled);
        c->pair_sa = phks__malloc_array(most, most / 2 * sizeof *c->pair_sa);
        c->pair_sb = phks__malloc_array(most, most / 2 * sizeof *c->pair_sb);
        c->pair_es = phks__malloc_array(most, most / 2 * sizeof *c->pair_es);
        c->image_distance = phks__malloc_array(
            (na + 1) * (nb + 1), R * R * sizeof *c->image_distance);
    }
    void *owned[] = OWNED(c), *spin_owned[] = {SPIN_OWNED(c)};
    size_t needed = sizeof owned / sizeof owned[0] -
                    (spin ? 0 : sizeof spin_owned / sizeof spin_owned[0]);
    for (size_t k = 0; k < needed; k++)
        if (!owned[k])
            return false;
    return true;
}

phks_status phks__verifier_new(const phks_signature *a, size_t points,
                               phks__verifier **out)
{
    *out = NULL;
    phks__verifier *c = phks__calloc(1, sizeof *c);
    if (!c)
        return phks__fail_oom("verified matching");
    c->a = a;
    c->na = a->count;
    c->length = a->length;
    c->steps = c->length > 1 ? c->length - 1 : 1;
    c->slack = sqrt(4 * a->options.feature_scale * a->options.tau);
    c->avx2 = phks__cpu_avx2();
    if (!allocate(c, points)) {
        phks__verifier_free(c);
        return phks__fail_oom("verified matching");
    }
    compared_vectors(a, c->na, c->va);
    boundary_weights(a, c->na, c->wa);
    square_distances(a, c->na, c->ga);
    if (a->spin)
        straight_distances(a, c->na, c->sa);
    *out = c;
    return PHKS_OK;
}

/* Everything of entry b the scales do not change. */
static void load_entry(phks__verifier *c, const phks_signature *b)
{
    c->b = b;
    c->nb = phks__signature_points(b);
    for (size_t k = 0; k < c->length; k++)
        c->log_times[k] = log(b->options.scales[k]);
    /* b's vectors by point into vb_shift, free until a scale is tried,
     * then by time scale into vb. */
    compared_vectors(b, c->nb, c->vb_shift);
    for (size_t j = 0; j < c->nb; j++)
        for (size_t k = 0; k < c->length; k++)
            c->vb[k * c->nb + j] = c->vb_shift[j * c->length + k];
    boundary_weights(b, c->nb, c->wb);
    step_weights(c);
    square_distances(b, c->nb, c->gb);
    c->spin = c->a->spin && b->spin;
    c->straight = c->spin && c->a->unit_scale > 0 && b->unit_scale > 0;
    if (c->straight)
        straight_distances(b, c->nb, c->sb);
    if (c->spin)
        image_distances(c);
}

void phks__verifier_run(phks__verifier *c, const phks_signature *b,
                        double nearest, uint32_t *pair_of, double *score)
{
    load_entry(c, b);
    *score = verified_score(nearest, best_affinity(c, pair_of), c->na) *
             phks__global_factor(c->a, b);
}

/* Into best[j] the affinity of feature i with b's point j at the scale
 * proposed, where it is larger. */
static void keep_best_affinities(const phks__verifier *c, size_t i,
                                 double *best)
{
    for (size_t j = 0; j < c->nb; j++)
        best[j] = fmax(best[j], own_affinity(c, i, j));
}

phks_status phks__candidates(const phks_signature *a, size_t feature,
                             const phks_signature *b, size_t k,
                             phks_candidate *out, size_t *count)
{
    size_t nb = phks__signature_points(b);
    phks__verifier *c;
    double *best = phks__calloc(nb + 1, sizeof *best);
    phks_status st = best ? phks__verifier_new(a, nb, &c)
                          : phks__fail_oom("phks_candidates");
    if (st != PHKS_OK) {
        phks__free(best);
        return st;
    }
    load_entry(c, b);
    for (int steps = -SCALE_STEPS; steps <= SCALE_STEPS; steps++) {
        propose_at(c, steps);
        keep_best_affinities(c, feature, best);
    }
    size_t taken = 0;
    for (; taken < k && taken < nb; taken++) {
        size_t most = 0;
        for (size_t j = 1; j < nb; j++)
            if (best[j] > best[most])
                most = j;
        if (!(best[most] > 0))
            break;
        out[taken] = (phks_candidate){(uint32_t)most, best[most]};
        best[most] = -1;
    }
    *count = taken;
    phks__verifier_free(c);
    phks__free(best);
    return PHKS_OK;
}

phks_status phks__verify(const phks_signature *a, const phks_signature *b,
                         double nearest, uint32_t *pair_of, double *score)
{
    phks__verifier *v;
    phks_status st = phks__verifier_new(a, phks__signature_points(b), &v);
    if (st != PHKS_OK)
        return st;
    phks__verifier_run(v, b, nearest, pair_of, score);
    phks__verifier_free(v);
    return PHKS_OK;
}
