/*
 * laplacian.c - the Belkin-Sun-Wang mesh-Laplacian in symmetric form.
 *
 * With h = tau, c = 1 / (4 pi h^2), A the vertex areas and
 * W(w,p) = exp(-|w-p|^2 / 4h) cut at radius r:
 *     S = c (diag(K 1) - K),  K_wp = A_w A_p W(w,p)  (w != p)
 * and the generalised problem S phi = lambda Mh phi is turned into the
 * standard one B x = lambda x with B = Mh^-1/2 S Mh^-1/2, phi = Mh^-1/2 x:
 *     B_wp = -c K_wp / sqrt(Mh_w Mh_p),   B_ww = c (K 1)_w / Mh_w.
 * Mh = A for the paper's operator; Mh = A D for the random-walk one, with
 * D_w = (1 / 4 pi h) sum_k A_k W(w,k) (k = w included) as in appendix B.
 * B is symmetric positive semi-definite, so solvers need no factorisation.
 *
 * The same matrix serves any weighted point set (HKS-simp's samples, whose
 * masses are the areas they stand for): a mesh is its vertices with their
 * areas.
 */
#include "operator/operator.h"
#include "core/simd.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Rows are built in batches so that the progress callback can cancel. */
#define ROW_BATCHES 16

typedef struct {
    const phks__grid *grid;
    const double *xyz;
    double scale;
    double radius2;   /* squared cut-off radius */
    double inv4h;     /* 1 / 4h */
    /* The points in the grid's order (cell by cell), so that the points of
     * a row of cells lie in one stretch of memory: scaled positions and
     * areas. */
    const double *px, *py, *pz, *parea;
    size_t *row_start;
    uint32_t *col;
    double *val;      /* on the fill pass: A_p W(w,p) */
    double *density;  /* sum_p A_p W(w,p), p = w included */
    bool fill;
    bool avx2;        /* distances with AVX2 (same results)              */
} build_ctx;

/* Candidates are examined in chunks of this many: distances first, then
 * the kernel for those within the radius, without unpredictable branches. */
#define CHUNK 256

/* Squared distances from p of the sorted points [lo, hi) into d2 (the
 * same roundings in both versions: no fused multiply-add). */
static void distances_generic(const build_ctx *b, const double p[3], size_t lo,
                              size_t hi, double *d2)
{
    for (size_t i = lo; i < hi; i++) {
        double dx = b->px[i] - p[0], dy = b->py[i] - p[1], dz = b->pz[i] - p[2];
        d2[i - lo] = dx * dx + dy * dy + dz * dz;
    }
}

#if PHKS__HAVE_AVX2
__attribute__((target("avx2"))) static void distances_avx2(const build_ctx *b,
                                                            const double p[3],
                                                            size_t lo, size_t hi,
                                                            double *d2)
{
    const __m256d cx = _mm256_set1_pd(p[0]), cy = _mm256_set1_pd(p[1]),
                  cz = _mm256_set1_pd(p[2]);
    size_t i = lo;
    for (; i + 4 <= hi; i += 4) {
        __m256d dx = _mm256_sub_pd(_mm256_loadu_pd(b->px + i), cx);
        __m256d dy = _mm256_sub_pd(_mm256_loadu_pd(b->py + i), cy);
        __m256d dz = _mm256_sub_pd(_mm256_loadu_pd(b->pz + i), cz);
        __m256d s = _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy));
        _mm256_storeu_pd(d2 + (i - lo), _mm256_add_pd(s, _mm256_mul_pd(dz, dz)));
    }
    distances_generic(b, p, i, hi, d2 + (i - lo));
}
#endif

/* y = exp(-x * scale) for x in [0, 64 / scale] (the kernel's arguments:
 * |w - p|^2 / 4h below cutoff^2 <= 64). */
static void kernel_generic(const double *x, double scale, double *y, size_t count)
{
    for (size_t i = 0; i < count; i++)
        y[i] = exp(-x[i] * scale);
}

#if PHKS__HAVE_AVX2
/* exp(t) = 2^k exp(r), k = round(t / ln 2), r = t - k ln 2 in two parts
 * (Cody-Waite), |r| <= ln 2 / 2, exp(r) by its Taylor polynomial of degree
 * 13 (truncation below 1e-17 relative), Horner with fused multiply-adds:
 * within 2 units in the last place of glibc's exp over the kernel's range,
 * at a fraction of its time. */
__attribute__((target("avx2,fma"))) static void kernel_avx2(const double *x,
                                                             double scale,
                                                             double *y,
                                                             size_t count)
{
    static const double coef[14] = {
        1.0, 1.0, 1.0 / 2, 1.0 / 6, 1.0 / 24, 1.0 / 120, 1.0 / 720,
        1.0 / 5040, 1.0 / 40320, 1.0 / 362880, 1.0 / 3628800,
        1.0 / 39916800, 1.0 / 479001600, 1.0 / 6227020800.0};
    const __m256d s = _mm256_set1_pd(-scale);
    const __m256d inv_ln2 = _mm256_set1_pd(1.4426950408889634);
    const __m256d ln2_hi = _mm256_set1_pd(6.93147180369123816490e-01);
    const __m256d ln2_lo = _mm256_set1_pd(1.90821492927058770002e-10);
    size_t i = 0;
    for (; i + 4 <= count; i += 4) {
        __m256d t = _mm256_mul_pd(_mm256_loadu_pd(x + i), s);
        __m256d k = _mm256_round_pd(_mm256_mul_pd(t, inv_ln2),
                                    _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
        __m256d r = _mm256_fnmadd_pd(k, ln2_hi, t);
        r = _mm256_fnmadd_pd(k, ln2_lo, r);
        __m256d e = _mm256_set1_pd(coef[13]);
        for (int j = 12; j >= 0; j--)
            e = _mm256_fmadd_pd(e, r, _mm256_set1_pd(coef[j]));
        /* 2^k: k is in [-93, 0], its exponent field is k + 1023 */
        __m128i k32 = _mm256_cvtpd_epi32(k);
        __m256i k64 = _mm256_cvtepi32_epi64(k32);
        __m256i bits = _mm256_slli_epi64(_mm256_add_epi64(k64, _mm256_set1_epi64x(1023)), 52);
        _mm256_storeu_pd(y + i, _mm256_mul_pd(e, _mm256_castsi256_pd(bits)));
    }
    kernel_generic(x + i, scale, y + i, count - i);
}
#endif

static void kernel(const build_ctx *b, const double *x, double *y, size_t count)
{
#if PHKS__HAVE_AVX2
    if (b->avx2) {
        kernel_avx2(x, b->inv4h, y, count);
        return;
    }
#endif
    kernel_generic(x, b->inv4h, y, count);
}

static void distances(const build_ctx *b, const double p[3], size_t lo,
                      size_t hi, double *d2)
{
#if PHKS__HAVE_AVX2
    if (b->avx2) {
        distances_avx2(b, p, lo, hi, d2);
        return;
    }
#endif
    distances_generic(b, p, lo, hi, d2);
}

/* Visits the neighbours of point w within the radius: counts them (first
 * pass) or stores them (second pass), and sums the kernel density. The
 * 27 cells around w's are 9 runs of 3 consecutive cells; in each run the
 * candidates lie in one stretch of the sorted arrays. w itself is at
 * distance 0, within any radius the options allow. */
static void scan_row(const build_ctx *b, size_t w)
{
    const phks__grid *g = b->grid;
    const double r2 = b->radius2;
    double p[3];
    size_t c[3], range[9][2];
    for (int d = 0; d < 3; d++)
        p[d] = b->xyz[3 * w + d] * b->scale;
    phks__grid_cell(g, p, c);
    size_t runs = phks__grid_neighbourhood(g, c, range);
    size_t count = 0, out = b->fill ? b->row_start[w] : 0;
    double density = 0;
    for (size_t r = 0; r < runs; r++) {
        size_t lo = range[r][0], hi = range[r][1];
        for (size_t first = lo; first < hi; first += CHUNK) {
            size_t last = hi - first > CHUNK ? first + CHUNK : hi, kept = 0;
            uint32_t near[CHUNK];
            double dist2[CHUNK];
            distances(b, p, first, last, dist2);
            if (!b->fill) {
                for (size_t j = 0; j < last - first; j++)
                    count += dist2[j] < r2;
                continue;
            }
            for (size_t j = 0; j < last - first; j++) {
                near[kept] = (uint32_t)(first + j);
                dist2[kept] = dist2[j];
                kept += dist2[j] < r2;
            }
            double weight[CHUNK];
            kernel(b, dist2, weight, kept);
            for (size_t j = 0; j < kept; j++) {
                double aw = b->parea[near[j]] * weight[j];
                density += aw;
                b->col[out] = g->points[near[j]];
                b->val[out] = aw;
                out++;
            }
        }
    }
    if (b->fill)
        b->density[w] = density;
    else
        b->row_start[w + 1] = count;
}

static void scan_rows(void *ctx, size_t begin, size_t end)
{
    for (size_t w = begin; w < end; w++)
        scan_row(ctx, w);
}

/* Turns the stored A_p W(w,p) into entries of B (see the top comment),
 * rows [begin, end); each row's Gershgorin bound goes to row_bound. */
typedef struct {
    phks__operator_matrix *op;
    const double *area, *gain;
    double c;
    double *row_bound;
} finish_ctx;

static void finish_rows(void *ctx, size_t begin, size_t end)
{
    const finish_ctx *f = ctx;
    phks__operator_matrix *op = f->op;
    const double *area = f->area, *gain = f->gain;
    const double c = f->c;
    for (size_t w = begin; w < end; w++) {
        double diag = 0, off = 0;
        size_t self = op->row_start[w];
        for (size_t i = op->row_start[w]; i < op->row_start[w + 1]; i++) {
            uint32_t p = op->col[i];
            if (p == w) {
                self = i;
                continue;
            }
            double k = area[w] * op->val[i]; /* K_wp = A_w A_p W */
            if (gain)
                k *= sqrt(gain[w] * gain[p]);
            diag += k;
            op->val[i] = -c * k / sqrt(op->mass[w] * op->mass[p]);
            off += fabs(op->val[i]);
        }
        op->val[self] = c * diag / op->mass[w];
        f->row_bound[w] = op->val[self] + off;
    }
}

/* Morton (Z-order) key of a point: its position quantised to 2^21 steps
 * per axis of the bounding cube, bits interleaved. */
static uint64_t spread_bits(uint64_t v)
{
    v &= 0x1fffff;
    v = (v | v << 32) & 0x1f00000000ffffull;
    v = (v | v << 16) & 0x1f0000ff0000ffull;
    v = (v | v << 8) & 0x100f00f00f00f00full;
    v = (v | v << 4) & 0x10c30c30c30c30c3ull;
    v = (v | v << 2) & 0x1249249249249249ull;
    return v;
}

typedef struct {
    uint64_t key;
    uint32_t point;
} morton_item;

static int morton_cmp(const void *a, const void *b)
{
    const morton_item *x = a, *y = b;
    if (x->key != y->key)
        return x->key < y->key ? -1 : 1;
    return x->point < y->point ? -1 : x->point > y->point;
}

/* op->order: the points sorted by Morton key (ties by index), so that
 * points close in the order are close in space. */
static phks_status morton_order(const double *xyz, size_t n,
                                phks__operator_matrix *op)
{
    morton_item *items = phks__malloc_array(n, sizeof *items);
    op->order = phks__malloc_array(n, sizeof *op->order);
    if (!items || !op->order) {
        phks__free(items);
        return phks__fail_oom("operator");
    }
    double lo[3] = {INFINITY, INFINITY, INFINITY}, extent = 0;
    for (size_t i = 0; i < n; i++)
        for (int d = 0; d < 3; d++)
            lo[d] = fmin(lo[d], xyz[3 * i + d]);
    for (size_t i = 0; i < n; i++)
        for (int d = 0; d < 3; d++)
            extent = fmax(extent, xyz[3 * i + d] - lo[d]);
    double steps = extent > 0 ? 0x1.fffffp20 / extent : 0;
    for (size_t i = 0; i < n; i++) {
        uint64_t key = 0;
        for (int d = 0; d < 3; d++) {
            double q = (xyz[3 * i + d] - lo[d]) * steps;
            key |= spread_bits(q > 0 ? (uint64_t)q : 0) << d;
        }
        items[i] = (morton_item){key, (uint32_t)i};
    }
    qsort(items, n, sizeof *items, morton_cmp);
    for (size_t i = 0; i < n; i++)
        op->order[i] = items[i].point;
    phks__free(items);
    return PHKS_OK;
}

phks_status phks__operator_build_points(const phks__points *points,
                                        const phks_options *opt,
                                        phks__span at,
                                        phks__operator_matrix *op)
{
    const double *xyz = points->xyz, *area = points->area;
    const double *gain = points->gain;
    const size_t n = points->n;
    const double scale = points->scale;
    memset(op, 0, sizeof *op);
    double h = opt->tau, radius = opt->cutoff * sqrt(4 * h);
    double *density = phks__malloc_array(n, sizeof *density), *sorted = NULL;
    phks__grid grid = {0};
    phks_status st = PHKS_OK;
    op->n = n;
    op->row_start = phks__calloc(n + 1, sizeof *op->row_start);
    op->mass = phks__malloc_array(n, sizeof *op->mass);
    if (!density || !op->row_start || !op->mass) {
        st = phks__fail_oom("operator");
        goto done;
    }
    st = phks__grid_build(xyz, n, scale, radius, &grid);
    if (st != PHKS_OK)
        goto done;
    sorted = phks__malloc_array(n, 4 * sizeof *sorted);
    if (!sorted) {
        st = phks__fail_oom("operator");
        goto done;
    }
    for (size_t i = 0; i < n; i++) {
        const double *r = xyz + 3 * (size_t)grid.points[i];
        sorted[i] = r[0] * scale;
        sorted[n + i] = r[1] * scale;
        sorted[2 * n + i] = r[2] * scale;
        sorted[3 * n + i] = area[grid.points[i]];
    }

    build_ctx b = {&grid, xyz, scale, radius * radius, 1 / (4 * h),
                   sorted, sorted + n, sorted + 2 * n, sorted + 3 * n,
                   op->row_start, NULL, NULL, density, false,
                   phks__cpu_avx2()};
    unsigned threads = phks__thread_count(opt);
    st = phks__run_batched(n, threads, scan_rows, &b,
                           phks__span_part(at, 0, 0.3), ROW_BATCHES);
    if (st != PHKS_OK)
        goto done;
    for (size_t w = 0; w < n; w++)
        op->row_start[w + 1] += op->row_start[w];
    size_t nnz = op->row_start[n];
    op->col = phks__malloc_array(nnz, sizeof *op->col);
    op->val = phks__malloc_array(nnz, sizeof *op->val);
    if (!op->col || !op->val) {
        st = phks__fail_oom("operator matrix");
        goto done;
    }
    b.col = op->col;
    b.val = op->val;
    b.fill = true;
    st = phks__run_batched(n, threads, scan_rows, &b,
                           phks__span_part(at, 0.3, 1), ROW_BATCHES);
    if (st != PHKS_OK)
        goto done;

    for (size_t w = 0; w < n; w++)
        op->mass[w] = opt->operator_kind == PHKS_OPERATOR_RANDOM_WALK
                          ? area[w] * density[w] / (4 * PHKS__PI * h)
                          : area[w];
    /* the row bounds go where the sorted positions were */
    finish_ctx f = {op, area, gain, 1 / (4 * PHKS__PI * h * h), sorted};
    phks__parallel_for(n, threads, finish_rows, &f);
    op->norm_bound = 0;
    for (size_t w = 0; w < n; w++)
        op->norm_bound = fmax(op->norm_bound, sorted[w]);
    st = morton_order(xyz, n, op);
    if (st == PHKS_OK)
        st = phks__span_report(at, 1);
done:
    phks__grid_release(&grid);
    phks__free(density);
    phks__free(sorted);
    if (st != PHKS_OK)
        phks__operator_release(op);
    return st;
}

phks_status phks__operator_build(const phks__unit_mesh *um,
                                 const phks_options *opt, phks__span at,
                                 phks__operator_matrix *op)
{
    phks__points points = {um->mesh->xyz, um->mesh->vertex_count, um->scale,
                           um->area, NULL};
    return phks__operator_build_points(&points, opt, at, op);
}

void phks__operator_release(phks__operator_matrix *op)
{
    phks__free(op->row_start);
    phks__free(op->col);
    phks__free(op->val);
    phks__free(op->mass);
    phks__free(op->order);
    memset(op, 0, sizeof *op);
}

typedef struct {
    const phks__operator_matrix *op;
    const double *x;
    double *y;
    size_t k;
} apply_ctx;

static void apply_rows(void *ctx, size_t begin, size_t end)
{
    const apply_ctx *a = ctx;
    const size_t k = a->k;
    for (size_t w = begin; w < end; w++) {
        double *y = a->y + w * k;
        for (size_t j = 0; j < k; j++)
            y[j] = 0;
        for (size_t i = a->op->row_start[w]; i < a->op->row_start[w + 1]; i++) {
            const double v = a->op->val[i];
            const double *x = a->x + (size_t)a->op->col[i] * k;
            for (size_t j = 0; j < k; j++)
                y[j] += v * x[j];
        }
    }
}

void phks__operator_apply(const phks__operator_matrix *op, const double *x,
                         double *y, size_t k, unsigned threads)
{
    apply_ctx a = {op, x, y, k};
    phks__parallel_for(op->n, threads, apply_rows, &a);
}
