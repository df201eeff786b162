/*
 * lanczos_pairs.c - the operator laid out for fast products on blocks of
 * vectors: the eigen-solver's hot loop.
 *
 * A product of B with a block of PHKS__PAIR_BLOCK vectors (row-major, one
 * row of the block per point) reads, for every non-zero B_wp, the block's
 * row p: 128 bytes, from the second-level cache at best. That load, not the
 * arithmetic, bounds the CSR product. Two points close in space have almost
 * the same neighbours within the cut-off radius, so here rows go in pairs
 * of neighbours (consecutive in the operator's locality order) that share
 * one column list holding the union of their columns, with two values per
 * entry (zero where a column belongs to one row only). A pair reads each
 * block row once for two rows of the result: the union is only a little
 * longer than one row, so a product costs about half as much
 * (docs/benchmarks.md).
 * Visiting points in the locality order (Morton order of their positions)
 * makes consecutive pairs read nearly the same block rows, which the cache
 * then holds. Beyond a few thousand vertices the matrix outgrows the
 * caches and is read from memory at every product, and that bounds the
 * product (docs/benchmarks.md); up to 65536
 * points the columns are stored in 16 bits, 18 bytes per entry instead of
 * 20.
 *
 * The whole solve runs on the permuted numbering: row r of this matrix is
 * point order[r] of the operator; columns are numbered likewise. Each row
 * of a product is computed by one thread in a fixed order, so results do
 * not depend on the thread count.
 */
#include "eigen/lanczos.h"
#include "core/simd.h"

#include <string.h>

#define B PHKS__PAIR_BLOCK

void phks__operator_pairs_release(phks__operator_pairs *pm)
{
    phks__free(pm->order);
    phks__free(pm->start);
    phks__free(pm->col);
    phks__free(pm->col16);
    phks__free(pm->val);
    memset(pm, 0, sizeof *pm);
}

typedef struct {
    const phks__operator_matrix *op;
    phks__operator_pairs *pm;
    const uint32_t *rank;   /* inverse of pm->order                       */
    bool fill;
} pairs_ctx;

/* Largest point count whose columns fit in 16 bits. */
#define NARROW_MAX 65536

static size_t column(const phks__operator_pairs *pm, size_t e)
{
    return pm->col16 ? pm->col16[e] : pm->col[e];
}

static void set_column(phks__operator_pairs *pm, size_t e, uint32_t col)
{
    if (pm->col16)
        pm->col16[e] = (uint16_t)col;
    else
        pm->col[e] = col;
}

/* Counts (first pass) or stores (second) the entries of pairs [lo, hi):
 * the columns of the first row in the operator's order, then those of the
 * second row that the first lacks. mark[c] (n entries, all SIZE_MAX on
 * entry and exit) holds the entry of column c in the current pair. */
static void pair_rows(const pairs_ctx *c, size_t lo, size_t hi, size_t *mark)
{
    const phks__operator_matrix *op = c->op;
    phks__operator_pairs *pm = c->pm;
    for (size_t g = lo; g < hi; g++) {
        size_t at = c->fill ? pm->start[g] : 0, first = at;
        for (int r = 0; r < 2 && 2 * g + (size_t)r < pm->n; r++) {
            uint32_t w = pm->order[2 * g + (size_t)r];
            for (size_t i = op->row_start[w]; i < op->row_start[w + 1]; i++) {
                uint32_t col = c->rank[op->col[i]];
                size_t e = mark[col];
                if (e == SIZE_MAX) {
                    e = mark[col] = at++;
                    if (c->fill) {
                        set_column(pm, e, col);
                        pm->val[2 * e] = pm->val[2 * e + 1] = 0;
                    }
                }
                if (c->fill)
                    pm->val[2 * e + (size_t)r] = op->val[i];
            }
        }
        for (size_t e = first; e < at; e++) {
            /* reset the marks: the columns are stored (fill) or are
             * found again from the rows (count) */
            if (c->fill)
                mark[column(pm, e)] = SIZE_MAX;
        }
        if (!c->fill) {
            for (int r = 0; r < 2 && 2 * g + (size_t)r < pm->n; r++) {
                uint32_t w = pm->order[2 * g + (size_t)r];
                for (size_t i = op->row_start[w]; i < op->row_start[w + 1]; i++)
                    mark[c->rank[op->col[i]]] = SIZE_MAX;
            }
            pm->start[g + 1] = at;
        }
    }
}

typedef struct {
    const pairs_ctx *c;
    size_t **marks;
    size_t pairs;
    unsigned threads;
} pairs_job;

static void pair_chunk(void *ctx, size_t begin, size_t end)
{
    const pairs_job *j = ctx;
    for (size_t t = begin; t < end; t++)
        pair_rows(j->c, j->pairs * t / j->threads, j->pairs * (t + 1) / j->threads,
                  j->marks[t]);
}

/* Splits the pairs into `parts` ranges of about equal entry counts. */
static void balance(phks__operator_pairs *pm)
{
    size_t total = pm->start[pm->pairs];
    size_t g = 0;
    pm->bound[0] = 0;
    for (unsigned t = 1; t < pm->parts; t++) {
        size_t goal = total / pm->parts * t + total % pm->parts * t / pm->parts;
        while (g < pm->pairs && pm->start[g] < goal)
            g++;
        pm->bound[t] = g;
    }
    pm->bound[pm->parts] = pm->pairs;
}

phks_status phks__operator_pairs_build(const phks__operator_matrix *op,
                                      unsigned threads, phks__operator_pairs *pm)
{
    memset(pm, 0, sizeof *pm);
    size_t n = op->n;
    if (threads < 1)
        threads = 1;
    if (threads > PHKS__PAIR_MAX_THREADS)
        threads = PHKS__PAIR_MAX_THREADS;
    pm->n = n;
    pm->pairs = (n + 1) / 2;
    pm->threads = threads;
    pm->parts = threads * PHKS__PAIR_PARTS_PER_THREAD;
    pm->order = phks__malloc_array(n, sizeof *pm->order);
    pm->start = phks__calloc(pm->pairs + 1, sizeof *pm->start);
    uint32_t *rank = phks__malloc_array(n, sizeof *rank);
    size_t *marks[PHKS__PAIR_MAX_THREADS] = {NULL};
    phks_status st = PHKS_OK;
    if (!pm->order || !pm->start || !rank)
        st = phks__fail_oom("operator pairs");
    for (unsigned t = 0; t < threads && st == PHKS_OK; t++) {
        marks[t] = phks__malloc_array(n, sizeof *marks[t]);
        if (!marks[t])
            st = phks__fail_oom("operator pairs");
        else
            memset(marks[t], 0xff, n * sizeof *marks[t]);
    }
    if (st != PHKS_OK)
        goto done;
    for (size_t r = 0; r < n; r++) {
        pm->order[r] = op->order ? op->order[r] : (uint32_t)r;
        rank[pm->order[r]] = (uint32_t)r;
    }
    pairs_ctx c = {op, pm, rank, false};
    pairs_job job = {&c, marks, pm->pairs, threads};
    phks__parallel_for(threads, threads, pair_chunk, &job);
    for (size_t g = 0; g < pm->pairs; g++)
        pm->start[g + 1] += pm->start[g];
    size_t entries = pm->start[pm->pairs];
    if (n <= NARROW_MAX)
        pm->col16 = phks__malloc_array(entries, sizeof *pm->col16);
    else
        pm->col = phks__malloc_array(entries, sizeof *pm->col);
    pm->val = phks__malloc_array(entries, 2 * sizeof *pm->val);
    if ((!pm->col && !pm->col16) || !pm->val) {
        st = phks__fail_oom("operator pairs");
        goto done;
    }
    c.fill = true;
    phks__parallel_for(threads, threads, pair_chunk, &job);
    balance(pm);
done:
    phks__free(rank);
    for (unsigned t = 0; t < threads; t++)
        phks__free(marks[t]);
    if (st != PHKS_OK)
        phks__operator_pairs_release(pm);
    return st;
}

/* ---------------------------------------------------------------- kernels */

typedef struct {
    const phks__operator_pairs *pm;
    const double *x, *z;
    double *out;
    double alpha, gamma, beta;
} poly_ctx;

/* out rows of pair g from the two accumulated rows acc[0..1][B]. */
static void finish_pair(const poly_ctx *p, size_t g, double acc[2][B])
{
    for (size_t r = 0; r < 2 && 2 * g + r < p->pm->n; r++) {
        size_t w = 2 * g + r;
        const double *xw = p->x + w * B;
        double *o = p->out + w * B;
        if (p->z) {
            const double *zw = p->z + w * B;
            for (size_t j = 0; j < B; j++)
                o[j] = p->alpha * acc[r][j] + p->gamma * xw[j] + p->beta * zw[j];
        } else {
            for (size_t j = 0; j < B; j++)
                o[j] = p->alpha * acc[r][j] + p->gamma * xw[j];
        }
    }
}

static void poly_generic(void *ctx, size_t begin, size_t end)
{
    const poly_ctx *p = ctx;
    const phks__operator_pairs *pm = p->pm;
    for (size_t t = begin; t < end; t++)
        for (size_t g = pm->bound[t]; g < pm->bound[t + 1]; g++) {
            double acc[2][B] = {{0}};
            for (size_t i = pm->start[g]; i < pm->start[g + 1]; i++) {
                const double v0 = pm->val[2 * i], v1 = pm->val[2 * i + 1];
                const double *x = p->x + column(pm, i) * B;
                for (size_t j = 0; j < B; j++) {
                    acc[0][j] += v0 * x[j];
                    acc[1][j] += v1 * x[j];
                }
            }
            finish_pair(p, g, acc);
        }
}

#if PHKS__HAVE_AVX2
/* The AVX2 kernel, compiled once for each width of the column indices
 * (exactly one of col16, col32 is not NULL). */
__attribute__((target("avx2,fma"), always_inline)) static inline void
poly_avx2_body(const poly_ctx *p, size_t begin, size_t end,
               const uint16_t *col16, const uint32_t *col32)
{
    const phks__operator_pairs *pm = p->pm;
    const __m256d alpha = _mm256_set1_pd(p->alpha), gamma = _mm256_set1_pd(p->gamma),
                  beta = _mm256_set1_pd(p->beta);
    for (size_t t = begin; t < end; t++)
        for (size_t g = pm->bound[t]; g < pm->bound[t + 1]; g++) {
            __m256d a0 = _mm256_setzero_pd(), a1 = a0, a2 = a0, a3 = a0;
            __m256d b0 = a0, b1 = a0, b2 = a0, b3 = a0;
            const size_t last = pm->start[g + 1];
            for (size_t i = pm->start[g]; i < last; i++) {
                const double *x = p->x + (col16 ? (size_t)col16[i] : (size_t)col32[i]) * B;
                const __m256d x0 = _mm256_loadu_pd(x), x1 = _mm256_loadu_pd(x + 4),
                              x2 = _mm256_loadu_pd(x + 8), x3 = _mm256_loadu_pd(x + 12);
                const __m256d v0 = _mm256_broadcast_sd(pm->val + 2 * i);
                const __m256d v1 = _mm256_broadcast_sd(pm->val + 2 * i + 1);
                a0 = _mm256_fmadd_pd(v0, x0, a0);
                a1 = _mm256_fmadd_pd(v0, x1, a1);
                a2 = _mm256_fmadd_pd(v0, x2, a2);
                a3 = _mm256_fmadd_pd(v0, x3, a3);
                b0 = _mm256_fmadd_pd(v1, x0, b0);
                b1 = _mm256_fmadd_pd(v1, x1, b1);
                b2 = _mm256_fmadd_pd(v1, x2, b2);
                b3 = _mm256_fmadd_pd(v1, x3, b3);
            }
            const __m256d acc[2][4] = {{a0, a1, a2, a3}, {b0, b1, b2, b3}};
            for (size_t r = 0; r < 2 && 2 * g + r < pm->n; r++) {
                size_t w = 2 * g + r;
                const double *xw = p->x + w * B;
                double *o = p->out + w * B;
                for (size_t j = 0; j < 4; j++) {
                    __m256d y = _mm256_fmadd_pd(gamma, _mm256_loadu_pd(xw + 4 * j),
                                                _mm256_mul_pd(alpha, acc[r][j]));
                    if (p->z)
                        y = _mm256_fmadd_pd(beta, _mm256_loadu_pd(p->z + w * B + 4 * j), y);
                    _mm256_storeu_pd(o + 4 * j, y);
                }
            }
        }
}

__attribute__((target("avx2,fma"))) static void poly_avx2_narrow(void *ctx,
                                                                  size_t begin,
                                                                  size_t end)
{
    const poly_ctx *p = ctx;
    poly_avx2_body(p, begin, end, p->pm->col16, NULL);
}

__attribute__((target("avx2,fma"))) static void poly_avx2_wide(void *ctx,
                                                                size_t begin,
                                                                size_t end)
{
    const poly_ctx *p = ctx;
    poly_avx2_body(p, begin, end, NULL, p->pm->col);
}
#endif

void phks__operator_pairs_poly(const phks__operator_pairs *pm, bool avx2,
                              const double *x, const double *z, double *out,
                              double alpha, double gamma, double beta)
{
    poly_ctx p = {pm, x, z, out, alpha, gamma, beta};
#if PHKS__HAVE_AVX2
    if (avx2) {
        phks__parallel_for(pm->parts, pm->threads,
                          pm->col16 ? poly_avx2_narrow : poly_avx2_wide, &p);
        return;
    }
#else
    (void)avx2;
#endif
    phks__parallel_for(pm->parts, pm->threads, poly_generic, &p);
}
