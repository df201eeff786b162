/*
 * lanczos_tridiag.c - the small dense problem of the block Lanczos solver:
 * T = V^T p(B) V reduced to tridiagonal form, its eigenpairs (MRRR, with
 * divide and conquer where MRRR fails on tight clusters), T's Ritz
 * vectors and residuals, and the convergence check built on them.
 */
#include "eigen/lanczos.h"
#include "eigen/householder.h"

#include <cblas.h>
#include <math.h>
#include <string.h>

#define BLOCK PHKS__LANCZOS_BLOCK

/* T[0:m, 0:m] to tridiagonal form (diag, off; the reflectors stay in
 * tfull and reflect), and edge = Q^T times the last b unit vectors, which
 * is all the residuals need of the reflectors. The reduction (O(m^3), the
 * costly part: docs/benchmarks.md) serves every pairs_t call until T or
 * tfull changes. It is the library's own (householder.c): LAPACK's dsytrd
 * and dormtr gave bits that depend on the BLAS's thread count. */
phks_status phks__lanczos_reduce_t(phks__lanczos *L, size_t m)
{
    size_t b = L->b;
    for (size_t j = 0; j < m; j++)
        for (size_t i = 0; i <= j; i++)
            L->tfull[j * m + i] = L->tfull[i * m + j] = L->t[j * L->room + i];
    phks__tridiagonal_reduce(L->tfull, m, L->diag, L->off, L->reflect, L->diag_work);
    memset(L->edge, 0, m * b * sizeof(double));
    for (size_t j = 0; j < b; j++)
        L->edge[j * m + m - b + j] = 1;
    phks__tridiagonal_apply(L->tfull, m, L->reflect, true, L->edge, b);
    return PHKS_OK;
}

/* Every eigenvalue of the tridiagonal form (ascending, into theta), with
 * its eigenvectors into ritz when `vectors`: what pairs_t does when MRRR
 * gives up. MRRR fails (dstemr info 2x) where T has clusters of equal
 * eigenvalues tighter than its representation tree can split, which is what
 * an exactly symmetric mesh gives (2l + 1 equal values per degree on a
 * geodesic sphere). Divide and conquer (dstedc) deflates such clusters
 * instead of separating them, and its vectors are orthogonal to working
 * precision whatever the clustering; implicit QL/QR (dsteqr) backs it up.
 * Both cost a few times MRRR, and run only after it failed, so ordinary
 * meshes keep MRRR's results bit for bit. */
static phks_status pairs_t_fallback(phks__lanczos *L, size_t m, bool vectors,
                                    lapack_int mrrr_info)
{
    lapack_int info = 0;
    for (int method = 0; method < 2; method++) {
        memcpy(L->diag_work, L->diag, m * sizeof(double));
        memcpy(L->off_work, L->off, m * sizeof(double));
        if (!vectors)
            info = LAPACKE_dsterf((lapack_int)m, L->diag_work, L->off_work);
        else if (method == 0)
            info = LAPACKE_dstedc(LAPACK_COL_MAJOR, 'I', (lapack_int)m,
                                  L->diag_work, L->off_work, L->ritz,
                                  (lapack_int)m);
        else
            info = LAPACKE_dsteqr(LAPACK_COL_MAJOR, 'I', (lapack_int)m,
                                  L->diag_work, L->off_work, L->ritz,
                                  (lapack_int)m);
        if (info == 0) {
            memcpy(L->theta, L->diag_work, m * sizeof(double));
            return PHKS_OK;
        }
        if (!vectors)
            break;
    }
    return phks__fail(PHKS_ERROR_SOLVER,
                     "Lanczos: dstemr info %d, and %s info %d after it",
                     (int)mrrr_info, vectors ? "dsteqr" : "dsterf", (int)info);
}

/* Eigenpairs il..iu (1-based, ascending) of T from reduce_t's tridiagonal
 * form: the values into theta, the last b rows of the eigenvectors into
 * bottom (b x count, for the residuals), and the eigenvectors of the
 * tridiagonal form into ritz (leading dimension m; ritz_vectors turns them
 * into T's); with vectors false, the values only. MRRR (dstemr) on a copy
 * of the tridiagonal form (it overwrites its input). Asked for a subset,
 * dstemr finds the eigenvalues by bisection, which pays for a few pairs
 * but not for more than a quarter of them, where it takes longer than
 * computing all (docs/benchmarks.md): then every pair is computed (dqds)
 * and the subset kept. */
phks_status phks__lanczos_pairs_t(phks__lanczos *L, size_t m, size_t il, size_t iu,
                           bool vectors)
{
    size_t b = L->b, count = iu - il + 1;
    bool all = vectors && 4 * count > m;
    memcpy(L->diag_work, L->diag, m * sizeof(double));
    memcpy(L->off_work, L->off, m * sizeof(double));
    lapack_int found = 0;
    lapack_logical tryrac = 1;
    lapack_int info = LAPACKE_dstemr(
        LAPACK_COL_MAJOR, vectors ? 'V' : 'N', all ? 'A' : 'I', (lapack_int)m,
        L->diag_work, L->off_work, 0, 0, (lapack_int)il, (lapack_int)iu, &found,
        L->theta, L->ritz, (lapack_int)m, (lapack_int)(all ? m : count),
        L->support, &tryrac);
    if (info != 0 || (size_t)found != (all ? m : count)) {
        phks_status st = pairs_t_fallback(L, m, vectors, info);
        if (st != PHKS_OK)
            return st;
        all = true;
    }
    if (all) {
        memmove(L->theta, L->theta + (il - 1), count * sizeof(double));
        memmove(L->ritz, L->ritz + (il - 1) * m, count * m * sizeof(double));
    }
    if (vectors)
        cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, (int)b, (int)count,
                    (int)m, 1.0, L->edge, (int)m, L->ritz, (int)m, 0.0,
                    L->bottom, (int)b);
    return PHKS_OK;
}

/* Both: eigenpairs il..iu of T[0:m, 0:m]. */
phks_status phks__lanczos_eig_t(phks__lanczos *L, size_t m, size_t il, size_t iu)
{
    phks_status st = phks__lanczos_reduce_t(L, m);
    return st == PHKS_OK ? phks__lanczos_pairs_t(L, m, il, iu, true) : st;
}

/* Columns [first, first + count) of ritz, from eig_t's last call, become
 * eigenvectors of T, in columns [0, count). MRRR's vectors are orthogonal to a few hundred
 * rounding errors only, where the eigenvectors (and the Rayleigh-Ritz
 * step, when it is needed) want them orthonormal to working precision:
 * Cholesky QR (a count x count Gram matrix) restores that; its loss of
 * orthogonality is of the order of eps times the square of the condition
 * number, here 1 + 1e-13, so one pass does (the Ritz vectors of the test
 * suite stay M-orthonormal to 3e-15, as with two). */
phks_status phks__lanczos_ritz_vectors(phks__lanczos *L, size_t m, size_t first, size_t count)
{
    double *s = L->ritz;
    memmove(s, s + first * m, count * m * sizeof(double));
    phks__tridiagonal_apply(L->tfull, m, L->reflect, false, s, count);
    /* the Gram matrix goes where T's reduction was: it is not needed now */
    double *gram = L->tfull;
    cblas_dsyrk(CblasColMajor, CblasUpper, CblasTrans, (int)count, (int)m, 1.0, s,
                (int)m, 0.0, gram, (int)count);
    lapack_int info = LAPACKE_dpotrf(LAPACK_COL_MAJOR, 'U', (lapack_int)count, gram,
                          (lapack_int)count);
    if (info != 0)
        return phks__fail(PHKS_ERROR_SOLVER, "Lanczos: dpotrf info %d", (int)info);
    cblas_dtrsm(CblasColMajor, CblasRight, CblasUpper, CblasNoTrans, CblasNonUnit,
                (int)m, (int)count, 1.0, gram, (int)count, s, (int)m);
    return PHKS_OK;
}

/* |R s_last| for Ritz vector e (its last b rows in column e of bottom):
 * its residual. */
double phks__lanczos_ritz_residual(const phks__lanczos *L, const double *r, size_t e)
{
    size_t b = L->b;
    const double *s = L->bottom + e * b;
    double sum = 0;
    for (size_t i = 0; i < b; i++) {
        double x = 0;
        for (size_t j = i; j < b; j++)
            x += r[j * b + i] * s[j];
        sum += x * x;
    }
    return sqrt(sum);
}

/* The log of the largest ratio of a Ritz residual to its threshold, scale
 * times the Ritz value's gap to floor_mu, over columns [first, first +
 * count) of theta and bottom. */
static double worst_excess(const phks__lanczos *L, const double *r, double floor_mu,
                           size_t first, size_t count, double scale)
{
    double excess = -INFINITY;
    for (size_t e = first; e < first + count; e++) {
        double gap = L->theta[e] - floor_mu;
        double res = phks__lanczos_ritz_residual(L, r, e);
        double x = gap > 0 ? log(res / (scale * gap)) : INFINITY;
        excess = isnan(x) ? INFINITY : fmax(excess, x);
    }
    return excess;
}

/* Wanted pairs a convergence check looks at before all the others: the
 * lowest ones. The largest ratio of residual to threshold is at the
 * lowest wanted pairs (they lie nearest the guard, where p separates
 * least; so it was at every check measured: docs/benchmarks.md), so a
 * failing check, most of them, costs the reduction and these pairs
 * instead of every pair. */
#define FIRST_PAIRS 24

/* Convergence check at basis size m: *excess is the log of the largest
 * ratio of a residual of the top k Ritz pairs of T to its threshold (scale
 * times its gap to the (q+1)-th largest Ritz value, q = k + guard); the
 * pairs pass when it is <= 0, and then theta, ritz and bottom hold the
 * pairs m - q .. m (theta[0] the (q+1)-th largest), the top k in columns
 * q - k + 1 .. q. */
phks_status phks__lanczos_check(phks__lanczos *L, const double *r, size_t m, size_t q,
                         size_t k, double scale, double *excess)
{
    size_t few = FIRST_PAIRS < k ? FIRST_PAIRS : k, lowest = m - k + 1;
    phks_status st = phks__lanczos_reduce_t(L, m);
    if (st == PHKS_OK)
        st = phks__lanczos_pairs_t(L, m, m - q, m - q, false);
    if (st != PHKS_OK)
        return st;
    double floor_mu = L->theta[0];
    st = phks__lanczos_pairs_t(L, m, lowest, lowest + few - 1, true);
    if (st != PHKS_OK)
        return st;
    *excess = worst_excess(L, r, floor_mu, 0, few, scale);
    if (*excess > 0)
        return PHKS_OK;
    st = phks__lanczos_pairs_t(L, m, m - q, m, true);
    if (st == PHKS_OK)
        *excess = worst_excess(L, r, L->theta[0], 1 + q - k, k, scale);
    return st;
}
