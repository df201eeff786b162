/*
 * block_project.c - the Gram-Schmidt products of the eigen-solver: a block
 * W of PHKS_PAIR_BLOCK vectors (row-major, as the operator products leave
 * it) against a basis V of cnt vectors (column-major):
 *     C = V^T W,   W -= V C.
 * With W 16 vectors wide these are thin matrix products that spend much
 * of their time, in a general BLAS, packing V; here V is read in place,
 * four columns at a time against half of W's row (8 accumulators), over
 * stretches of rows that keep W in the first-level cache. C = V^T W is
 * split over threads by columns of V, W -= V C by rows of W: every entry
 * is summed by one thread in a fixed order, so the results do not depend
 * on the thread count.
 */
#include "internal.h"

#include <string.h>

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#define HAVE_AVX2_KERNEL 1
#else
#define HAVE_AVX2_KERNEL 0
#endif

#define B PHKS_PAIR_BLOCK
/* Rows of W per stretch: 128 rows of 16 doubles are 16 KB. */
#define STRETCH 128

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
    for (size_t r0 = 0; r0 < p->n; r0 += STRETCH) {
        size_t r1 = r0 + STRETCH < p->n ? r0 + STRETCH : p->n;
        for (size_t j = j0; j < j1; j++) {
            const double *v = p->v + j * p->n;
            double *c = p->c + j * B;
            for (size_t i = r0; i < r1; i++)
                for (size_t l = 0; l < B; l++)
                    c[l] += v[i] * p->w[i * B + l];
        }
    }
}

#if HAVE_AVX2_KERNEL
__attribute__((target("avx2,fma"))) static void coef_avx2(const project_ctx *p,
                                                           size_t j0, size_t j1)
{
    const size_t n = p->n;
    memset(p->c + j0 * B, 0, (j1 - j0) * B * sizeof(double));
    for (size_t r0 = 0; r0 < n; r0 += STRETCH) {
        size_t r1 = r0 + STRETCH < n ? r0 + STRETCH : n;
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
#if HAVE_AVX2_KERNEL
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

#if HAVE_AVX2_KERNEL
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
#if HAVE_AVX2_KERNEL
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

void phks_block_project(const double *v, size_t n, size_t cnt, double *w,
                        double *c, unsigned threads, bool avx2)
{
    project_ctx p = {v, n, cnt, w, w, c, c, avx2};
    phks_parallel_for((cnt + 3) / 4, threads, coef_range, &p);
    phks_parallel_for((n + STRETCH - 1) / STRETCH, threads, subtract_range, &p);
}
