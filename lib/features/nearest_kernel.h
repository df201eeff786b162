/*
 * nearest_kernel.h - the paper's nearest-L1 score of a query against
 * blocks of transposed vectors, in SIMD lanes: the database's scan
 * (db_scan.c) and score.c's score of small sets share it.
 *
 * An entry block holds each scale's values of all its vectors side by
 * side (one lane per vector), padded with +infinity to a multiple of
 * PHKS__NEAREST_LANES, so the L1 distances from one query vector to a
 * row of lanes are computed at once while each lane still adds its
 * |a - b| terms in scale order, as score.c's l1 does: the scores are
 * bit for bit those of the plain loops.
 *
 * Header-only: each file that includes it compiles the kernel into its
 * own functions, cloned per instruction set with PHKS__NEAREST_CLONES.
 */
#ifndef PHKS_NEAREST_KERNEL_H
#define PHKS_NEAREST_KERNEL_H

#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#define PHKS__NEAREST_LANES 8
#define PHKS__NEAREST_ROWS 4

/* The paper's score of the query q against one entry block e of `lanes`
 * lanes, ne of them real. The query's nq vectors of L values are row-major
 * in q, padded with rows of +infinity to a multiple of PHKS__NEAREST_ROWS
 * (a padded row meets a padded lane in inf - inf = NaN, which no minimum
 * ever picks). With
 * prune, gives up as soon as the partial sum reaches limit (and returns
 * it).
 *
 * Every lane adds its |q - e| terms in scale order, as score.c's l1
 * does; minima are taken with score.c's comparison (x < m ? x : m from
 * +infinity), whose result does not depend on the order of the values;
 * the total adds the query's row minima in order, then the entry's. GCC
 * and Clang get explicit vectors (the auto-vectoriser would rather run
 * along the scales, which reorders each sum); four query rows per pass
 * share each load of the entry and give eight independent chains of
 * additions. Other compilers get plain loops. */
/* PHKS_NO_SIMD forces the plain loops, to test them with GCC
 * (core/simd.h). */
#if (defined(__GNUC__) || defined(__clang__)) && !defined(PHKS_NO_SIMD)
/* Inlined into each clone of its callers, so each gets its instructions. */
#define INLINE inline __attribute__((always_inline))
#define VW 4 /* doubles per vector: one AVX register, two SSE2 ones */
typedef double vdouble __attribute__((vector_size(VW * sizeof(double))));
typedef int64_t vbits __attribute__((vector_size(VW * sizeof(double))));

/* Macros rather than functions: a vector passed by value draws ABI notes
 * from the compilers when AVX is off. */
#define SPLAT(x) ((vdouble){(x), (x), (x), (x)})
#define LOAD(v, p) memcpy(&(v), (p), sizeof(vdouble))
#define STORE(p, v) memcpy((p), &(v), sizeof(vdouble))
#define ABS_DIFF(x, r) \
    ((vdouble)((vbits)((x) - (r)) & \
               (vbits){INT64_MAX, INT64_MAX, INT64_MAX, INT64_MAX}))
/* Lane-wise m = x < m ? x : m. */
#define MIN_INTO(m, x)                                                  \
    do {                                                                \
        vbits less_ = (x) < (m);                                        \
        (m) = (vdouble)(((vbits)(x) & less_) | ((vbits)(m) & ~less_)); \
    } while (0)

static INLINE double hmin(const vdouble *v)
{
    double m = INFINITY;
    for (int t = 0; t < VW; t++)
        m = (*v)[t] < m ? (*v)[t] : m;
    return m;
}

/* Row minima of the PHKS__NEAREST_ROWS query rows at q against the entry
 * block, and the
 * distances folded into colmin. */
static INLINE void rows_against(const double *q, size_t L, const double *e,
                                size_t lanes, double *colmin,
                                double min[PHKS__NEAREST_ROWS])
{
    vdouble m0 = SPLAT(INFINITY), m1 = m0, m2 = m0, m3 = m0;
    const double *q0 = q, *q1 = q + L, *q2 = q + 2 * L, *q3 = q + 3 * L;
    for (size_t jb = 0; jb < lanes; jb += PHKS__NEAREST_LANES) {
        vdouble a00 = {0}, a01 = {0}, a10 = {0}, a11 = {0};
        vdouble a20 = {0}, a21 = {0}, a30 = {0}, a31 = {0};
        const double *r = e + jb;
        for (size_t s = 0; s < L; s++, r += lanes) {
            vdouble r0, r1, x;
            LOAD(r0, r);
            LOAD(r1, r + VW);
            x = SPLAT(q0[s]);
            a00 += ABS_DIFF(x, r0);
            a01 += ABS_DIFF(x, r1);
            x = SPLAT(q1[s]);
            a10 += ABS_DIFF(x, r0);
            a11 += ABS_DIFF(x, r1);
            x = SPLAT(q2[s]);
            a20 += ABS_DIFF(x, r0);
            a21 += ABS_DIFF(x, r1);
            x = SPLAT(q3[s]);
            a30 += ABS_DIFF(x, r0);
            a31 += ABS_DIFF(x, r1);
        }
        vdouble c0, c1;
        LOAD(c0, colmin + jb);
        LOAD(c1, colmin + jb + VW);
        MIN_INTO(c0, a00);
        MIN_INTO(c0, a10);
        MIN_INTO(c0, a20);
        MIN_INTO(c0, a30);
        MIN_INTO(c1, a01);
        MIN_INTO(c1, a11);
        MIN_INTO(c1, a21);
        MIN_INTO(c1, a31);
        STORE(colmin + jb, c0);
        STORE(colmin + jb + VW, c1);
        MIN_INTO(m0, a00);
        MIN_INTO(m0, a01);
        MIN_INTO(m1, a10);
        MIN_INTO(m1, a11);
        MIN_INTO(m2, a20);
        MIN_INTO(m2, a21);
        MIN_INTO(m3, a30);
        MIN_INTO(m3, a31);
    }
    min[0] = hmin(&m0);
    min[1] = hmin(&m1);
    min[2] = hmin(&m2);
    min[3] = hmin(&m3);
}
#else
#define INLINE inline

static INLINE void rows_against(const double *q, size_t L, const double *e,
                                size_t lanes, double *colmin,
                                double min[PHKS__NEAREST_ROWS])
{
    for (int u = 0; u < PHKS__NEAREST_ROWS; u++)
        min[u] = INFINITY;
    for (size_t j = 0; j < lanes; j++)
        for (int u = 0; u < PHKS__NEAREST_ROWS; u++) {
            double d = 0;
            for (size_t s = 0; s < L; s++)
                d += fabs(q[u * L + s] - e[s * lanes + j]);
            min[u] = d < min[u] ? d : min[u];
            colmin[j] = d < colmin[j] ? d : colmin[j];
        }
}
#endif

static INLINE double phks__nearest_block(const double *q, size_t nq, size_t L,
                                 const double *e, size_t ne, size_t lanes,
                                 double *colmin, bool prune, double limit)
{
    for (size_t j = 0; j < lanes; j++)
        colmin[j] = INFINITY;
    double total = 0;
    for (size_t i = 0; i < nq;
         i += PHKS__NEAREST_ROWS, q += PHKS__NEAREST_ROWS * L) {
        double min[PHKS__NEAREST_ROWS];
        rows_against(q, L, e, lanes, colmin, min);
        for (size_t u = 0; u < PHKS__NEAREST_ROWS && i + u < nq; u++)
            total += min[u];
        if (prune && total >= limit)
            return total;
    }
    for (size_t j = 0; j < ne; j++)
        total += colmin[j];
    return total;
}

/* The same code compiled twice on x86-64 with GCC, and picked at load time
 * by the CPU: AVX2 does four lanes per instruction instead of two. Both
 * give identical results (no multiplications, so no fused operations).
 * Not under ThreadSanitizer: the dynamic loader runs the picker (an ifunc
 * resolver) before the sanitizer's runtime is ready, and its instrumented
 * entry crashes every program linked with the library at start-up. Not
 * with PHKS_NO_SIMD, whose plain loops are to run as themselves. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && \
    defined(__linux__) && !defined(__SANITIZE_THREAD__) &&              \
    !defined(PHKS_NO_SIMD)
#define PHKS__NEAREST_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define PHKS__NEAREST_CLONES
#endif

#endif
