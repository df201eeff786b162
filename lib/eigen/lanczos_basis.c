/*
 * lanczos_basis.c - the block Lanczos basis: its workspace, the
 * re-orthogonalisation of a new block against the basis (classical
 * Gram-Schmidt, twice where needed), its QR (Cholesky QR twice, Householder
 * when that is ill-conditioned) and the block step that ties them.
 */
#include "eigen/lanczos.h"
#include "eigen/householder.h"

#include <cblas.h>
#include <math.h>
#include <string.h>

#define BLOCK PHKS__LANCZOS_BLOCK
/* A new direction this much smaller than its norm before projection is
 * numerically in the span of the basis already. */
#define BREAKDOWN 1e-12
/* Below this (relative to the norm before projection), the new block's
 * orthogonality to the basis is restored by further passes. */
#define REPAIR 1e-6

void phks__lanczos_release(phks__lanczos *L)
{
    phks__free(L->v);
    phks__free(L->t);
    phks__free(L->w);
    phks__free(L->keep);
    for (int i = 0; i < 3; i++)
        phks__free(L->rows[i]);
    phks__free(L->c);
    phks__free(L->tau);
    phks__free(L->ritz);
    phks__free(L->theta);
    phks__free(L->support);
    phks__free(L->tfull);
    phks__free(L->diag);
    phks__free(L->off);
    phks__free(L->diag_work);
    phks__free(L->off_work);
    phks__free(L->reflect);
    phks__free(L->edge);
    phks__free(L->gram_parts);
    phks__free(L->saved);
    phks__free(L->bottom);
    memset(L, 0, sizeof *L);
}

#define GROW(field, count)                                                   \
    do {                                                                     \
        void *p_ = phks__realloc_array(L->field, (count), sizeof *L->field);  \
        if (!p_)                                                             \
            return phks__fail_oom("Lanczos workspace");                       \
        L->field = p_;                                                       \
    } while (0)

/* Makes room for `columns` basis vectors, growing geometrically up to cap.
 * T is kept as a full room x room matrix (column-major, leading dimension
 * room), so growing it moves its columns. */
phks_status phks__lanczos_reserve(phks__lanczos *L, size_t columns)
{
    if (columns <= L->room)
        return PHKS_OK;
    size_t room = L->room + L->room / 2 > columns ? L->room + L->room / 2 : columns;
    room = room < L->cap ? room : L->cap;
    room -= room % L->b;
    size_t old = L->room;
    GROW(v, L->n * room);
    GROW(t, room * room);
    for (size_t j = old; j-- > 0;) {
        memmove(L->t + j * room, L->t + j * old, old * sizeof *L->t);
        memset(L->t + j * room + old, 0, (room - old) * sizeof *L->t);
    }
    memset(L->t + old * room, 0, (room - old) * room * sizeof *L->t);
    GROW(c, room * L->b);
    GROW(ritz, room * room);
    GROW(theta, room);
    GROW(support, 2 * room);
    GROW(tfull, room * room);
    GROW(diag, room);
    GROW(off, room);
    GROW(diag_work, room);
    GROW(off_work, room);
    GROW(reflect, room);
    GROW(edge, room * L->b);
    GROW(bottom, room * L->b);
    L->room = room;
    return PHKS_OK;
}

phks_status phks__lanczos_allocate(phks__lanczos *L, size_t first)
{
    size_t n = L->n, b = L->b;
    L->w = phks__malloc_array(n, b * sizeof(double));
    L->keep = phks__malloc_array(n, b * sizeof(double));
    for (int i = 0; i < 3; i++)
        L->rows[i] = phks__malloc_array(n, b * sizeof(double));
    L->tau = phks__malloc_array(b, sizeof(double));
    L->gram_parts = phks__malloc_array(phks__block_gram_parts(n), b * b * sizeof(double));
    L->saved = phks__malloc_array(n, b * sizeof(double));
    if (!L->w || !L->keep || !L->rows[0] || !L->rows[1] || !L->rows[2] || !L->tau ||
        !L->gram_parts || !L->saved)
        return phks__fail_oom("Lanczos workspace");
    return phks__lanczos_reserve(L, first < L->cap ? first : L->cap);
}

/* Euclidean norm; the vectors here are far from overflow, and a dot
 * product is several times faster than dnrm2's scaled sum. */
static double norm2(size_t n, const double *x)
{
    return sqrt(phks__dot(x, x, n));
}

/* A fixed pseudo-random block, so that every run starts alike. */
void phks__lanczos_random_block(double *w, size_t n, size_t b, uint64_t seed)
{
    phks__random_fill(w, n * b, seed * 0x9E3779B97F4A7C15ull + 1);
}

/* One classical Gram-Schmidt pass of W against V[:, lo:m]; when col >= 0
 * the coefficients are added to T (rows lo..m-1 of columns col..col+b-1). */
static void project(phks__lanczos *L, size_t lo, size_t m, double *w, long col)
{
    size_t n = L->n, b = L->b, cnt = m - lo;
    const double *v = L->v + lo * n;
    cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, (int)cnt, (int)b,
                (int)n, 1.0, v, (int)n, w, (int)n, 0.0, L->c, (int)cnt);
    cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, (int)n, (int)b,
                (int)cnt, -1.0, v, (int)n, L->c, (int)cnt, 1.0, w, (int)n);
    if (col >= 0)
        for (size_t j = 0; j < b; j++) {
            double *t = L->t + ((size_t)col + j) * L->room + lo;
            for (size_t i = 0; i < cnt; i++)
                t[i] += L->c[j * cnt + i];
        }
}

/* One classical Gram-Schmidt pass of the row-major block wr against
 * V[:, lo:m] (lanczos_gram.c); when col >= 0 the coefficients are added
 * to T (rows lo..m-1 of columns col..col+b-1). */
static void project_rows(phks__lanczos *L, const phks__lanczos_engine *e, size_t lo, size_t m,
                         double *wr, long col)
{
    size_t n = L->n, b = L->b, cnt = m - lo;
    phks__block_project(L->v + lo * n, n, cnt, wr, L->c, e->pm->threads, e->avx2);
    if (col >= 0)
        for (size_t j = 0; j < b; j++) {
            double *t = L->t + ((size_t)col + j) * L->room + lo;
            for (size_t i = 0; i < cnt; i++)
                t[i] += L->c[i * b + j];
        }
}

/* Euclidean norms of the BLOCK columns of the row-major block wr. */
static void row_block_norms(const double *wr, size_t n, double norm[BLOCK])
{
    double sum[BLOCK] = {0};
    for (size_t i = 0; i < n; i++)
        for (size_t j = 0; j < BLOCK; j++)
            sum[j] += wr[i * BLOCK + j] * wr[i * BLOCK + j];
    for (size_t j = 0; j < BLOCK; j++)
        norm[j] = sqrt(sum[j]);
}

/* Makes the row-major block wr orthogonal to V[:, 0:m]. The large
 * coefficients of a Lanczos step are those on the last two blocks (the
 * three-term recurrence): they are removed first, with two passes ("twice
 * is enough"). What is left against the whole basis is the slow loss of
 * orthogonality, of the order of the rounding errors, so one pass over the
 * whole basis removes it without cancellation; a second one follows when
 * the pass did shrink a column by more than 1/sqrt(2) (Daniel-Gragg-
 * Kaufman-Stewart). When col >= 0, wr is p(B) times the basis block at
 * columns [col, col + b), and the coefficients go to T. With L->local (the
 * probe), only the last two blocks. */
static void orthogonalise(phks__lanczos *L, const phks__lanczos_engine *e, size_t m, double *wr,
                          long col)
{
    size_t b = L->b;
    if (m == 0)
        return;
    size_t lo = m > 2 * b ? m - 2 * b : 0;
    project_rows(L, e, lo, m, wr, col);
    project_rows(L, e, lo, m, wr, col);
    if (lo == 0 || L->local)
        return;
    double before[BLOCK], after[BLOCK];
    row_block_norms(wr, L->n, before);
    project_rows(L, e, 0, m, wr, col);
    row_block_norms(wr, L->n, after);
    double smallest = INFINITY;
    for (size_t j = 0; j < b; j++)
        smallest = fmin(smallest, before[j] > 0 ? after[j] / before[j] : 1);
    if (smallest < 0.7071)
        project_rows(L, e, 0, m, wr, col);
}

/* Householder QR of the n x b block w: w becomes Q, r (b x b, column-major)
 * receives R. Returns the smallest |R_ii| relative to the largest column
 * norm of w before. The library's own QR (householder.c), not LAPACK's,
 * whose bits depend on the BLAS's thread count. */
phks_status phks__lanczos_qr(phks__lanczos *L, double *w, double *r, double *smallest)
{
    size_t n = L->n, b = L->b;
    double big = 0, rb[BLOCK * BLOCK];
    for (size_t j = 0; j < b; j++)
        big = fmax(big, norm2(n, w + j * n));
    phks__householder_qr(w, n, b, rb, L->tau);
    double s = INFINITY;
    for (size_t j = 0; j < b; j++)
        s = fmin(s, fabs(rb[j * b + j]));
    if (r)
        memcpy(r, rb, b * b * sizeof *r);
    *smallest = big > 0 ? s / big : 0;
    return PHKS_OK;
}

/* Upper Cholesky factor f (column-major, zeros below) of the b x b Gram
 * matrix g; false when g is not numerically positive definite or the
 * factor's diagonal spans more than CHOLQR_COND. */
#define CHOLQR_COND 1e5
static bool cholesky(const double *g, double *f, size_t b)
{
    memset(f, 0, b * b * sizeof(double));
    double lo = INFINITY, hi = 0;
    for (size_t j = 0; j < b; j++) {
        for (size_t i = 0; i < j; i++) {
            double x = g[j * b + i];
            for (size_t l = 0; l < i; l++)
                x -= f[i * b + l] * f[j * b + l];
            f[j * b + i] = x / f[i * b + i];
        }
        double d = g[j * b + j];
        for (size_t l = 0; l < j; l++)
            d -= f[j * b + l] * f[j * b + l];
        if (!(d > 0))
            return false;
        f[j * b + j] = sqrt(d);
        lo = fmin(lo, f[j * b + j]);
        hi = fmax(hi, f[j * b + j]);
    }
    return lo > hi / CHOLQR_COND;
}

/* u (row-major) = f^-1 for f upper triangular (column-major). */
static void upper_inverse(const double *f, double *u, size_t b)
{
    memset(u, 0, b * b * sizeof(double));
    for (size_t j = 0; j < b; j++) {
        u[j * b + j] = 1 / f[j * b + j];
        for (size_t i = j; i-- > 0;) {
            double x = 0;
            for (size_t l = i + 1; l <= j; l++)
                x += f[l * b + i] * u[l * b + j];
            u[i * b + j] = -x / f[i * b + i];
        }
    }
}

/* QR of the row-major block wr by Cholesky QR twice: the Gram matrix, its
 * Cholesky factor R1, wr := wr R1^-1, and again (R2); r = R2 R1. The
 * products run on the library's threads and leave the same bits for any
 * thread count. Twice is orthogonal to working precision while wr's
 * condition number stays well below 1 / sqrt(eps) (Yamamoto et al. 2015):
 * false, with wr spoilt, when a factor shows a condition above
 * CHOLQR_COND; Householder's QR (next_block) then does the job. Against
 * Householder: the same residuals and eigenvalues in less time
 * (docs/benchmarks.md), and no call into the BLAS between products (whose
 * idle threads would compete with the products' own). */
static bool cholesky_qr(phks__lanczos *L, const phks__lanczos_engine *e, double *wr, double *r)
{
    size_t b = L->b;
    double g[BLOCK * BLOCK], r1[BLOCK * BLOCK], r2[BLOCK * BLOCK];
    for (int pass = 0; pass < 2; pass++) {
        double *f = pass == 0 ? r1 : r2;
        phks__block_gram(wr, L->n, L->gram_parts, g, e->pm->threads, e->avx2);
        if (!cholesky(g, f, b))
            return false;
        upper_inverse(f, g, b);
        phks__block_times_upper(wr, L->n, g, e->pm->threads, e->avx2);
    }
    for (size_t j = 0; j < b; j++)
        for (size_t i = 0; i < b; i++) {
            double x = 0;
            for (size_t l = i; l <= j; l++)
                x += r2[l * b + i] * r1[j * b + l];
            r[j * b + i] = x;
        }
    return true;
}

/* Next basis block from the residual w (already orthogonal to V[:, 0:m]):
 * w = Q R. When w is (nearly) rank-deficient, Householder's Q may leave the
 * span it should avoid, so weak columns are replaced by random ones, Q is
 * re-orthogonalised against the basis, and R is recomputed as the exact
 * projection Q^T w. `scale` is the norm of w before the projections. */
static phks_status next_block(phks__lanczos *L, const phks__lanczos_null *null,
                              size_t m, double *r, double scale)
{
    size_t n = L->n, b = L->b;
    double smallest;
    memcpy(L->keep, L->w, n * b * sizeof(double));
    phks_status st = phks__lanczos_qr(L, L->w, r, &smallest);
    double weakest = INFINITY;
    for (size_t j = 0; j < b; j++)
        weakest = fmin(weakest, fabs(r[j * b + j]));
    if (st != PHKS_OK || weakest > REPAIR * scale)
        return st;
    double big = scale;
    double *q = L->w;
    phks__lanczos_random_block(L->rows[0], n, b, m + 17);
    for (size_t j = 0; j < b; j++)
        if (fabs(r[j * b + j]) <= BREAKDOWN * big || big == 0)
            memcpy(q + j * n, L->rows[0] + j * n, n * sizeof(double));
    for (int pass = 0; pass < 2; pass++) {
        if (null)
            phks__lanczos_null_cols(null, q, n, b);
        project(L, 0, m, q, -1);
        project(L, 0, m, q, -1);
        st = phks__lanczos_qr(L, q, NULL, &smallest);
        if (st != PHKS_OK)
            return st;
    }
    cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, (int)b, (int)b, (int)n,
                1.0, q, (int)n, L->keep, (int)n, 0.0, r, (int)b);
    return PHKS_OK;
}

/* One block step: W = p(B) V_last, project, next block. m = columns so far.
 * Returns with r = coupling of the new block (in L->w). */
phks_status phks__lanczos_step(phks__lanczos *L, const phks__lanczos_run *rc, size_t m, double *r)
{
    size_t n = L->n, b = L->b;
    double *wr, norm[BLOCK], scale = 0;
    phks_status fst = phks__lanczos_apply_rows(rc->eng, rc->f, L->v + (m - b) * n,
                                        L->rows, n, &wr);
    if (fst != PHKS_OK)
        return fst;
    const phks__lanczos_null *null = rc->eng->null;
    /* p(B) magnifies the null-space part of the rounding errors (p is
     * largest at 0): it goes before it counts in the norms, and again
     * after the Gram-Schmidt, whose own rounding the QR would magnify
     * where the residual is small. */
    if (null)
        phks__lanczos_null_rows(null, wr, n);
    row_block_norms(wr, n, norm);
    for (size_t j = 0; j < b; j++)
        scale = fmax(scale, norm[j]);
    orthogonalise(L, rc->eng, m, wr, (long)(m - b));
    if (null)
        phks__lanczos_null_rows(null, wr, n);
    /* W as it is, for Householder's QR and the repairs */
    memcpy(L->saved, wr, n * b * sizeof(double));
    if (cholesky_qr(L, rc->eng, wr, r)) {
        double weakest = INFINITY;
        for (size_t j = 0; j < b; j++)
            weakest = fmin(weakest, fabs(r[j * b + j]));
        if (weakest > REPAIR * scale) {
            phks__lanczos_to_cols(rc->eng, wr, L->w, n);
            return PHKS_OK;
        }
    }
    phks__lanczos_to_cols(rc->eng, L->saved, L->w, n);
    return next_block(L, null, m, r, scale);
}
