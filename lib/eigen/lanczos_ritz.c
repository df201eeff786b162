/*
 * lanczos_ritz.c - X = V S for the eigen-solver's Ritz vectors (V: n x m,
 * S: m x k, X: n x k, all column-major), on the library's threads; also
 * its other products of n-row vectors with a small matrix (the residuals'
 * sketch, Rayleigh-Ritz).
 *
 * Why not the BLAS. This is the solve's largest product (n x m x k) and,
 * with OPENBLAS_NUM_THREADS=1, the longest serial stretch left in it.
 * Calling the BLAS from the library's threads instead cost more processor
 * time (docs/benchmarks.md): the team's
 * worker is a new thread for each computation, and OpenBLAS sets up its
 * buffers for each new thread that calls it. So a packed product here:
 * S is packed once into panels of NR columns (NR values per row of S,
 * contiguous), each thread packs MR-row slivers of V for a stretch of
 * rows (the stretch's V fits the second-level cache), and an MR x NR tile
 * of X is summed in registers along the whole of m. Each entry of X is
 * summed in the order j = 0 .. m - 1 by one thread, so the result does not
 * depend on the thread count.
 */
#include "eigen/lanczos.h"
#include "core/simd.h"

#include <string.h>

#define MR 8       /* rows of a tile: two AVX2 registers                  */
#define NR 6       /* columns of a tile: 12 accumulators                  */
#define STRETCH 64 /* rows packed at a time: 64 x 624 doubles is 320 KB   */
#define UNITS_PER_THREAD 4 /* runs of stretches, taken as threads come free */

typedef struct {
    const double *v, *spack;
    double *x;
    size_t n, m, k, panels;
    double *vpack[PHKS__PAIR_MAX_THREADS * UNITS_PER_THREAD]; /* one per unit */
    size_t units;
    bool avx2;
} product_ctx;

/* Rows [r0, r1) of V, MR at a time: sliver g holds, for each j, rows
 * r0 + g MR .. + MR - 1 of column j (zeros past r1). */
static void pack_rows(const product_ctx *p, size_t r0, size_t r1, double *vp)
{
    size_t slivers = (r1 - r0 + MR - 1) / MR;
    for (size_t g = 0; g < slivers; g++) {
        size_t lo = r0 + g * MR, rows = r1 - lo < MR ? r1 - lo : MR;
        double *out = vp + g * MR * p->m;
        for (size_t j = 0; j < p->m; j++) {
            const double *col = p->v + j * p->n + lo;
            for (size_t i = 0; i < MR; i++)
                out[j * MR + i] = i < rows ? col[i] : 0;
        }
    }
}

/* The MR x NR tile acc (acc[c * MR + i]: row i, column c) into X. */
static void store_tile(const product_ctx *p, size_t row, size_t rows,
                       size_t panel, const double *acc)
{
    for (size_t c = 0; c < NR && panel * NR + c < p->k; c++)
        memcpy(p->x + (panel * NR + c) * p->n + row, acc + c * MR,
               rows * sizeof(double));
}

static void tile_generic(size_t m, const double *vs, const double *sp, double *acc)
{
    for (size_t i = 0; i < MR * NR; i++)
        acc[i] = 0;
    for (size_t j = 0; j < m; j++)
        for (size_t c = 0; c < NR; c++)
            for (size_t i = 0; i < MR; i++)
                acc[c * MR + i] += vs[j * MR + i] * sp[j * NR + c];
}

#if PHKS__HAVE_AVX2
__attribute__((target("avx2,fma"))) static void tile_avx2(size_t m, const double *vs,
                                                           const double *sp,
                                                           double *acc)
{
    __m256d a0 = _mm256_setzero_pd(), a1 = a0, b0 = a0, b1 = a0, c0 = a0, c1 = a0;
    __m256d d0 = a0, d1 = a0, e0 = a0, e1 = a0, f0 = a0, f1 = a0;
    for (size_t j = 0; j < m; j++) {
        const __m256d v0 = _mm256_loadu_pd(vs + j * MR), v1 = _mm256_loadu_pd(vs + j * MR + 4);
        const double *s = sp + j * NR;
        __m256d t = _mm256_broadcast_sd(s);
        a0 = _mm256_fmadd_pd(v0, t, a0);
        a1 = _mm256_fmadd_pd(v1, t, a1);
        t = _mm256_broadcast_sd(s + 1);
        b0 = _mm256_fmadd_pd(v0, t, b0);
        b1 = _mm256_fmadd_pd(v1, t, b1);
        t = _mm256_broadcast_sd(s + 2);
        c0 = _mm256_fmadd_pd(v0, t, c0);
        c1 = _mm256_fmadd_pd(v1, t, c1);
        t = _mm256_broadcast_sd(s + 3);
        d0 = _mm256_fmadd_pd(v0, t, d0);
        d1 = _mm256_fmadd_pd(v1, t, d1);
        t = _mm256_broadcast_sd(s + 4);
        e0 = _mm256_fmadd_pd(v0, t, e0);
        e1 = _mm256_fmadd_pd(v1, t, e1);
        t = _mm256_broadcast_sd(s + 5);
        f0 = _mm256_fmadd_pd(v0, t, f0);
        f1 = _mm256_fmadd_pd(v1, t, f1);
    }
    _mm256_storeu_pd(acc, a0);
    _mm256_storeu_pd(acc + 4, a1);
    _mm256_storeu_pd(acc + 8, b0);
    _mm256_storeu_pd(acc + 12, b1);
    _mm256_storeu_pd(acc + 16, c0);
    _mm256_storeu_pd(acc + 20, c1);
    _mm256_storeu_pd(acc + 24, d0);
    _mm256_storeu_pd(acc + 28, d1);
    _mm256_storeu_pd(acc + 32, e0);
    _mm256_storeu_pd(acc + 36, e1);
    _mm256_storeu_pd(acc + 40, f0);
    _mm256_storeu_pd(acc + 44, f1);
}
#endif

/* Units [begin, end): each a run of stretches, packed in turn. */
static void product_range(void *ctx, size_t begin, size_t end)
{
    const product_ctx *p = ctx;
    size_t stretches = (p->n + STRETCH - 1) / STRETCH;
    for (size_t t = begin; t < end; t++) {
        double *vp = p->vpack[t];
        for (size_t s = stretches * t / p->units; s < stretches * (t + 1) / p->units;
             s++) {
            size_t r0 = s * STRETCH, r1 = r0 + STRETCH < p->n ? r0 + STRETCH : p->n;
            pack_rows(p, r0, r1, vp);
            size_t slivers = (r1 - r0 + MR - 1) / MR;
            for (size_t panel = 0; panel < p->panels; panel++)
                for (size_t g = 0; g < slivers; g++) {
                    double acc[MR * NR];
                    const double *vs = vp + g * MR * p->m, *sp = p->spack + panel * NR * p->m;
#if PHKS__HAVE_AVX2
                    if (p->avx2)
                        tile_avx2(p->m, vs, sp, acc);
                    else
#endif
                        tile_generic(p->m, vs, sp, acc);
                    size_t row = r0 + g * MR, rows = r1 - row < MR ? r1 - row : MR;
                    store_tile(p, row, rows, panel, acc);
                }
        }
    }
}

phks_status phks__ritz_product(const double *v, size_t n, size_t m, const double *s,
                              size_t k, double *x, unsigned threads, bool avx2)
{
    if (threads < 1)
        threads = 1;
    if (threads > PHKS__PAIR_MAX_THREADS)
        threads = PHKS__PAIR_MAX_THREADS;
    product_ctx p = {v, NULL, x, n, m, k, (k + NR - 1) / NR, {NULL},
                     (size_t)threads * UNITS_PER_THREAD, avx2};
    phks_status st = PHKS_OK;
    double *spack = phks__malloc_array(p.panels * NR, m * sizeof(double));
    for (size_t t = 0; t < p.units && spack; t++)
        if (!(p.vpack[t] = phks__malloc_array(STRETCH, m * sizeof(double))))
            st = phks__fail_oom("Ritz vectors");
    if (!spack)
        st = phks__fail_oom("Ritz vectors");
    if (st == PHKS_OK) {
        for (size_t panel = 0; panel < p.panels; panel++)
            for (size_t j = 0; j < m; j++)
                for (size_t c = 0; c < NR; c++) {
                    size_t col = panel * NR + c;
                    spack[(panel * m + j) * NR + c] = col < k ? s[col * m + j] : 0;
                }
        p.spack = spack;
        phks__parallel_for(p.units, threads, product_range, &p);
    }
    phks__free(spack);
    for (size_t t = 0; t < p.units; t++)
        phks__free(p.vpack[t]);
    return st;
}
