/*
 * verify.c - PHKS_MATCHING_VERIFIED: descriptors propose, geometry
 * decides (docs/method.md section 14).
 *
 * Each feature of the query a proposes its CANDIDATES nearest features of
 * the entry b by vector distance. Two proposals (i, j) and (i', j') agree
 * when the distance along a's surface between i and i' is that along b's
 * between j and j', times the scale s of a's unit box against b's. The
 * largest mutually agreeing set is found as Leordeanu and Hebert's
 * spectral matching does: the leading eigenvector of the proposals'
 * affinity matrix, read greedily into a one-to-one set whose members each
 * agree with most of those taken before them. The score is one minus
 * that set's affinity over the most a query of its size can reach.
 *
 * The scale s is voted for by the ratios of the proposals' distances:
 * the unit box of a cut shape enlarges what is left of it. With the
 * local-area scaling a shape scaled by s has at time t the vector its
 * unscaled self has at t / s^2 (docs/method.md section 9), so b's vectors
 * are then read at the shifted times before proposals are made again.
 */
#include "features/features.h"

#include <float.h>
#include <math.h>
#include <string.h>

/* Proposals per query feature. */
#define CANDIDATES 3
/* Vector distance at which a proposal's own affinity falls to 1/e, per
 * entry of the vector: the logarithms of the local-area scaling differ by
 * 0.15 where HKS A_t differs by about 16%. */
#define VECTOR_SIGMA 0.15
/* Relative disagreement of two distances at which a pair's affinity
 * falls to 1/e. A query's own distance may be longer: a cut or a scan
 * can only lengthen a path, so its excess counts half. */
#define DISTANCE_SIGMA 0.2
/* A member of the verified set agrees, on average, at least this well
 * with those taken before it. */
#define AGREEMENT 0.5
/* Power iterations: the leading eigenvector of a non-negative matrix of
 * a few dozen rows settles well within them. */
#define ITERATIONS 30
/* The scale vote: log2 s in bins of 1 / SCALE_BINS_PER_OCTAVE, from
 * -SCALE_HALF_BINS to SCALE_HALF_BINS of them (1.5 octaves: a cut that
 * leaves a third of a shape's extent). */
#define SCALE_BINS_PER_OCTAVE 8
#define SCALE_HALF_BINS 12

typedef struct proposal {
    uint32_t i, j;
    double distance, affinity;
} proposal;

typedef struct verify_ctx {
    const phks_signature *a, *b;
    size_t length;
    double sigma;     /* vector distance scale: VECTOR_SIGMA * length     */
    double slack;     /* positional uncertainty of a feature point        */
    double *va, *vb;  /* vectors as compared (logarithms)                 */
    double *vb_shift; /* b's vectors read at the times shifted by scale   */
    double *dist;     /* a->count x b->count                              */
    proposal *p;
    size_t count;
    double *m, *x, *y;
} verify_ctx;

static double geodesic(const phks_signature *s, size_t i, size_t j)
{
    return i < j ? s->geodesic[phks__pair_index(i, j)]
                 : s->geodesic[phks__pair_index(j, i)];
}

/* The vectors in a form where a ratio is a difference: the local-area
 * scaling's values already are logarithms. */
static void compared_vectors(const phks_signature *s, double *out)
{
    bool logs = s->options.hks_scaling == PHKS_HKS_SCALING_LOCAL_AREA;
    for (size_t k = 0; k < s->count * s->length; k++)
        out[k] = logs ? s->vectors[k] : log(fmax(s->vectors[k], DBL_MIN));
}

/* b's vectors read at times t / s^2 by linear interpolation in log t,
 * held at the first and last scale outside them. */
static void shift_times(const verify_ctx *c, double scale, double *out)
{
    const phks_options *o = &c->b->options;
    size_t L = c->length;
    for (size_t s = 0; s < L; s++) {
        double t = log(o->scales[s]) - 2 * log(scale);
        size_t k = 0;
        while (k + 2 < L && log(o->scales[k + 1]) < t)
            k++;
        double t0 = log(o->scales[k]), t1 = log(o->scales[k + 1]);
        double w = L > 1 ? (t - t0) / (t1 - t0) : 0;
        w = w < 0 ? 0 : w > 1 ? 1 : w;
        for (size_t f = 0; f < c->b->count; f++) {
            const double *v = c->vb + f * L;
            out[f * L + s] = L > 1 ? (1 - w) * v[k] + w * v[k + 1] : v[0];
        }
    }
}

static void distances(verify_ctx *c, const double *vb)
{
    size_t L = c->length;
    for (size_t i = 0; i < c->a->count; i++)
        for (size_t j = 0; j < c->b->count; j++) {
            double s = 0;
            for (size_t k = 0; k < L; k++)
                s += fabs(c->va[i * L + k] - vb[j * L + k]);
            c->dist[i * c->b->count + j] = s;
        }
}

/* Each query feature's CANDIDATES nearest entry features (lower index
 * first on ties). */
static void propose(verify_ctx *c)
{
    size_t nb = c->b->count, per = nb < CANDIDATES ? nb : CANDIDATES;
    c->count = 0;
    for (size_t i = 0; i < c->a->count; i++) {
        const double *row = c->dist + i * nb;
        proposal *mine = c->p + c->count;
        size_t have = 0;
        for (size_t j = 0; j < nb; j++) {
            if (have == per && row[j] >= mine[per - 1].distance)
                continue;
            size_t at = have < per ? have++ : per - 1;
            for (; at > 0 && mine[at - 1].distance > row[j]; at--)
                mine[at] = mine[at - 1];
            mine[at] = (proposal){(uint32_t)i, (uint32_t)j, row[j],
                                  exp(-row[j] / c->sigma)};
        }
        c->count += have;
    }
}

/* How well two distances agree, 1 at equality (see DISTANCE_SIGMA). */
static double agreement(const verify_ctx *c, double ga, double gb)
{
    if (!isfinite(ga) || !isfinite(gb))
        return 0;
    double e = (ga - gb) / (fmax(ga, gb) + c->slack);
    if (e > 0)
        e /= 2;
    e /= DISTANCE_SIGMA;
    return exp(-e * e);
}

/* The scale of a's unit box against b's most proposals agree with. */
static double vote_scale(const verify_ctx *c)
{
    enum { BINS = 2 * SCALE_HALF_BINS + 1 };
    double votes[BINS] = {0};
    for (size_t p = 0; p < c->count; p++)
        for (size_t q = p + 1; q < c->count; q++) {
            const proposal *x = c->p + p, *y = c->p + q;
            if (x->i == y->i || x->j == y->j)
                continue;
            double ga = geodesic(c->a, x->i, y->i), gb = geodesic(c->b, x->j, y->j);
            /* Short distances say little about a ratio. */
            if (!(ga > 2 * c->slack && gb > 2 * c->slack) || !isfinite(ga) ||
                !isfinite(gb))
                continue;
            double bin = log2(ga / gb) * SCALE_BINS_PER_OCTAVE + SCALE_HALF_BINS;
            if (bin < 0 || bin > BINS - 1)
                continue;
            votes[(size_t)(bin + 0.5)] += x->affinity * y->affinity;
        }
    /* Neighbouring bins count half, so a vote split by a bin edge is
     * not lost. */
    size_t best = BINS / 2;
    double top = -1;
    for (size_t k = 0; k < BINS; k++) {
        double v = votes[k] + 0.5 * ((k ? votes[k - 1] : 0) +
                                     (k + 1 < BINS ? votes[k + 1] : 0));
        if (v > top + 1e-300) {
            top = v;
            best = k;
        }
    }
    if (top <= 0)
        return 1;
    return exp2(((double)best - SCALE_HALF_BINS) / SCALE_BINS_PER_OCTAVE);
}

static void affinities(verify_ctx *c, double scale)
{
    size_t n = c->count;
    for (size_t p = 0; p < n; p++) {
        c->m[p * n + p] = c->p[p].affinity;
        for (size_t q = p + 1; q < n; q++) {
            const proposal *x = c->p + p, *y = c->p + q;
            double w = 0;
            if (x->i != y->i && x->j != y->j)
                w = agreement(c, geodesic(c->a, x->i, y->i),
                              scale * geodesic(c->b, x->j, y->j)) *
                    sqrt(x->affinity * y->affinity);
            c->m[p * n + q] = c->m[q * n + p] = w;
        }
    }
}

static void leading_vector(verify_ctx *c)
{
    size_t n = c->count;
    for (size_t p = 0; p < n; p++)
        c->x[p] = 1 / sqrt((double)n);
    for (int it = 0; it < ITERATIONS; it++) {
        double norm = 0;
        for (size_t p = 0; p < n; p++) {
            double s = 0;
            for (size_t q = 0; q < n; q++)
                s += c->m[p * n + q] * c->x[q];
            c->y[p] = s;
            norm += s * s;
        }
        if (!(norm > 0))
            return;
        norm = sqrt(norm);
        for (size_t p = 0; p < n; p++)
            c->x[p] = c->y[p] / norm;
    }
}

/* Reads the eigenvector greedily into a one-to-one set and returns its
 * affinity; pair_of as phks__verify's. */
static double select_set(verify_ctx *c, uint32_t *pair_of)
{
    size_t n = c->count, taken = 0;
    size_t *set = (size_t *)(void *)c->y; /* y is free again: n slots */
    double total = 0;
    for (;;) {
        size_t best = n;
        for (size_t p = 0; p < n; p++)
            if (c->x[p] > 0 && (best == n || c->x[p] > c->x[best]))
                best = p;
        if (best == n)
            break;
        c->x[best] = 0;
        const proposal *x = c->p + best;
        double with = 0;
        bool clash = false;
        for (size_t k = 0; k < taken && !clash; k++) {
            const proposal *y = c->p + set[k];
            clash = x->i == y->i || x->j == y->j;
            with += c->m[best * n + set[k]];
        }
        if (clash)
            continue;
        double mean = taken ? with / (double)taken : 0;
        if (taken && mean < AGREEMENT * sqrt(x->affinity) *
                                sqrt(c->p[set[0]].affinity))
            continue;
        set[taken++] = best;
        total += x->affinity + 2 * with;
        if (pair_of)
            pair_of[x->i] = x->j;
    }
    return total;
}

static void release(verify_ctx *c)
{
    phks__free(c->va);
    phks__free(c->vb);
    phks__free(c->vb_shift);
    phks__free(c->dist);
    phks__free(c->p);
    phks__free(c->m);
    phks__free(c->x);
    phks__free(c->y);
}

phks_status phks__verify(const phks_signature *a, const phks_signature *b,
                         uint32_t *pair_of, double *score)
{
    size_t na = a->count, nb = b->count, L = a->length;
    size_t most = na * (nb < CANDIDATES ? nb : CANDIDATES);
    verify_ctx c = {0};
    c.a = a;
    c.b = b;
    c.length = L;
    c.sigma = VECTOR_SIGMA * (double)L;
    c.slack = sqrt(4 * a->options.feature_scale * a->options.tau);
    c.va = phks__malloc_array(na, L * sizeof *c.va);
    c.vb = phks__malloc_array(nb, L * sizeof *c.vb);
    c.vb_shift = phks__malloc_array(nb, L * sizeof *c.vb_shift);
    c.dist = phks__malloc_array(na, nb * sizeof *c.dist);
    c.p = phks__malloc_array(most + 1, sizeof *c.p);
    c.m = phks__malloc_array(most * most + 1, sizeof *c.m);
    c.x = phks__malloc_array(most + 1, sizeof *c.x);
    c.y = phks__malloc_array(most + 1, sizeof(double) > sizeof(size_t)
                                           ? sizeof(double)
                                           : sizeof(size_t));
    if (!c.va || !c.vb || !c.vb_shift || !c.dist || !c.p || !c.m || !c.x ||
        !c.y) {
        release(&c);
        return phks__fail_oom("verified matching");
    }
    for (size_t i = 0; pair_of && i < na; i++)
        pair_of[i] = UINT32_MAX;
    compared_vectors(a, c.va);
    compared_vectors(b, c.vb);
    distances(&c, c.vb);
    propose(&c);
    double scale = vote_scale(&c);
    if (scale != 1 && a->options.hks_scaling == PHKS_HKS_SCALING_LOCAL_AREA) {
        shift_times(&c, scale, c.vb_shift);
        distances(&c, c.vb_shift);
        propose(&c);
    }
    affinities(&c, scale);
    leading_vector(&c);
    double total = select_set(&c, pair_of);
    *score = 1 - total / ((double)na * (double)na);
    release(&c);
    return PHKS_OK;
}
