/*
 * lanczos_extract.c - the k lowest eigenpairs of B from a converged block
 * Lanczos basis: the Ritz vectors as they are, their residuals bounded by
 * one product on a random sketch, or Rayleigh-Ritz with B where that bound
 * fails.
 */
#include "eigen/lanczos.h"

#include <cblas.h>
#include <math.h>
#include <string.h>

#define BLOCK PHKS__LANCZOS_BLOCK

/* The residuals' sketch (ritz_pairs): SKETCH columns, one product, and a
 * bound that fails with probability (8 / SKETCH_FACTOR)^(SKETCH / 2). */
#define SKETCH BLOCK
#define SKETCH_FACTOR 80.0

/* The k Ritz vectors of the top of T taken as they are, X = V S (into
 * vectors), with the eigenvalues p^-1(theta) of B, ascending; out->worst is a
 * bound on their largest residual |B x - lambda x| (below).
 *
 * Why no Rayleigh quotients. p is monotone on the wanted interval, so a
 * converged Ritz vector of p(B) is an eigenvector of B, and its Ritz value
 * theta, accurate to rounding errors in |p(B)|, gives the eigenvalue: the
 * error in lambda is that over |p'|, a few units in the last place of |B|
 * (the Rayleigh quotient's own). Where two eigenvalues of B are close,
 * their Ritz vectors may mix them, but by no more than the residual in p(B)
 * over the gap between their p values, which bounds their residual in B by
 * that residual over |p'|. And if fewer than k eigenvalues lay below the
 * cut, the k-th largest eigenvalue of p(B), hence theta_k, would be at most
 * 1 (interlacing): theta_k > 1 shows that the k values are the lowest.
 *
 * Why a sketch. The residuals R = B X - X Lambda are still checked, as a
 * safety net under that argument, but not column by column (k / BLOCK
 * products, a sizeable share of a solve's: docs/benchmarks.md): the
 * product of B with SKETCH random combinations X g_j, g_j uniform in
 * [-1/2, 1/2]^k, gives R g_j. If a column r_e of R has |r_e| = rho, then
 * with u = R^T r_e / |R^T r_e|, |R g| >= rho |u^T g|, and u^T g has a
 * density of at most sqrt(2) (Ball: the largest central section of the
 * unit cube), so P(sum_j |R g_j|^2 <= rho^2 x) <= P(every |u^T g_j| <=
 * sqrt x) <= (8 x)^(SKETCH / 2). worst = sqrt(SKETCH_FACTOR sum_j
 * |R g_j|^2) is therefore below the largest residual with probability at
 * most (8 / SKETCH_FACTOR)^(SKETCH / 2) = 1e-8. Where the bound exceeds the
 * tolerance, or theta_k <= 1, the Rayleigh-Ritz step with B on all q
 * vectors (rayleigh_ritz) settles it. */
phks_status phks__lanczos_ritz_pairs(phks__lanczos *L,
                                     const phks__lanczos_engine *eng,
                                     const phks__lanczos_filter *f, size_t m,
                                     size_t q, size_t k,
                                     phks__lanczos_out *out)
{
    double *values = out->values, *vectors = out->vectors;
    size_t n = L->n;
    phks_status st = PHKS_OK;
    double *s = phks__malloc_array(m, k * sizeof(double));
    double *g = phks__malloc_array(k, 2 * SKETCH * sizeof(double));
    double *y = phks__malloc_array(n, 2 * SKETCH * sizeof(double));
    double *by = phks__malloc_array(n, SKETCH * sizeof(double));
    if (!s || !g || !y || !by) {
        st = phks__fail_oom("Lanczos Ritz pairs");
        goto done;
    }
    /* the top k, theta ascending, in columns 0 .. k - 1 of ritz (theta[q -
     * k + 1 .. q]): the largest, the smallest eigenvalue of B, goes first */
    for (size_t e = 0; e < k; e++) {
        memcpy(s + e * m, L->ritz + (k - 1 - e) * m, m * sizeof(double));
        double theta = L->theta[q - e];
        values[e] = f->degree > 1 && !(theta > 1) ? f->c - f->e
                                                  : phks__lanczos_filter_inverse(f, theta);
        /* monotone in exact arithmetic; rounding must not break the order */
        if (e > 0 && values[e] < values[e - 1])
            values[e] = values[e - 1];
    }
    st = phks__ritz_product(L->v, n, m, s, k, vectors, eng->pm->threads, eng->avx2);
    if (st != PHKS_OK)
        goto done;
    /* G (k x SKETCH) and Lambda G beside it; Y = X [G, Lambda G] */
    phks__random_fill(g, k * SKETCH, 0x5EEDull);
    for (size_t j = 0; j < SKETCH; j++)
        for (size_t e = 0; e < k; e++)
            g[(SKETCH + j) * k + e] = values[e] * g[j * k + e];
    st = phks__ritz_product(vectors, n, k, g, 2 * SKETCH, y, eng->pm->threads,
                           eng->avx2);
    if (st != PHKS_OK)
        goto done;
    phks__lanczos_filter plain = {1, 0, 1};
    st = phks__lanczos_apply(eng, &plain, y, by, L->rows, n);
    if (st != PHKS_OK)
        goto done;
    /* by = -B X G: R G = -by - X Lambda G */
    double sum = 0;
    for (size_t i = 0; i < n * SKETCH; i++) {
        double d = by[i] + y[n * SKETCH + i];
        sum += d * d;
    }
    out->worst = sqrt(SKETCH_FACTOR * sum);
done:
    phks__free(s);
    phks__free(g);
    phks__free(y);
    phks__free(by);
    return st;
}

/* Rayleigh-Ritz with B on the q Ritz vectors Y = V S of the top of T.
 * out receives the k lowest pairs, the largest residual norm among them
 * (worst) and the (k+1)-th value, an upper bound on lambda_{k+1} (next;
 * q > k). */
phks_status phks__lanczos_rayleigh_ritz(phks__lanczos *L,
                                        const phks__lanczos_engine *eng,
                                        size_t m, size_t q, size_t k,
                                        phks__lanczos_out *out)
{
    double *values = out->values, *vectors = out->vectors;
    size_t n = L->n, b = L->b;
    size_t qb = (q + b - 1) / b * b; /* padded to whole blocks */
    phks_status st = PHKS_OK;
    double *y = phks__malloc_array(n, qb * sizeof(double));
    double *by = phks__malloc_array(n, qb * sizeof(double));
    double *g = phks__malloc_array(qb, qb * sizeof(double));
    double *gv = phks__malloc_array(qb, sizeof(double));
    if (!y || !by || !g || !gv) {
        st = phks__fail_oom("Lanczos Rayleigh-Ritz");
        goto done;
    }
    /* Ritz vectors of the top q (theta ascending: the last q columns) */
    st = phks__ritz_product(L->v, n, m, L->ritz, q, y, eng->pm->threads, eng->avx2);
    if (st != PHKS_OK)
        goto done;
    if (qb > q)
        memset(y + q * n, 0, (qb - q) * n * sizeof(double));
    phks__lanczos_filter plain = {1, 0, 1};
    for (size_t j = 0; j < qb; j += b) {
        st = phks__lanczos_apply(eng, &plain, y + j * n, by + j * n, L->rows, n);
        if (st != PHKS_OK)
            goto done;
        for (size_t i = 0; i < n * b; i++)
            by[j * n + i] = -by[j * n + i];
    }
    cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, (int)q, (int)q, (int)n,
                1.0, y, (int)n, by, (int)n, 0.0, g, (int)q);
    st = phks__progress(eng->opt, PHKS_STAGE_EIGEN, eng->fraction);
    if (st != PHKS_OK)
        goto done;
    for (size_t j = 0; j < q; j++) /* symmetrise */
        for (size_t i = 0; i < j; i++)
            g[j * q + i] = g[i * q + j] = 0.5 * (g[j * q + i] + g[i * q + j]);
    /* divide and conquer: several times faster than dsyev's QR iteration
     * at q of a few hundred */
    lapack_int info = LAPACKE_dsyevd(LAPACK_COL_MAJOR, 'V', 'U', (lapack_int)q, g,
                                     (lapack_int)q, gv);
    if (info != 0) {
        st = phks__fail(PHKS_ERROR_SOLVER, "Lanczos: dsyevd info %d", (int)info);
        goto done;
    }
    st = phks__ritz_product(y, n, q, g, k, vectors, eng->pm->threads, eng->avx2);
    if (st == PHKS_OK)
        st = phks__progress(eng->opt, PHKS_STAGE_EIGEN, eng->fraction);
    if (st != PHKS_OK)
        goto done;
    /* residuals: B X - X Theta = (B Y) G_k - X Theta, into y */
    st = phks__ritz_product(by, n, q, g, k, y, eng->pm->threads, eng->avx2);
    if (st != PHKS_OK)
        goto done;
    double w = 0;
    for (size_t e = 0; e < k; e++) {
        double s = 0;
        const double *x = vectors + e * n, *bx = y + e * n;
        for (size_t i = 0; i < n; i++) {
            double d = bx[i] - gv[e] * x[i];
            s += d * d;
        }
        w = fmax(w, sqrt(s));
        values[e] = gv[e];
    }
    out->worst = w;
    out->next = gv[k];
done:
    phks__free(y);
    phks__free(by);
    phks__free(g);
    phks__free(gv);
    return st;
}
