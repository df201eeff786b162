/*
 * lanczos_gram.c - the Gram-Schmidt products of the eigen-solver: a block
 * W of PHKS__PAIR_BLOCK vectors (row-major, as the operator products leave
 * it) against a basis V of cnt vectors (column-major):
 *     C = V^T W,   W -= V C.
 * With W 16 vectors wide these are thin matrix products that spend much
 * of their time, in a general BLAS, packing V; here V is read in place,
 * four columns at a time against half of W's row (8 accumulators), over
 * stretches of rows that keep W in the first- or second-level cache. C = V^T W is
 * split over threads by columns of V, W -= V C by rows of W: every entry
 * is summed by one thread in a fixed order, so the results do not depend
 * on the thread count.
 */
#include "eigen/lanczos.h"
#include "core/simd.h"

#include <string.h>

#define B PHKS__PAIR_BLOCK
/* Rows of W per stretch in W -= V C: 128 rows of 16 doubles are 16 KB,
 * which stay in the first-level cache while every column of V passes. */
#define STRETCH 128
/* Rows per stretch in C = V^T W, where each thread sweeps its own columns
 * of V: 512 rows are one 4 KB page of a column, so a pass touches each
 * page of V once, not four times (fewer TLB misses, a measurable gain:
 * docs/benchmarks.md). W's 64 KB stay
 * in the second-level cache. The sums run over the rows in the same
 * order whatever the stretch, so the results do not change. */
#define COEF_STRETCH 512

typedef struct {
    const double *v;
    size_t n, cnt;
    const double *w;  /* C = V^T W: W read                              */
    double *wout;     /* W -= V C: W written                            */
    double *c;        /* cnt x B, row-major                             */
    const double *cin;
    bool avx2;
} project_ctx;

/* ------------------------------------------------------------ C = V^T W */

static void coef_generic(const project_ctx *p, size_t j0, size_t j1)
{
    memset(p->c + j0 * B, 0, (j1 - j0) * B * sizeof(double));
    for (size_t r0 = 0; r0 < p->n; r0 += COEF_STRETCH) {
        size_t r1 = r0 + COEF_STRETCH < p->n ? r0 + COEF_STRETCH : p->n;
        for (size_t j = j0; j < j1; j++) {
            const double *v = p->v + j * p->n;
            double *c = p->c + j * B;
            for (size_t i = r0; i < r1; i++)
                for (size_t l = 0; l < B; l++)
                    c[l] += v[i] * p->w[i * B + l];
        }
    }
}

#if PHKS__HAVE_AVX2
__attribute__((target("avx2,fma"))) static void coef_avx2(const project_ctx *p,
                                                           size_t j0, size_t j1)
{
    const size_t n = p->n;
    memset(p->c + j0 * B, 0, (j1 - j0) * B * sizeof(double));
    for (size_t r0 = 0; r0 < n; r0 += COEF_STRETCH) {
        size_t r1 = r0 + COEF_STRETCH < n ? r0 + COEF_STRETCH : n;
        for (size_t j = j0; j < j1; j += 4) {
            const double *v0 = p->v + j * n, *v1 = v0 + n, *v2 = v1 + n, *v3 = v2 + n;
            for (size_t h = 0; h < B; h += 8) {
                double *c0 = p->c + j * B + h, *c1 = c0 + B, *c2 = c1 + B, *c3 = c2 + B;
                __m256d a0 = _mm256_loadu_pd(c0), a1 = _mm256_loadu_pd(c0 + 4);
                __m256d b0 = _mm256_loadu_pd(c1), b1 = _mm256_loadu_pd(c1 + 4);
                __m256d d0 = _mm256_loadu_pd(c2), d1 = _mm256_loadu_pd(c2 + 4);
                __m256d e0 = _mm256_loadu_pd(c3), e1 = _mm256_loadu_pd(c3 + 4);
                for (size_t i = r0; i < r1; i++) {
                    const double *w = p->w + i * B + h;
                    const __m256d w0 = _mm256_loadu_pd(w), w1 = _mm256_loadu_pd(w + 4);
                    __m256d x = _mm256_broadcast_sd(v0 + i);
                    a0 = _mm256_fmadd_pd(x, w0, a0);
                    a1 = _mm256_fmadd_pd(x, w1, a1);
                    x = _mm256_broadcast_sd(v1 + i);
                    b0 = _mm256_fmadd_pd(x, w0, b0);
                    b1 = _mm256_fmadd_pd(x, w1, b1);
                    x = _mm256_broadcast_sd(v2 + i);
                    d0 = _mm256_fmadd_pd(x, w0, d0);
                    d1 = _mm256_fmadd_pd(x, w1, d1);
                    x = _mm256_broadcast_sd(v3 + i);
                    e0 = _mm256_fmadd_pd(x, w0, e0);
                    e1 = _mm256_fmadd_pd(x, w1, e1);
                }
                _mm256_storeu_pd(c0, a0);
                _mm256_storeu_pd(c0 + 4, a1);
                _mm256_storeu_pd(c1, b0);
                _mm256_storeu_pd(c1 + 4, b1);
                _mm256_storeu_pd(c2, d0);
                _mm256_storeu_pd(c2 + 4, d1);
                _mm256_storeu_pd(c3, e0);
                _mm256_storeu_pd(c3 + 4, e1);
            }
        }
    }
}
#endif

static void coef_range(void *ctx, size_t begin, size_t end)
{
    const project_ctx *p = ctx;
    /* units are quads of columns; the last may be shorter */
    size_t j0 = 4 * begin, j1 = 4 * end < p->cnt ? 4 * end : p->cnt;
#if PHKS__HAVE_AVX2
    if (p->avx2) {
        size_t full = j0 + (j1 - j0) / 4 * 4;
        coef_avx2(p, j0, full);
        if (full < j1)
            coef_generic(p, full, j1);
        return;
    }
#endif
    coef_generic(p, j0, j1);
}

/* ------------------------------------------------------------ W -= V C */

static void subtract_generic(const project_ctx *p, size_t r0, size_t r1,
                             size_t j0, size_t j1)
{
    for (size_t j = j0; j < j1; j++) {
        const double *v = p->v + j * p->n, *c = p->cin + j * B;
        for (size_t i = r0; i < r1; i++)
            for (size_t l = 0; l < B; l++)
                p->wout[i * B + l] -= v[i] * c[l];
    }
}

#if PHKS__HAVE_AVX2
__attribute__((target("avx2,fma"))) static void subtract_avx2(const project_ctx *p,
                                                               size_t r0, size_t r1,
                                                               size_t cnt)
{
    const size_t n = p->n;
    for (size_t j = 0; j < cnt; j += 4) {
        const double *v0 = p->v + j * n, *v1 = v0 + n, *v2 = v1 + n, *v3 = v2 + n;
        for (size_t h = 0; h < B; h += 8) {
            const double *c0 = p->cin + j * B + h, *c1 = c0 + B, *c2 = c1 + B, *c3 = c2 + B;
            const __m256d a0 = _mm256_loadu_pd(c0), a1 = _mm256_loadu_pd(c0 + 4);
            const __m256d b0 = _mm256_loadu_pd(c1), b1 = _mm256_loadu_pd(c1 + 4);
            const __m256d d0 = _mm256_loadu_pd(c2), d1 = _mm256_loadu_pd(c2 + 4);
            const __m256d e0 = _mm256_loadu_pd(c3), e1 = _mm256_loadu_pd(c3 + 4);
            for (size_t i = r0; i < r1; i++) {
                double *w = p->wout + i * B + h;
                __m256d w0 = _mm256_loadu_pd(w), w1 = _mm256_loadu_pd(w + 4);
                __m256d x = _mm256_broadcast_sd(v0 + i);
                w0 = _mm256_fnmadd_pd(x, a0, w0);
                w1 = _mm256_fnmadd_pd(x, a1, w1);
                x = _mm256_broadcast_sd(v1 + i);
                w0 = _mm256_fnmadd_pd(x, b0, w0);
                w1 = _mm256_fnmadd_pd(x, b1, w1);
                x = _mm256_broadcast_sd(v2 + i);
                w0 = _mm256_fnmadd_pd(x, d0, w0);
                w1 = _mm256_fnmadd_pd(x, d1, w1);
                x = _mm256_broadcast_sd(v3 + i);
                w0 = _mm256_fnmadd_pd(x, e0, w0);
                w1 = _mm256_fnmadd_pd(x, e1, w1);
                _mm256_storeu_pd(w, w0);
                _mm256_storeu_pd(w + 4, w1);
            }
        }
    }
}
#endif

static void subtract_range(void *ctx, size_t begin, size_t end)
{
    const project_ctx *p = ctx;
    /* units are stretches of rows */
    for (size_t s = begin; s < end; s++) {
        size_t r0 = s * STRETCH, r1 = r0 + STRETCH < p->n ? r0 + STRETCH : p->n;
#if PHKS__HAVE_AVX2
        if (p->avx2) {
            size_t full = p->cnt / 4 * 4;
            subtract_avx2(p, r0, r1, full);
            subtract_generic(p, r0, r1, full, p->cnt);
            continue;
        }
#endif
        subtract_generic(p, r0, r1, 0, p->cnt);
    }
}

void phks__block_project(const double *v, size_t n, size_t cnt, double *w,
                        double *c, unsigned threads, bool avx2)
{
    project_ctx p = {v, n, cnt, w, w, c, c, avx2};
    phks__parallel_for((cnt + 3) / 4, threads, coef_range, &p);
    phks__parallel_for((n + STRETCH - 1) / STRETCH, threads, subtract_range, &p);
}

/* ------------------------------------------------ Gram matrix, solve */

/* Rows summed per partial Gram matrix: fixed, so that the sum does not
 * depend on how the stretches are spread over threads. */
#define GRAM_STRETCH 512

typedef struct {
    const double *w;
    double *wout;
    size_t n;
    double *parts;        /* B x B per stretch                          */
    const double *inv;    /* B x B, row-major: R^-1                     */
    bool avx2;
} gram_ctx;

static void gram_generic(const double *w, size_t r0, size_t r1, double *part)
{
    for (size_t i = r0; i < r1; i++)
        for (size_t a = 0; a < B; a++)
            for (size_t c = 0; c < B; c++)
                part[a * B + c] += w[i * B + a] * w[i * B + c];
}

#if PHKS__HAVE_AVX2
/* Two rows of the Gram matrix at a time, over the stretch's rows (which
 * stay in the second-level cache between the eight sweeps). */
__attribute__((target("avx2,fma"))) static void gram_avx2(const double *w,
                                                           size_t r0, size_t r1,
                                                           double *part)
{
    for (size_t a = 0; a < B; a += 2) {
        __m256d p0 = _mm256_setzero_pd(), p1 = p0, p2 = p0, p3 = p0;
        __m256d q0 = p0, q1 = p0, q2 = p0, q3 = p0;
        for (size_t i = r0; i < r1; i++) {
            const double *x = w + i * B;
            const __m256d x0 = _mm256_loadu_pd(x), x1 = _mm256_loadu_pd(x + 4),
                          x2 = _mm256_loadu_pd(x + 8), x3 = _mm256_loadu_pd(x + 12);
            __m256d s = _mm256_broadcast_sd(x + a);
            p0 = _mm256_fmadd_pd(s, x0, p0);
            p1 = _mm256_fmadd_pd(s, x1, p1);
            p2 = _mm256_fmadd_pd(s, x2, p2);
            p3 = _mm256_fmadd_pd(s, x3, p3);
            s = _mm256_broadcast_sd(x + a + 1);
            q0 = _mm256_fmadd_pd(s, x0, q0);
            q1 = _mm256_fmadd_pd(s, x1, q1);
            q2 = _mm256_fmadd_pd(s, x2, q2);
            q3 = _mm256_fmadd_pd(s, x3, q3);
        }
        double *o = part + a * B;
        _mm256_storeu_pd(o, p0);
        _mm256_storeu_pd(o + 4, p1);
        _mm256_storeu_pd(o + 8, p2);
        _mm256_storeu_pd(o + 12, p3);
        _mm256_storeu_pd(o + 16, q0);
        _mm256_storeu_pd(o + 20, q1);
        _mm256_storeu_pd(o + 24, q2);
        _mm256_storeu_pd(o + 28, q3);
    }
}
#endif

static void gram_range(void *ctx, size_t begin, size_t end)
{
    const gram_ctx *g = ctx;
    for (size_t s = begin; s < end; s++) {
        double *part = g->parts + s * B * B;
        size_t r0 = s * GRAM_STRETCH;
        size_t r1 = r0 + GRAM_STRETCH < g->n ? r0 + GRAM_STRETCH : g->n;
#if PHKS__HAVE_AVX2
        if (g->avx2) {
            gram_avx2(g->w, r0, r1, part);
            continue;
        }
#endif
        memset(part, 0, B * B * sizeof(double));
        gram_generic(g->w, r0, r1, part);
    }
}

size_t phks__block_gram_parts(size_t n)
{
    return (n + GRAM_STRETCH - 1) / GRAM_STRETCH;
}

void phks__block_gram(const double *w, size_t n, double *parts, double *g,
                     unsigned threads, bool avx2)
{
    gram_ctx c = {w, NULL, n, parts, NULL, avx2};
    size_t count = phks__block_gram_parts(n);
    phks__parallel_for(count, threads, gram_range, &c);
    memset(g, 0, B * B * sizeof(double));
    for (size_t s = 0; s < count; s++)
        for (size_t i = 0; i < B * B; i++)
            g[i] += parts[s * B * B + i];
}

static void times_generic(const gram_ctx *g, size_t r0, size_t r1)
{
    for (size_t i = r0; i < r1; i++) {
        double *x = g->wout + i * B, y[B] = {0};
        for (size_t l = 0; l < B; l++)
            for (size_t j = l; j < B; j++)
                y[j] += x[l] * g->inv[l * B + j];
        memcpy(x, y, sizeof y);
    }
}

#if PHKS__HAVE_AVX2
__attribute__((target("avx2,fma"))) static void times_avx2(const gram_ctx *g,
                                                            size_t r0, size_t r1)
{
    const double *inv = g->inv;
    for (size_t i = r0; i < r1; i++) {
        double *x = g->wout + i * B;
        __m256d y0 = _mm256_setzero_pd(), y1 = y0, y2 = y0, y3 = y0;
        /* row l of R^-1 is zero left of column l */
        for (size_t l = 0; l < B; l++) {
            const __m256d s = _mm256_broadcast_sd(x + l);
            const double *v = inv + l * B;
            if (l < 4)
                y0 = _mm256_fmadd_pd(s, _mm256_loadu_pd(v), y0);
            if (l < 8)
                y1 = _mm256_fmadd_pd(s, _mm256_loadu_pd(v + 4), y1);
            if (l < 12)
                y2 = _mm256_fmadd_pd(s, _mm256_loadu_pd(v + 8), y2);
            y3 = _mm256_fmadd_pd(s, _mm256_loadu_pd(v + 12), y3);
        }
        _mm256_storeu_pd(x, y0);
        _mm256_storeu_pd(x + 4, y1);
        _mm256_storeu_pd(x + 8, y2);
        _mm256_storeu_pd(x + 12, y3);
    }
}
#endif

static void times_range(void *ctx, size_t begin, size_t end)
{
    const gram_ctx *g = ctx;
#if PHKS__HAVE_AVX2
    if (g->avx2) {
        times_avx2(g, begin, end);
        return;
    }
#endif
    times_generic(g, begin, end);
}

void phks__block_times_upper(double *w, size_t n, const double *inv,
                            unsigned threads, bool avx2)
{
    gram_ctx c = {NULL, w, n, NULL, inv, avx2};
    phks__parallel_for(n, threads, times_range, &c);
}
