/*
 * simp_sample.c - the samples of HKS-simp (paper appendix B,
 * docs/method.md section 11): local maxima of a short-time heat
 * diagonal, with spatial coverage, each carrying the area of the mesh
 * vertices it stands for.
 *
 * The paper propagates unit vectors alpha steps with the heat operator
 * H = I - tau D^-1 L of the whole mesh and keeps the local maxima of the
 * diagonal of H^alpha. On a dense mesh that operator cannot even be built:
 * its rows hold every vertex within the cut-off (3.5 kernel widths, about
 * 10^4 vertices per row at 1.6M vertices). So, in time and memory linear
 * in the vertex count (vertices are sorted by radix sorts; only the far
 * fewer candidates and samples by comparison):
 *
 * 1. Candidates. The mesh is cut into cubic cells of edge eps (0.73 times
 *    the expected sample spacing rho, for about CANDIDATES occupied cells
 *    per wanted sample). Each cell's vertices become one candidate: the
 *    vertex nearest to their area-weighted centroid, carrying their summed
 *    area. eps is below the kernel width sqrt(4 tau), so step 2 sees the
 *    mesh's kernel sums up to the quadrature of a Gaussian over cells
 *    smaller than it.
 * 2. Heat diagonal. On the candidates, the operator of appendix B with
 *    the candidates' areas: H_ij = A_j W_ij / d_i, d_i = sum_k A_k W_ik
 *    (for tau = h, H = I - tau D^-1 L is exactly this Markov matrix).
 *    alpha = 2 steps: (H^2)_ii / A_i = (1/d_i) sum_j A_j W_ij^2 / d_j, the
 *    density of heat back at i at time 2 tau from a unit source (divided
 *    by A_i so that it estimates the heat kernel h_t(x, x), the paper's
 *    HKS, rather than the return probability, which would mostly track
 *    the candidates' areas). It is high where heat gathers: tips, thin
 *    parts, boundaries. Two passes over the kernel neighbourhoods and O(1)
 *    memory per candidate, where alpha > 2 would need whole rows of
 *    H^(alpha/2) per candidate. The kernel is cut at HEAT_CUTOFF widths:
 *    the ranking of a smooth function needs no more.
 * 3. Samples. Candidates are visited by decreasing heat value (ties: lower
 *    vertex first) and kept when no sample kept so far lies within rho.
 *    Every local maximum of the heat diagonal within radius rho is kept
 *    (nothing above it lies that close), and the result is a maximal
 *    rho-packing, so every candidate lies within rho of a sample: regions
 *    without maxima (flat, or where the heat diagonal only slopes) are
 *    covered all the same, and so is every component. rho is adjusted
 *    (count ~ area / rho^2) until the count is within 1% of
 *    simplify_target, for at most TRIALS rounds, keeping the closest.
 * 4. Relaxation. The local maxima within PIN_RADIUS rho stay where they
 *    are (the heat's gathering points, about one sample in six); the
 *    other samples take RELAX_ROUNDS Lloyd steps (each moves to the vertex
 *    nearest the centroid of the vertices nearest to it). Evenly spaced
 *    samples make a better quadrature of the kernel, and HKS at 5 tau
 *    correlates much better with the exact one; pinning every rho-maximum
 *    instead of those at PIN_RADIUS rho lost a little of that gain
 *    (docs/benchmarks.md).
 * 5. Masses and gains. Every mesh vertex gives its area to its nearest
 *    sample (Euclidean, ties to the lower sample): Voronoi areas. They are
 *    then adjusted so that the samples reproduce the mesh's own kernel
 *    sums at every sample (match_density): the density (the operator's
 *    diagonal) through the masses, the second moment (the operator's
 *    scale) through a gain per sample.
 *
 * Everything is deterministic: sorts are stable with explicit tie-breaks,
 * parallel loops write disjoint outputs, sums run in a fixed order, and no
 * result depends on the number of threads.
 */
#include "spectrum/simp.h"
#include "core/simd.h"

#include <stdlib.h>

/* Occupied cells (candidates) per wanted sample. */
#define CANDIDATES 4.0
/* A maximal rho-packing of a surface of area S has about PACKING S / rho^2
 * points (random sequential packing of discs of diameter rho covers 0.547
 * of the plane). Only the first guess of rho. */
#define PACKING 0.70
/* Kernel cut-off of the heat diagonal, in widths sqrt(4h) (weight e^-9). */
#define HEAT_CUTOFF 3.0
#define TRIALS 10
/* Samples that are local maxima of the heat diagonal within this many
 * packing radii are not moved by the relaxation. */
#define PIN_RADIUS 2.0
/* Lloyd steps (the samples stop moving after two or three: they snap to
 * vertices). */
#define RELAX_ROUNDS 3
/* Density matching: multiplicative steps, over-relaxed by DENSITY_OMEGA
 * (stable below 2, see match_density). 40 rounds bring the largest
 * mismatch under 2%. */
#define DENSITY_ROUNDS 40
#define DENSITY_OMEGA 1.5
/* The reference kernel sums come from the vertices gathered in cells of
 * this fraction of the kernel width sqrt(4h). */
#define REFERENCE_CELL 0.125
/* Batches per pass, so that progress is reported (and cancellation
 * noticed) well within a second on a million vertices. */
#define BATCHES 32

bool phks__simplify_applies(const phks_options *opt, size_t n)
{
    return opt->simplify_above > 0 && n > opt->simplify_above &&
           n > opt->simplify_target;
}

void phks__samples_release(phks__samples *s)
{
    phks__free(s->vertex);
    phks__free(s->area);
    phks__free(s->of_vertex);
    phks__free(s->gain);
    memset(s, 0, sizeof *s);
}

/* ---------------------------------------------------------------------
 * Grid helpers (cells as grid.c buckets them)
 * --------------------------------------------------------------------- */

static double dist2(const double *a, const double *b)
{
    double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return dx * dx + dy * dy + dz * dz;
}

/* ---------------------------------------------------------------------
 * Kernel sums over point sets
 * --------------------------------------------------------------------- */

/* e[j] = exp(-d2_j / 4h) for the points within the radius, else 0; d2[j]
 * = d2_j. No branches, so the loop vectorises; built twice,
 * for the baseline instruction set and for AVX2 (chosen at run time). C11
 * mode contracts nothing into FMAs, so both give the same bits. */
/* The point and the kernel a row is taken for, passed by value so that
 * the loop sees plain scalars. */
typedef struct {
    double px, py, pz, r2, inv4h;
} row_query;

#define KERNEL_ROW_BODY                                                       \
    const double px = q.px, py = q.py, pz = q.pz, r2 = q.r2, inv4h = q.inv4h; \
    for (size_t j = 0; j < count; j++) {                                      \
        double dx = x[j] - px, dy = y[j] - py, dz = z[j] - pz;                \
        double dd = dx * dx + dy * dy + dz * dz;                              \
        double inside = dd < r2;                                              \
        e[j] = phks__exp_neg((dd < r2 ? dd : r2) * inv4h) * inside;           \
        d2[j] = dd;                                                           \
    }

static void kernel_row_base(const double *restrict x, const double *restrict y,
                            const double *restrict z, size_t count,
                            row_query q, double *restrict e,
                            double *restrict d2)
{
    KERNEL_ROW_BODY
}

#if PHKS__HAVE_AVX2
__attribute__((target("avx2,fma"))) static void
kernel_row_avx2(const double *restrict x, const double *restrict y,
                const double *restrict z, size_t count, row_query q,
                double *restrict e, double *restrict d2)
{
    KERNEL_ROW_BODY
}
#endif

void phks__kernel_row(const double *x, const double *y, const double *z,
                     size_t count, const double p[3], double r2, double inv4h,
                     double *e, double *d2)
{
    row_query q = {p[0], p[1], p[2], r2, inv4h};
#if PHKS__HAVE_AVX2
    if (phks__cpu_avx2()) {
        kernel_row_avx2(x, y, z, count, q, e, d2);
        return;
    }
#endif
    kernel_row_base(x, y, z, count, q, e, d2);
}

/* A point set bucketed by a grid with cells of the kernel radius, stored
 * in grid order as separate coordinate arrays, so that the points of a row
 * of three cells are contiguous and phks__kernel_row runs over them. */
typedef struct {
    phks__grid grid;
    size_t count;
    double *x, *y, *z;
    double r2, inv4h;
} kernel_points;

static void kernel_points_release(kernel_points *kp)
{
    phks__grid_release(&kp->grid);
    phks__free(kp->x);
    phks__free(kp->y);
    phks__free(kp->z);
    memset(kp, 0, sizeof *kp);
}

static phks_status kernel_points_build(const double *xyz, size_t count,
                                       double h, double radius,
                                       kernel_points *kp)
{
    memset(kp, 0, sizeof *kp);
    kp->count = count;
    kp->r2 = radius * radius;
    kp->inv4h = 1 / (4 * h);
    phks_status st = phks__grid_build(xyz, count, 1, radius, &kp->grid);
    if (st != PHKS_OK)
        return st;
    kp->x = phks__malloc_array(count, sizeof *kp->x);
    kp->y = phks__malloc_array(count, sizeof *kp->y);
    kp->z = phks__malloc_array(count, sizeof *kp->z);
    if (!kp->x || !kp->y || !kp->z) {
        kernel_points_release(kp);
        return phks__fail_oom("simplification: kernel sums");
    }
    for (size_t s = 0; s < count; s++) {
        const double *p = xyz + 3 * (size_t)kp->grid.points[s];
        kp->x[s] = p[0];
        kp->y[s] = p[1];
        kp->z[s] = p[2];
    }
    return PHKS_OK;
}

/* A per-point array in grid order. */
static void to_grid_order(const kernel_points *kp, const double *in,
                          double *out)
{
    for (size_t s = 0; s < kp->count; s++)
        out[s] = in[kp->grid.points[s]];
}

#define SUM_CHUNK 256

/* Over the points within the radius of p: *sum0 = sum coef_j e_j (e_j^2
 * when squared) and, if sum2 is not NULL, *sum2 = sum coef_j e_j d2_j,
 * with e_j = exp(-d2_j / 4h) and coef in grid order. */
static void kernel_sums(const kernel_points *kp, const double p[3],
                        const double *coef, bool squared, double *sum0,
                        double *sum2)
{
    double e[SUM_CHUNK], d2[SUM_CHUNK];
    size_t c[3], range[9][2];
    phks__grid_cell(&kp->grid, p, c);
    size_t runs = phks__grid_neighbourhood(&kp->grid, c, range);
    double s0 = 0, s2 = 0;
    for (size_t r = 0; r < runs; r++) {
        size_t a = range[r][0], b = range[r][1];
        for (size_t lo = a; lo < b; lo += SUM_CHUNK) {
            size_t len = b - lo < SUM_CHUNK ? b - lo : SUM_CHUNK;
            phks__kernel_row(kp->x + lo, kp->y + lo, kp->z + lo, len, p,
                            kp->r2, kp->inv4h, e, d2);
            const double *cf = coef + lo;
            for (size_t j = 0; j < len; j++) {
                double w = cf[j] * (squared ? e[j] * e[j] : e[j]);
                s0 += w;
                if (sum2)
                    s2 += w * d2[j];
            }
        }
    }
    *sum0 = s0;
    if (sum2)
        *sum2 = s2;
}

/* ---------------------------------------------------------------------
 * 1. Candidates
 * --------------------------------------------------------------------- */

typedef struct {
    size_t count;
    uint32_t *vertex; /* representative mesh vertex */
    double *area;     /* summed vertex areas        */
    double *xyz;      /* unit-box position of the representative */
} candidates;

static void candidates_release(candidates *c)
{
    phks__free(c->vertex);
    phks__free(c->area);
    phks__free(c->xyz);
    memset(c, 0, sizeof *c);
}

static phks_status make_candidates(const double *xyz, size_t n,
                                   const double *area, double eps,
                                   candidates *out)
{
    memset(out, 0, sizeof *out);
    double lo[3] = {INFINITY, INFINITY, INFINITY};
    double hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t v = 0; v < n; v++)
        for (int d = 0; d < 3; d++) {
            lo[d] = fmin(lo[d], xyz[3 * v + d]);
            hi[d] = fmax(hi[d], xyz[3 * v + d]);
        }
    uint64_t dims[3];
    for (;;) {
        double cells = 1;
        for (int d = 0; d < 3; d++)
            cells *= floor((hi[d] - lo[d]) / eps) + 1;
        if (cells < 0x1p60)
            break;
        eps *= 2;
    }
    for (int d = 0; d < 3; d++)
        dims[d] = (uint64_t)floor((hi[d] - lo[d]) / eps) + 1;
    unsigned bits = 1;
    while (bits < 64 && ((uint64_t)1 << bits) < dims[0] * dims[1] * dims[2])
        bits++;

    phks__keyed *a = phks__malloc_array(n, sizeof *a);
    phks__keyed *tmp = phks__malloc_array(n, sizeof *tmp), *sorted = NULL;
    if (!a || !tmp) {
        phks__free(a);
        phks__free(tmp);
        return phks__fail_oom("simplification: candidates");
    }
    for (size_t v = 0; v < n; v++) {
        uint64_t c[3];
        for (int d = 0; d < 3; d++) {
            double x = floor((xyz[3 * v + d] - lo[d]) / eps);
            c[d] = x < 0 ? 0 : x >= (double)dims[d] ? dims[d] - 1 : (uint64_t)x;
        }
        a[v].key = (c[2] * dims[1] + c[1]) * dims[0] + c[0];
        a[v].id = (uint32_t)v;
    }
    phks_status st = phks__radix_sort(a, tmp, n, bits, PHKS__SPAN_NONE, &sorted);
    if (sorted == tmp) {
        tmp = a;
        a = sorted;
    }
    phks__free(tmp);
    size_t count = 0;
    for (size_t i = 0; st == PHKS_OK && i < n; i++)
        count += i == 0 || a[i].key != a[i - 1].key;
    if (st == PHKS_OK) {
        out->vertex = phks__malloc_array(count, sizeof *out->vertex);
        out->area = phks__malloc_array(count, sizeof *out->area);
        out->xyz = phks__malloc_array(count, 3 * sizeof *out->xyz);
        if (!out->vertex || !out->area || !out->xyz)
            st = phks__fail_oom("simplification: candidates");
    }
    if (st != PHKS_OK) {
        phks__free(a);
        candidates_release(out);
        return st;
    }
    out->count = count;
    size_t c = 0;
    for (size_t i = 0; i < n; c++) {
        size_t j = i;
        double mass = 0, g[3] = {0, 0, 0};
        for (; j < n && a[j].key == a[i].key; j++) {
            const double *p = xyz + 3 * (size_t)a[j].id;
            double w = area[a[j].id];
            mass += w;
            for (int d = 0; d < 3; d++)
                g[d] += w * p[d];
        }
        for (int d = 0; d < 3; d++)
            g[d] /= mass;
        uint32_t best = a[i].id;
        double best_d = dist2(xyz + 3 * (size_t)best, g);
        for (const phks__keyed *q = a + i + 1; q < a + j; q++) {
            double d = dist2(xyz + 3 * (size_t)q->id, g);
            if (d < best_d) {
                best_d = d;
                best = q->id;
            }
        }
        out->vertex[c] = best;
        out->area[c] = mass;
        memcpy(out->xyz + 3 * c, xyz + 3 * (size_t)best, 3 * sizeof(double));
        i = j;
    }
    phks__free(a);
    return PHKS_OK;
}

/* ---------------------------------------------------------------------
 * 2. Heat diagonal
 * --------------------------------------------------------------------- */

typedef struct {
    const kernel_points *kp;
    const double *xyz;    /* the points, in their own order */
    const double *coef;   /* grid order: A_j, then A_j / d_j */
    double *out;          /* grid order: d, then the heat   */
    const double *density; /* grid order; NULL on the first pass */
} heat_ctx;

/* Slot s (grid order): d_s on the first pass, the heat value after. */
static void heat_rows(void *ctx, size_t begin, size_t end)
{
    const heat_ctx *h = ctx;
    for (size_t s = begin; s < end; s++) {
        const double *p = h->xyz + 3 * (size_t)h->kp->grid.points[s];
        double sum;
        kernel_sums(h->kp, p, h->coef, h->density != NULL, &sum, NULL);
        h->out[s] = h->density ? sum / h->density[s] : sum;
    }
}

phks_status phks__heat_diagonal(const phks__kernel_points *points,
                                const phks_options *opt, phks__span at,
                                double *out)
{
    const double *xyz = points->xyz, *area = points->area;
    const size_t n = points->n;
    const double h = points->h, radius = points->radius;
    kernel_points kp;
    phks_status st = kernel_points_build(xyz, n, h, radius, &kp);
    if (st != PHKS_OK)
        return st;
    double *coef = phks__malloc_array(n, sizeof *coef);
    double *density = phks__malloc_array(n, sizeof *density);
    double *heat = phks__malloc_array(n, sizeof *heat);
    if (!coef || !density || !heat) {
        st = phks__fail_oom("simplification: heat diagonal");
        goto done;
    }
    /* Slots in grid order: neighbouring points are visited together. */
    to_grid_order(&kp, area, coef);
    heat_ctx ctx = {&kp, xyz, coef, density, NULL};
    unsigned threads = opt ? phks__thread_count(opt) : 1;
    st = phks__run_batched(n, threads, heat_rows, &ctx,
                           phks__span_part(at, 0, 0.5), BATCHES);
    if (st != PHKS_OK)
        goto done;
    for (size_t s = 0; s < n; s++)
        coef[s] /= density[s];
    ctx.out = heat;
    ctx.density = density;
    st = phks__run_batched(n, threads, heat_rows, &ctx,
                           phks__span_part(at, 0.5, 1), BATCHES);
    if (st != PHKS_OK)
        goto done;
    for (size_t s = 0; s < n; s++)
        out[kp.grid.points[s]] = heat[s];
done:
    kernel_points_release(&kp);
    phks__free(coef);
    phks__free(density);
    phks__free(heat);
    return st;
}

/* ---------------------------------------------------------------------
 * 3. Samples: a maximal rho-packing in order of decreasing heat
 * --------------------------------------------------------------------- */

typedef struct {
    double heat;
    uint32_t vertex, index;
} ranked;

static int by_heat(const void *pa, const void *pb)
{
    const ranked *a = pa, *b = pb;
    if (a->heat != b->heat)
        return a->heat > b->heat ? -1 : 1;
    return a->vertex < b->vertex ? -1 : a->vertex > b->vertex;
}

/* Whether some point j of the grid (positions xyz) within squared
 * distance r2 of p, in p's cell or the 26 around it (the cells are at
 * least the radius wide), satisfies pred(ctx, j). */
static bool near_one(const phks__grid *g, const double *xyz, const double *p,
                     double r2, bool (*pred)(const void *, uint32_t),
                     const void *ctx)
{
    size_t c[3], range[9][2];
    phks__grid_cell(g, p, c);
    size_t runs = phks__grid_neighbourhood(g, c, range);
    for (size_t r = 0; r < runs; r++)
        for (size_t q = range[r][0]; q < range[r][1]; q++) {
            uint32_t j = g->points[q];
            if (pred(ctx, j) && dist2(p, xyz + 3 * (size_t)j) < r2)
                return true;
        }
    return false;
}

static bool is_kept(const void *keep, uint32_t j)
{
    return ((const unsigned char *)keep)[j] != 0;
}

typedef struct above_ctx {
    const candidates *c;
    const double *heat;
    uint32_t i;
} above_ctx;

/* Candidate j is hotter than i (ties: the lower vertex). */
static bool is_above(const void *ctx, uint32_t j)
{
    const above_ctx *a = ctx;
    const double *h = a->heat;
    return h[j] > h[a->i] ||
           (h[j] == h[a->i] && a->c->vertex[j] < a->c->vertex[a->i]);
}

/* Marks in keep[] the candidates of the packing of radius rho visited in
 * `order`; *count gets how many are kept. */
static phks_status pack(const candidates *c, const ranked *order, double rho,
                        unsigned char *keep, size_t *count)
{
    phks__grid g = {0};
    phks_status st = phks__grid_build(c->xyz, c->count, 1, rho, &g);
    if (st != PHKS_OK)
        return st;
    double rho2 = rho * rho;
    size_t kept = 0;
    memset(keep, 0, c->count * sizeof *keep);
    for (size_t k = 0; k < c->count; k++) {
        uint32_t i = order[k].index;
        const double *p = c->xyz + 3 * (size_t)i;
        if (!near_one(&g, c->xyz, p, rho2, is_kept, keep)) {
            keep[i] = 1;
            kept++;
        }
    }
    phks__grid_release(&g);
    *count = kept;
    return PHKS_OK;
}

/* Marks the kept candidates (keep[i] != 0) that no candidate of higher
 * heat (ties: lower vertex) approaches within radius with 2. */
static phks_status mark_maxima(const candidates *c, const double *heat,
                               double radius, unsigned char *keep)
{
    phks__grid g = {0};
    phks_status st = phks__grid_build(c->xyz, c->count, 1, radius, &g);
    if (st != PHKS_OK)
        return st;
    double r2 = radius * radius;
    for (size_t i = 0; i < c->count; i++) {
        if (!keep[i])
            continue;
        const double *p = c->xyz + 3 * i;
        const above_ctx ctx = {c, heat, (uint32_t)i};
        keep[i] = near_one(&g, c->xyz, p, r2, is_above, &ctx) ? 1 : 2;
    }
    phks__grid_release(&g);
    return PHKS_OK;
}

/* The packing whose sample count is nearest the target, starting from
 * radius *rho (set to the radius chosen). */
static phks_status choose_samples(const candidates *c, const double *heat,
                                  double *rho_io, size_t target,
                                  unsigned char *keep)
{
    double rho = *rho_io;
    ranked *order = phks__malloc_array(c->count, sizeof *order);
    unsigned char *trial = phks__malloc_array(c->count, sizeof *trial);
    if (!order || !trial) {
        phks__free(order);
        phks__free(trial);
        return phks__fail_oom("simplification: samples");
    }
    for (size_t i = 0; i < c->count; i++)
        order[i] = (ranked){heat[i], c->vertex[i], (uint32_t)i};
    qsort(order, c->count, sizeof *order, by_heat);
    phks_status st = PHKS_OK;
    size_t best = SIZE_MAX;
    for (int round = 0; round < TRIALS; round++) {
        size_t count;
        st = pack(c, order, rho, trial, &count);
        if (st != PHKS_OK)
            break;
        size_t miss = count > target ? count - target : target - count;
        if (best == SIZE_MAX || miss < best) {
            best = miss;
            *rho_io = rho;
            memcpy(keep, trial, c->count * sizeof *keep);
        }
        if (miss <= target / 100 || count == c->count)
            break;
        rho *= sqrt((double)count / (double)target);
    }
    phks__free(order);
    phks__free(trial);
    return st;
}

/* ---------------------------------------------------------------------
 * 4. Nearest sample of every vertex
 * --------------------------------------------------------------------- */

typedef struct {
    const phks__grid *grid;   /* over the samples */
    const double *sample_xyz;
    const double *xyz;       /* mesh vertices, unit box */
    uint32_t *nearest;
} nearest_ctx;

static void nearest_rows(void *ctx, size_t begin, size_t end)
{
    const nearest_ctx *nc = ctx;
    const phks__grid *g = nc->grid;
    size_t dmax = g->dims[0];
    if (g->dims[1] > dmax)
        dmax = g->dims[1];
    if (g->dims[2] > dmax)
        dmax = g->dims[2];
    for (size_t v = begin; v < end; v++) {
        const double *p = nc->xyz + 3 * v;
        size_t c[3];
        phks__grid_cell(g, p, c);
        double best = INFINITY;
        uint32_t who = UINT32_MAX;
        /* Rings of cells at Chebyshev distance k: a sample in ring k + 1 is
         * at least k cells away, so once the best is within k cells no
         * further ring can beat it. */
        for (size_t k = 0; k <= dmax; k++) {
            for (size_t dz = 0; dz <= 2 * k; dz++) {
                if (c[2] + dz < k || c[2] + dz - k >= g->dims[2])
                    continue;
                size_t z = c[2] + dz - k;
                for (size_t dy = 0; dy <= 2 * k; dy++) {
                    if (c[1] + dy < k || c[1] + dy - k >= g->dims[1])
                        continue;
                    size_t y = c[1] + dy - k;
                    bool face = dz == 0 || dz == 2 * k || dy == 0 || dy == 2 * k;
                    for (size_t dx = 0; dx <= 2 * k; dx += face ? 1 : 2 * k) {
                        if (c[0] + dx >= k && c[0] + dx - k < g->dims[0]) {
                            size_t cell = phks__grid_cell_index(g, c[0] + dx - k, y, z);
                            for (size_t q = g->cell_start[cell];
                                 q < g->cell_start[cell + 1]; q++) {
                                uint32_t s = g->points[q];
                                double d = dist2(p, nc->sample_xyz + 3 * (size_t)s);
                                if (d < best || (d == best && s < who)) {
                                    best = d;
                                    who = s;
                                }
                            }
                        }
                        if (k == 0)
                            break;
                    }
                }
            }
            double reach = (double)k * g->cell;
            if (who != UINT32_MAX && best <= reach * reach)
                break;
        }
        nc->nearest[v] = who;
    }
}

/* ---------------------------------------------------------------------
 * 5. Relaxation and densities
 * --------------------------------------------------------------------- */

typedef struct {
    uint32_t vertex;
    uint32_t pinned; /* a local maximum of the heat diagonal */
} pinned_vertex;

static int by_pinned_vertex(const void *pa, const void *pb)
{
    const pinned_vertex *a = pa, *b = pb;
    return a->vertex < b->vertex ? -1 : a->vertex > b->vertex;
}

/* of_vertex for the samples out->vertex (positions from xyz). */
static phks_status assign(const double *xyz, size_t n, phks__samples *out,
                          double rho, unsigned threads, phks__span at)
{
    size_t m = out->count;
    double *sample_xyz = phks__malloc_array(m, 3 * sizeof *sample_xyz);
    if (!sample_xyz)
        return phks__fail_oom("simplification: samples");
    for (size_t s = 0; s < m; s++)
        memcpy(sample_xyz + 3 * s, xyz + 3 * (size_t)out->vertex[s],
               3 * sizeof(double));
    phks__grid grid = {0};
    phks_status st = phks__grid_build(sample_xyz, m, 1, rho, &grid);
    if (st == PHKS_OK) {
        nearest_ctx nc = {&grid, sample_xyz, xyz, out->of_vertex};
        st = phks__run_batched(n, threads, nearest_rows, &nc, at, BATCHES);
    }
    phks__grid_release(&grid);
    phks__free(sample_xyz);
    return st;
}

/* One Lloyd step: every sample that is not a local maximum moves to the
 * vertex of its cell nearest to the cell's area-weighted centroid. Cells
 * are disjoint, so samples stay distinct. */
static phks_status relax(const double *xyz, const double *vertex_area,
                         size_t n, const phks__samples *out,
                         pinned_vertex *chosen)
{
    size_t m = out->count;
    double *cen = phks__calloc(m, 4 * sizeof *cen);
    double *best = phks__malloc_array(m, sizeof *best);
    if (!cen || !best) {
        phks__free(cen);
        phks__free(best);
        return phks__fail_oom("simplification: relaxation");
    }
    for (size_t v = 0; v < n; v++) {
        double *c = cen + 4 * (size_t)out->of_vertex[v];
        for (int d = 0; d < 3; d++)
            c[d] += vertex_area[v] * xyz[3 * v + d];
        c[3] += vertex_area[v];
    }
    for (size_t s = 0; s < m; s++) {
        for (int d = 0; d < 3; d++)
            cen[4 * s + d] /= cen[4 * s + 3];
        best[s] = INFINITY;
    }
    for (size_t v = 0; v < n; v++) {
        uint32_t s = out->of_vertex[v];
        if (chosen[s].pinned || !(cen[4 * (size_t)s + 3] > 0))
            continue;
        double d = dist2(xyz + 3 * v, cen + 4 * (size_t)s);
        if (d < best[s]) {
            best[s] = d;
            chosen[s].vertex = (uint32_t)v;
        }
    }
    phks__free(cen);
    phks__free(best);
    return PHKS_OK;
}

typedef struct {
    const kernel_points *kp;
    const double *mass;      /* grid order */
    const double *at;        /* where to evaluate, 3 each */
    double *out0, *out2;     /* sum m W and sum m W d^2 (out2 may be NULL) */
} density_ctx;

static void density_rows(void *ctx, size_t begin, size_t end)
{
    const density_ctx *dc = ctx;
    for (size_t i = begin; i < end; i++)
        kernel_sums(dc->kp, dc->at + 3 * i, dc->mass, false, dc->out0 + i,
                    dc->out2 ? dc->out2 + i : NULL);
}

/* At each of the n_at points `at`: the kernel sums over `points` (with
 * their masses) of W and of W d^2, the density and the second moment. */
static phks_status densities(const phks__kernel_points *points,
                             const double *at, size_t n_at, unsigned threads,
                             phks__span progress, double *out0, double *out2)
{
    const double *mass = points->area;
    const size_t count = points->n;
    kernel_points kp;
    phks_status st = kernel_points_build(points->xyz, count, points->h,
                                         points->radius, &kp);
    if (st != PHKS_OK)
        return st;
    double *coef = phks__malloc_array(count, sizeof *coef);
    if (!coef) {
        kernel_points_release(&kp);
        return phks__fail_oom("simplification: kernel sums");
    }
    to_grid_order(&kp, mass, coef);
    density_ctx dc = {&kp, coef, at, out0, out2};
    st = phks__run_batched(n_at, threads, density_rows, &dc, progress,
                           BATCHES);
    kernel_points_release(&kp);
    phks__free(coef);
    return st;
}

/* Masses and gains of the samples from the mesh's own kernel sums (taken
 * on `ref`, the mesh's vertices gathered in cells far below the kernel
 * width):
 * - Voronoi areas over- or under-count where samples are unevenly spaced
 *   at the kernel's scale. The masses are adjusted so that the samples'
 *   kernel density sum_q m_q W(p, q) at every sample p matches the mesh's,
 *   by DENSITY_ROUNDS multiplicative (Jacobi-like) steps m_p <- m_p *
 *   mesh_p / samples_p, then scaled back to the mesh's total area. The
 *   density is the operator's diagonal: what heat at p leaks.
 * - The kernel's second moment sum_q m_q W(p, q) |p - q|^2 sets the
 *   operator's scale (on a smooth function the operator is a quarter of it
 *   times the Laplacian). Samples miss the pairs closer than their spacing,
 *   which the mesh has, so their operator is weaker by a few percent (its
 *   eigenvalues too low). gain_p = mesh moment / samples' moment, and the
 *   samples' operator uses kernel entries K_pq sqrt(gain_p gain_q). */
static phks_status match_density(const double *xyz, const candidates *ref,
                                 phks__samples *out, double total,
                                 const phks_options *opt, phks__span at)
{
    const double h = opt->tau, radius = opt->cutoff * sqrt(4 * h);
    const unsigned threads = phks__thread_count(opt);
    size_t m = out->count;
    double *sample_at = phks__malloc_array(m, 3 * sizeof *sample_at);
    double *want0 = phks__malloc_array(m, sizeof *want0);
    double *want2 = phks__malloc_array(m, sizeof *want2);
    double *have = phks__malloc_array(m, sizeof *have);
    out->gain = phks__malloc_array(m, sizeof *out->gain);
    phks_status st = PHKS_OK;
    if (!sample_at || !want0 || !want2 || !have || !out->gain)
        st = phks__fail_oom("simplification: masses");
    if (st == PHKS_OK) {
        for (size_t s = 0; s < m; s++)
            memcpy(sample_at + 3 * s, xyz + 3 * (size_t)out->vertex[s], 3 * sizeof(double));
        phks__kernel_points mesh_points = {ref->xyz, ref->area, ref->count, h,
                                           radius};
        st = densities(&mesh_points, sample_at, m, threads,
                       phks__span_part(at, 0, 0.5), want0, want2);
    }
    phks__kernel_points samples = {sample_at, out->area, m, h, radius};
    for (int round = 0; st == PHKS_OK && round < DENSITY_ROUNDS; round++) {
        st = phks__span_report(at, 0.5 + 0.5 * round / DENSITY_ROUNDS);
        if (st == PHKS_OK)
            st = densities(&samples, sample_at, m, threads, PHKS__SPAN_NONE,
                           have, NULL);
        for (size_t s = 0; st == PHKS_OK && s < m; s++)
            out->area[s] *= pow(want0[s] / have[s], DENSITY_OMEGA);
    }
    if (st == PHKS_OK) {
        double sum = 0;
        for (size_t s = 0; s < m; s++)
            sum += out->area[s];
        for (size_t s = 0; s < m; s++)
            out->area[s] *= total / sum;
        st = densities(&samples, sample_at, m, threads, PHKS__SPAN_NONE, want0,
                       have);
    }
    /* A sample with no other sample within the cut-off (a target too
     * small for the kernel, or a speck of a component) has no second
     * moment to match; gains are kept within [1/4, 4] in any case. */
    for (size_t s = 0; st == PHKS_OK && s < m; s++) {
        double gain = want2[s] / have[s];
        out->gain[s] = !(have[s] > 0) || !(gain > 0) ? 1
                       : gain < 0.25                 ? 0.25
                       : gain > 4                    ? 4
                                                     : gain;
    }
    phks__free(sample_at);
    phks__free(want0);
    phks__free(want2);
    phks__free(have);
    return st;
}

/* ---------------------------------------------------------------------
 * The whole step
 * --------------------------------------------------------------------- */

phks_status phks__simplify(const phks__unit_mesh *um, const phks_options *opt,
                           phks__span at, phks__samples *out)
{
    const phks_mesh *mesh = um->mesh;
    const double scale = um->scale, *vertex_area = um->area;
    memset(out, 0, sizeof *out);
    size_t n = mesh->vertex_count, target = opt->simplify_target;
    double total = 0;
    for (size_t v = 0; v < n; v++)
        total += vertex_area[v];
    double rho = sqrt(PACKING * total / (double)target);
    double h = opt->tau, width = sqrt(4 * h);
    double cut = opt->cutoff < HEAT_CUTOFF ? opt->cutoff : HEAT_CUTOFF;
    unsigned threads = phks__thread_count(opt);

    candidates c = {0}, ref = {0};
    double *heat = NULL;
    unsigned char *keep = NULL;
    pinned_vertex *chosen = NULL;
    size_t m = 0;
    double *xyz = phks__malloc_array(n, 3 * sizeof *xyz);
    phks_status st = xyz ? PHKS_OK : phks__fail_oom("simplification");
    if (st == PHKS_OK) {
        for (size_t i = 0; i < 3 * n; i++)
            xyz[i] = mesh->xyz[i] * scale;
        st = phks__span_report(at, 0);
    }
    /* A surface of area S occupies about 1.5 S / eps^2 cells of edge eps
     * (the mean of |n_x| + |n_y| + |n_z| over directions n is 1.5). */
    if (st == PHKS_OK)
        st = make_candidates(xyz, n, vertex_area,
                             rho * sqrt(1.5 / (CANDIDATES * PACKING)), &c);
    if (st == PHKS_OK) {
        heat = phks__malloc_array(c.count, sizeof *heat);
        keep = phks__malloc_array(c.count, sizeof *keep);
        if (!heat || !keep)
            st = phks__fail_oom("simplification");
    }
    if (st == PHKS_OK) {
        phks__kernel_points candidate_points = {c.xyz, c.area, c.count, h,
                                                cut * width};
        st = phks__heat_diagonal(&candidate_points, opt,
                                 phks__span_part(at, 0.05, 0.45), heat);
    }
    if (st == PHKS_OK)
        st = phks__span_report(at, 0.45);
    if (st == PHKS_OK)
        st = choose_samples(&c, heat, &rho, target, keep);
    if (st == PHKS_OK)
        st = mark_maxima(&c, heat, PIN_RADIUS * rho, keep);

    /* The samples, ascending by vertex. */
    for (size_t i = 0; st == PHKS_OK && i < c.count; i++)
        m += keep[i] != 0;
    if (st == PHKS_OK) {
        chosen = phks__malloc_array(m, sizeof *chosen);
        out->count = m;
        out->vertex = phks__malloc_array(m, sizeof *out->vertex);
        out->area = phks__calloc(m, sizeof *out->area);
        out->of_vertex = phks__malloc_array(n, sizeof *out->of_vertex);
        if (!chosen || !out->vertex || !out->area || !out->of_vertex)
            st = phks__fail_oom("simplification: samples");
    }
    if (st == PHKS_OK) {
        size_t k = 0;
        for (size_t i = 0; i < c.count; i++)
            if (keep[i])
                chosen[k++] = (pinned_vertex){c.vertex[i], keep[i] == 2};
    }
    for (int round = 0; st == PHKS_OK && round <= RELAX_ROUNDS; round++) {
        qsort(chosen, m, sizeof *chosen, by_pinned_vertex);
        for (size_t i = 0; i < m; i++)
            out->vertex[i] = chosen[i].vertex;
        double step = 0.25 / (RELAX_ROUNDS + 1);
        st = assign(xyz, n, out, rho, threads,
                    phks__span_part(at, 0.5 + round * step,
                                    0.5 + (round + 1) * step));
        if (st == PHKS_OK && round < RELAX_ROUNDS)
            st = relax(xyz, vertex_area, n, out, chosen);
    }
    if (st == PHKS_OK) {
        for (size_t v = 0; v < n; v++)
            out->area[out->of_vertex[v]] += vertex_area[v];
        st = phks__span_report(at, 0.75);
    }
    if (st == PHKS_OK)
        st = make_candidates(xyz, n, vertex_area, REFERENCE_CELL * width, &ref);
    if (st == PHKS_OK)
        st = match_density(xyz, &ref, out, total, opt,
                           phks__span_part(at, 0.8, 1));

    phks__free(chosen);
    phks__free(xyz);
    phks__free(heat);
    phks__free(keep);
    candidates_release(&c);
    candidates_release(&ref);
    if (st != PHKS_OK)
        phks__samples_release(out);
    return st;
}
