/*
 * lanczos.c - the fast solver: block Lanczos on a Chebyshev
 * polynomial of B, with full re-orthogonalisation; the converged Ritz
 * vectors, checked against B itself.
 *
 * Why this shape. B is bounded (spectrum in [0, lmax], lmax ~ 1/tau) and we
 * want its k lowest eigenpairs, which sit in a small fraction of that
 * range. Plain Lanczos on B needs a Krylov basis several times k for that
 * (the polynomial degree it needs grows like sqrt(lmax / lambda_k)), and
 * with full re-orthogonalisation the cost is O(n m^2) in the basis size m:
 * that, not the products, dominates. Running Lanczos on p(B), where p is a
 * Chebyshev polynomial of low degree d that keeps [a, lmax] inside [-1, 1]
 * and grows fast below a (a just above lambda_k), needs a basis only a
 * little larger than k, at the price of d products per basis vector.
 *
 *  1. A short block Lanczos run on B (re-orthogonalised locally only) gives
 *     an upper bound on lmax (top Ritz value plus its residual) and, by
 *     Gauss quadrature on the random start block, an estimate of the
 *     eigenvalue count N(lambda), from which the cut a is chosen so that
 *     about k plus a margin eigenvalues lie below.
 *  2. Block Lanczos on p(B) (block BLOCK, classical Gram-Schmidt against the
 *     last two blocks twice and the whole basis once, Cholesky QR twice for
 *     each new block) until the top k + guard Ritz pairs of T = V^T p(B) V
 *     are converged (tridiagonal reduction of T and MRRR for the pairs).
 *  3. The top k Ritz vectors, with the eigenvalues of B their Ritz values
 *     stand for (p^-1), are the eigenpairs; one product with random
 *     combinations of them bounds their residuals |B x - lambda x|, which
 *     must be below tolerance * |B|; where they are not, Rayleigh-Ritz
 *     with B on the top k + guard Ritz vectors. If that fails too, Lanczos
 *     goes on; if the cut turned out to lie below lambda_k, the solve
 *     restarts with a higher one (at most three times); if the basis would
 *     grow past its cap (3 (k + guard) + 8 BLOCK), the solve falls back to
 *     plain Lanczos on B (degree 1, basis up to 12 k + 8 BLOCK), and when
 *     that does not converge either, to the dense solver if n <= 16384,
 *     to ARPACK above.
 *  Meshes too small for a Krylov basis (n < 8 BLOCK, or fewer than
 *  k + guard + 4 BLOCK usable columns, or no room for the probe) go to the
 *  dense solver directly.
 *
 * The whole solve runs in the numbering of the operator's pair layout
 * (lanczos_pairs.c: the points in Morton order), whose kernel applies B
 * to row-major blocks of BLOCK vectors fused with the Chebyshev recurrence
 * (one pass over the matrix per degree for the whole block); the
 * Gram-Schmidt and QR products take those row-major blocks as they are
 * (lanczos_gram.c). All of these run on the library's threads, each
 * result entry summed by one thread in a fixed order, so results are
 * bit-identical between runs and for any value of the threads option (the
 * BLAS's own thread count being fixed); between products
 * the solver makes no BLAS call (whose idle threads would compete with its
 * own), only in the convergence checks and the final Ritz vectors.
 */
#include "eigen/lanczos.h"
#include "core/simd.h"

#include <cblas.h>
#include <lapacke.h>
#include <math.h>
#include <string.h>

#define BLOCK PHKS__PAIR_BLOCK
/* A new direction this much smaller than its norm before projection is
 * numerically in the span of the basis already. */
#define BREAKDOWN 1e-12
/* Below this (relative to the norm before projection), the new block's
 * orthogonality to the basis is restored by further passes. */
#define REPAIR 1e-6
/* Steps of the first, plain Lanczos run that estimates the spectrum: the
 * fewest steps whose cuts stayed close to those of longer probes, with no
 * restart, and the least total work (products, Gram-Schmidt and checks,
 * weighed by their costs); the comparisons are in docs/benchmarks.md. */
#define PROBE_STEPS 12
/* Degree of the Chebyshev filter: chosen so that p(0) = T_d(x0) is about
 * cosh(FILTER_GROWTH), x0 = (lmax + a) / (lmax - a). With a near
 * 0.5 lmax that is degree 4, the fastest of the degrees tried (k = 300;
 * docs/benchmarks.md); when lambda_k is a smaller fraction of
 * lmax the degree grows, up to MAX_DEGREE. */
#define FILTER_GROWTH 4.9
#define MAX_DEGREE 16
/* The cut is placed where about CUT_MARGIN (k + guard) eigenvalues lie
 * below it, by the probe's estimate. */
#define CUT_MARGIN 1.2
/* The log of (largest Ritz residual / its threshold) falls at a steady
 * rate per basis column once convergence is near, slower than this one
 * on the meshes measured (docs/benchmarks.md); the second
 * check is placed by this faster rate, so that it comes early (one more
 * check) rather than late (more basis). */
#define FIRST_SLOPE 0.25
/* Largest n for which a solve that did not converge is redone densely
 * (dense.c's own limit). */
#define DENSE_FALLBACK_MAX_N 16384


/* ---------------------------------------------------------------- kernel */

typedef struct {
    const phks__operator_pairs *pm;
    bool avx2;
    const phks_options *opt;
    double fraction;        /* progress reported between products */
} engine;

/* out = alpha * (B x) + gamma * x + beta * z on row-major n x BLOCK blocks
 * (z may be NULL), in the pair matrix's numbering. */
static void poly_step(const engine *e, const double *x, const double *z,
                      double *out, double alpha, double gamma, double beta)
{
    phks__operator_pairs_poly(e->pm, e->avx2, x, z, out, alpha, gamma, beta);
}

/* The filter p(B) = T_d((c I - B) / e) (degree 1 with c = 0, e = 1: -B,
 * which spans the same Krylov space as B). */
typedef struct {
    int degree;
    double c, e;
} filter;

/* Column-major n x BLOCK <-> row-major, rows split over the product's
 * threads. */
typedef struct {
    const double *from;
    double *to;
    size_t n;
} transpose_ctx;

/* In stretches of 64 rows (8 KB of the row-major side), so that each
 * cache line is fetched once. */
#define TRANSPOSE_STRETCH 64

static void to_rows_range(void *ctx, size_t begin, size_t end)
{
    const transpose_ctx *t = ctx;
    for (size_t r0 = begin; r0 < end; r0 += TRANSPOSE_STRETCH) {
        size_t r1 = end - r0 > TRANSPOSE_STRETCH ? r0 + TRANSPOSE_STRETCH : end;
        for (size_t j = 0; j < BLOCK; j++)
            for (size_t i = r0; i < r1; i++)
                t->to[i * BLOCK + j] = t->from[j * t->n + i];
    }
}

static void to_cols_range(void *ctx, size_t begin, size_t end)
{
    const transpose_ctx *t = ctx;
    for (size_t r0 = begin; r0 < end; r0 += TRANSPOSE_STRETCH) {
        size_t r1 = end - r0 > TRANSPOSE_STRETCH ? r0 + TRANSPOSE_STRETCH : end;
        for (size_t j = 0; j < BLOCK; j++)
            for (size_t i = r0; i < r1; i++)
                t->to[j * t->n + i] = t->from[i * BLOCK + j];
    }
}

static void to_rows(const engine *e, const double *cols, double *rows, size_t n)
{
    transpose_ctx t = {cols, rows, n};
    phks__parallel_for(n, e->pm->threads, to_rows_range, &t);
}

static void to_cols(const engine *e, const double *rows, double *cols, size_t n)
{
    transpose_ctx t = {rows, cols, n};
    phks__parallel_for(n, e->pm->threads, to_cols_range, &t);
}

/* p(B) in (column-major), left row-major in one of the three scratch blocks
 * r[0..2]: *result. */
static phks_status apply_filter_rows(const engine *e, const filter *f,
                                     const double *in, double *r[3], size_t n,
                                     double **result)
{
    to_rows(e, in, r[0], n);
    /* T_1 = (c x - B x) / e */
    poly_step(e, r[0], NULL, r[1], -1 / f->e, f->c / f->e, 0);
    double *prev = r[0], *cur = r[1], *spare = r[2];
    for (int d = 2; d <= f->degree; d++) {
        /* each product is a pass over the matrix: report between them */
        phks_status st = phks__progress(e->opt, PHKS_STAGE_EIGEN, e->fraction);
        if (st != PHKS_OK)
            return st;
        /* T_{d} = 2 (c - B)/e T_{d-1} - T_{d-2} */
        poly_step(e, cur, prev, spare, -2 / f->e, 2 * f->c / f->e, -1);
            double *t = prev;
        prev = cur;
        cur = spare;
        spare = t;
    }
    *result = cur;
    return phks__progress(e->opt, PHKS_STAGE_EIGEN, e->fraction);
}

/* out (column-major) = p(B) in (column-major). */
static phks_status apply_filter(const engine *e, const filter *f,
                                const double *in, double *out, double *r[3],
                                size_t n)
{
    double *rows;
    phks_status st = apply_filter_rows(e, f, in, r, n, &rows);
    if (st == PHKS_OK)
        to_cols(e, rows, out, n);
    return st;
}

/* ------------------------------------------------------------- workspace */

typedef struct {
    size_t n, k, b;
    bool local;             /* re-orthogonalise against the last two blocks
                               only (the probe)                              */
    size_t cap;             /* most basis columns allowed                    */
    size_t room;            /* basis columns allocated so far                */
    double *v;              /* n x room, column-major basis                  */
    double *t;              /* room x room, V^T p(B) V (upper triangle)      */
    double *w;              /* n x b residual block                          */
    double *keep;           /* n x b copy of w for repairs                   */
    double *rows[3];        /* n x b row-major blocks for the operator       */
    double *c;              /* room x b projection coefficients              */
    double *tau;            /* b Householder scalars                         */
    double *ritz;           /* room x room eigenvectors of T                 */
    double *theta;          /* room eigenvalues of T                         */
    lapack_int *support;    /* 2 room, for dstemr                            */
    double *tfull;          /* room x room: T, then its tridiagonal reduction */
    double *diag, *off, *reflect; /* room each: T's tridiagonal form and
                               the reflectors' scalars                       */
    double *diag_work, *off_work; /* room each: its copy for dstemr          */
    double *edge;           /* room x b: Q^T of the last b unit vectors      */
    double *gram_parts;     /* partial Gram matrices of Cholesky QR          */
    double *saved;          /* n x b row-major: the block before its QR      */
    double *bottom;         /* b x room: last b rows of T's eigenvectors     */
} lanczos;

static void release(lanczos *L)
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
static phks_status reserve(lanczos *L, size_t columns)
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

static phks_status allocate(lanczos *L, size_t first)
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
    return reserve(L, first < L->cap ? first : L->cap);
}

/* Euclidean norm; the vectors here are far from overflow, and a dot
 * product is several times faster than dnrm2's scaled sum. */
static double norm2(size_t n, const double *x)
{
    return sqrt(cblas_ddot((int)n, x, 1, x, 1));
}

/* A fixed pseudo-random block, so that every run starts alike. */
static void random_block(double *w, size_t n, size_t b, uint64_t seed)
{
    phks__random_fill(w, n * b, seed * 0x9E3779B97F4A7C15ull + 1);
}

/* One classical Gram-Schmidt pass of W against V[:, lo:m]; when col >= 0
 * the coefficients are added to T (rows lo..m-1 of columns col..col+b-1). */
static void project(lanczos *L, size_t lo, size_t m, double *w, long col)
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
static void project_rows(lanczos *L, const engine *e, size_t lo, size_t m,
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
static void orthogonalise(lanczos *L, const engine *e, size_t m, double *wr,
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
 * norm of w before. */
static phks_status qr(lanczos *L, double *w, double *r, double *smallest)
{
    size_t n = L->n, b = L->b;
    double big = 0;
    for (size_t j = 0; j < b; j++)
        big = fmax(big, norm2(n, w + j * n));
    lapack_int info = LAPACKE_dgeqrf(LAPACK_COL_MAJOR, (lapack_int)n,
                                     (lapack_int)b, w, (lapack_int)n, L->tau);
    if (info != 0)
        return phks__fail(PHKS_ERROR_SOLVER, "Lanczos: dgeqrf info %d", (int)info);
    double s = INFINITY;
    for (size_t j = 0; j < b; j++)
        for (size_t i = 0; i < b; i++) {
            if (r)
                r[j * b + i] = i <= j ? w[j * n + i] : 0;
            if (i == j)
                s = fmin(s, fabs(w[j * n + i]));
        }
    info = LAPACKE_dorgqr(LAPACK_COL_MAJOR, (lapack_int)n, (lapack_int)b,
                          (lapack_int)b, w, (lapack_int)n, L->tau);
    if (info != 0)
        return phks__fail(PHKS_ERROR_SOLVER, "Lanczos: dorgqr info %d", (int)info);
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
static bool cholesky_qr(lanczos *L, const engine *e, double *wr, double *r)
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
static phks_status next_block(lanczos *L, size_t m, double *r, double scale)
{
    size_t n = L->n, b = L->b;
    double smallest;
    memcpy(L->keep, L->w, n * b * sizeof(double));
    phks_status st = qr(L, L->w, r, &smallest);
    double weakest = INFINITY;
    for (size_t j = 0; j < b; j++)
        weakest = fmin(weakest, fabs(r[j * b + j]));
    if (st != PHKS_OK || weakest > REPAIR * scale)
        return st;
    double big = scale;
    double *q = L->w;
    random_block(L->rows[0], n, b, m + 17);
    for (size_t j = 0; j < b; j++)
        if (fabs(r[j * b + j]) <= BREAKDOWN * big || big == 0)
            memcpy(q + j * n, L->rows[0] + j * n, n * sizeof(double));
    for (int pass = 0; pass < 2; pass++) {
        project(L, 0, m, q, -1);
        project(L, 0, m, q, -1);
        st = qr(L, q, NULL, &smallest);
        if (st != PHKS_OK)
            return st;
    }
    cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, (int)b, (int)b, (int)n,
                1.0, q, (int)n, L->keep, (int)n, 0.0, r, (int)b);
    return PHKS_OK;
}

/* T[0:m, 0:m] to tridiagonal form (diag, off; the reflectors stay in
 * tfull and reflect), and edge = Q^T times the last b unit vectors, which
 * is all the residuals need of the reflectors. The reduction (O(m^3), the
 * costly part: docs/benchmarks.md) serves every pairs_t call until T or
 * tfull changes. */
static phks_status reduce_t(lanczos *L, size_t m)
{
    size_t b = L->b;
    for (size_t j = 0; j < m; j++)
        memcpy(L->tfull + j * m, L->t + j * L->room, (j + 1) * sizeof(double));
    lapack_int info = LAPACKE_dsytrd(LAPACK_COL_MAJOR, 'U', (lapack_int)m,
                                     L->tfull, (lapack_int)m, L->diag, L->off,
                                     L->reflect);
    if (info != 0)
        return phks__fail(PHKS_ERROR_SOLVER, "Lanczos: dsytrd info %d", (int)info);
    memset(L->edge, 0, m * b * sizeof(double));
    for (size_t j = 0; j < b; j++)
        L->edge[j * m + m - b + j] = 1;
    info = LAPACKE_dormtr(LAPACK_COL_MAJOR, 'L', 'U', 'T', (lapack_int)m,
                          (lapack_int)b, L->tfull, (lapack_int)m, L->reflect,
                          L->edge, (lapack_int)m);
    if (info != 0)
        return phks__fail(PHKS_ERROR_SOLVER, "Lanczos: dormtr info %d", (int)info);
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
static phks_status pairs_t_fallback(lanczos *L, size_t m, bool vectors,
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
static phks_status pairs_t(lanczos *L, size_t m, size_t il, size_t iu,
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
static phks_status eig_t(lanczos *L, size_t m, size_t il, size_t iu)
{
    phks_status st = reduce_t(L, m);
    return st == PHKS_OK ? pairs_t(L, m, il, iu, true) : st;
}

/* Columns [first, first + count) of ritz, from eig_t's last call, become
 * eigenvectors of T, in columns [0, count). MRRR's vectors are orthogonal to a few hundred
 * rounding errors only, where the eigenvectors (and the Rayleigh-Ritz
 * step, when it is needed) want them orthonormal to working precision:
 * Cholesky QR (a count x count Gram matrix) restores that; its loss of
 * orthogonality is of the order of eps times the square of the condition
 * number, here 1 + 1e-13, so one pass does (the Ritz vectors of the test
 * suite stay M-orthonormal to 3e-15, as with two). */
static phks_status ritz_vectors(lanczos *L, size_t m, size_t first, size_t count)
{
    double *s = L->ritz;
    memmove(s, s + first * m, count * m * sizeof(double));
    lapack_int info = LAPACKE_dormtr(LAPACK_COL_MAJOR, 'L', 'U', 'N',
                                     (lapack_int)m, (lapack_int)count, L->tfull,
                                     (lapack_int)m, L->reflect, s, (lapack_int)m);
    if (info != 0)
        return phks__fail(PHKS_ERROR_SOLVER, "Lanczos: dormtr info %d", (int)info);
    /* the Gram matrix goes where T's reduction was: it is not needed now */
    double *gram = L->tfull;
    cblas_dsyrk(CblasColMajor, CblasUpper, CblasTrans, (int)count, (int)m, 1.0, s,
                (int)m, 0.0, gram, (int)count);
    info = LAPACKE_dpotrf(LAPACK_COL_MAJOR, 'U', (lapack_int)count, gram,
                          (lapack_int)count);
    if (info != 0)
        return phks__fail(PHKS_ERROR_SOLVER, "Lanczos: dpotrf info %d", (int)info);
    cblas_dtrsm(CblasColMajor, CblasRight, CblasUpper, CblasNoTrans, CblasNonUnit,
                (int)m, (int)count, 1.0, gram, (int)count, s, (int)m);
    return PHKS_OK;
}

/* |R s_last| for Ritz vector e (its last b rows in column e of bottom):
 * its residual. */
static double ritz_residual(const lanczos *L, const double *r, size_t e)
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

/* Runs block Lanczos on p(B) from the random block `seed`, extending the
 * basis until `done` says the top `want` Ritz pairs are good or the cap is
 * hit. */
typedef struct {
    const engine *eng;
    const filter *f;
} run_ctx;

/* One block step: W = p(B) V_last, project, next block. m = columns so far.
 * Returns with r = coupling of the new block (in L->w). */
static phks_status step(lanczos *L, const run_ctx *rc, size_t m, double *r)
{
    size_t n = L->n, b = L->b;
    double *wr, norm[BLOCK], scale = 0;
    phks_status fst = apply_filter_rows(rc->eng, rc->f, L->v + (m - b) * n,
                                        L->rows, n, &wr);
    if (fst != PHKS_OK)
        return fst;
    row_block_norms(wr, n, norm);
    for (size_t j = 0; j < b; j++)
        scale = fmax(scale, norm[j]);
    orthogonalise(L, rc->eng, m, wr, (long)(m - b));
    /* W as it is, for Householder's QR and the repairs */
    memcpy(L->saved, wr, n * b * sizeof(double));
    if (cholesky_qr(L, rc->eng, wr, r)) {
        double weakest = INFINITY;
        for (size_t j = 0; j < b; j++)
            weakest = fmin(weakest, fabs(r[j * b + j]));
        if (weakest > REPAIR * scale) {
            to_cols(rc->eng, wr, L->w, n);
            return PHKS_OK;
        }
    }
    to_cols(rc->eng, L->saved, L->w, n);
    return next_block(L, m, r, scale);
}

/* ----------------------------------------------------------- probe run */

/* A short plain block Lanczos on B: an upper bound on lmax and the cut a
 * with about `target` eigenvalues below it (Gauss quadrature estimate of
 * the counting function from the random start block). Its basis is kept
 * orthogonal to the last two blocks only: Lanczos without full
 * re-orthogonalisation still gives the Gauss quadrature of the start
 * block's spectral measure (Greenbaum; the copies of converged Ritz values
 * share their weight), and the extreme Ritz values stay within the
 * spectrum, at a small fraction of the cost. */
static phks_status probe(engine *eng, const phks_options *opt, size_t k,
                         size_t target, double *lmax, double *cut)
{
    size_t n = eng->pm->n, b = BLOCK;
    size_t steps = PROBE_STEPS;
    if ((steps + 1) * b > n - n % b)
        steps = (n - n % b) / b - 1;
    lanczos L = {.n = n, .k = k, .b = b, .local = true, .cap = steps * b};
    phks_status st = allocate(&L, L.cap);
    double r[BLOCK * BLOCK], smallest;
    filter plain = {1, 0, 1};
    run_ctx rc = {eng, &plain};
    if (st == PHKS_OK) {
        random_block(L.v, n, b, 0);
        st = qr(&L, L.v, r, &smallest);
    }
    size_t m = b;
    while (st == PHKS_OK) {
        st = step(&L, &rc, m, r);
        if (st != PHKS_OK || m + b > L.cap)
            break;
        memcpy(L.v + m * n, L.w, n * b * sizeof(double));
        m += b;
        eng->fraction = 0.02 * (double)m / (double)L.cap;
    }
    if (st == PHKS_OK)
        st = eig_t(&L, m, 1, m);
    if (st == PHKS_OK)
        st = ritz_vectors(&L, m, 0, m);
    if (st == PHKS_OK) {
        /* T holds -B: eigenvalues of B are -theta, in reverse order. */
        double top = -L.theta[0];
        double res = ritz_residual(&L, r, 0);
        *lmax = (top + res) * 1.01;
        /* count estimate: n / b * sum of |first-block components|^2 */
        double count = 0;
        *cut = *lmax;
        for (size_t e = m; e-- > 0;) {
            const double *s = L.ritz + e * m;
            double w = 0;
            for (size_t i = 0; i < b; i++)
                w += s[i] * s[i];
            count += w * (double)n / (double)b;
            if (count >= (double)target) {
                *cut = -L.theta[e];
                break;
            }
        }
    }
    release(&L);
    return st;
}

/* ------------------------------------------------------------- the solve */

/* The eigenvalue of B that p maps to theta, for theta >= 1 (p(lambda) =
 * T_d((c - lambda) / e) and T_d(x) = cosh(d acosh x) for x >= 1), or any
 * theta when d = 1. Well conditioned: where acosh is steep (theta near 1),
 * cosh flattens it again. */
static double filter_inverse(const filter *f, double theta)
{
    if (f->degree == 1)
        return f->c - f->e * theta;
    return f->c - f->e * cosh(acosh(theta) / f->degree);
}

/* The residuals' sketch (ritz_pairs): SKETCH columns, one product, and a
 * bound that fails with probability (8 / SKETCH_FACTOR)^(SKETCH / 2). */
#define SKETCH BLOCK
#define SKETCH_FACTOR 80.0

/* The k Ritz vectors of the top of T taken as they are, X = V S (into
 * vectors), with the eigenvalues p^-1(theta) of B, ascending; *worst is a
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
 * sqrt x) <= (8 x)^(SKETCH / 2). *worst = sqrt(SKETCH_FACTOR sum_j
 * |R g_j|^2) is therefore below the largest residual with probability at
 * most (8 / SKETCH_FACTOR)^(SKETCH / 2) = 1e-8. Where the bound exceeds the
 * tolerance, or theta_k <= 1, the Rayleigh-Ritz step with B on all q
 * vectors (rayleigh_ritz) settles it. */
static phks_status ritz_pairs(lanczos *L, const engine *eng, const filter *f,
                              size_t m, size_t q, size_t k, double *values,
                              double *vectors, double *worst)
{
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
                                                  : filter_inverse(f, theta);
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
    filter plain = {1, 0, 1};
    st = apply_filter(eng, &plain, y, by, L->rows, n);
    if (st != PHKS_OK)
        goto done;
    /* by = -B X G: R G = -by - X Lambda G */
    double sum = 0;
    for (size_t i = 0; i < n * SKETCH; i++) {
        double d = by[i] + y[n * SKETCH + i];
        sum += d * d;
    }
    *worst = sqrt(SKETCH_FACTOR * sum);
done:
    phks__free(s);
    phks__free(g);
    phks__free(y);
    phks__free(by);
    return st;
}

/* Rayleigh-Ritz with B on the q Ritz vectors Y = V S of the top of T.
 * values/vectors receive the k lowest pairs; *worst the largest residual
 * norm among them; *next the (k+1)-th value, an upper bound on
 * lambda_{k+1} (q > k). */
static phks_status rayleigh_ritz(lanczos *L, const engine *eng, size_t m,
                                 size_t q, size_t k, double *values,
                                 double *vectors, double *worst, double *next)
{
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
    filter plain = {1, 0, 1};
    for (size_t j = 0; j < qb; j += b) {
        st = apply_filter(eng, &plain, y + j * n, by + j * n, L->rows, n);
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
    *worst = w;
    *next = gv[k];
done:
    phks__free(y);
    phks__free(by);
    phks__free(g);
    phks__free(gv);
    return st;
}

/* The log of the largest ratio of a Ritz residual to its threshold, scale
 * times the Ritz value's gap to floor_mu, over columns [first, first +
 * count) of theta and bottom. */
static double worst_excess(const lanczos *L, const double *r, double floor_mu,
                           size_t first, size_t count, double scale)
{
    double excess = -INFINITY;
    for (size_t e = first; e < first + count; e++) {
        double gap = L->theta[e] - floor_mu;
        double res = ritz_residual(L, r, e);
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
static phks_status check(lanczos *L, const double *r, size_t m, size_t q,
                         size_t k, double scale, double *excess)
{
    size_t few = FIRST_PAIRS < k ? FIRST_PAIRS : k, lowest = m - k + 1;
    phks_status st = reduce_t(L, m);
    if (st == PHKS_OK)
        st = pairs_t(L, m, m - q, m - q, false);
    if (st != PHKS_OK)
        return st;
    double floor_mu = L->theta[0];
    st = pairs_t(L, m, lowest, lowest + few - 1, true);
    if (st != PHKS_OK)
        return st;
    *excess = worst_excess(L, r, floor_mu, 0, few, scale);
    if (*excess > 0)
        return PHKS_OK;
    st = pairs_t(L, m, m - q, m, true);
    if (st == PHKS_OK)
        *excess = worst_excess(L, r, L->theta[0], 1 + q - k, k, scale);
    return st;
}

/* Lanczos on p(B) until the k lowest eigenpairs of B are found. Returns
 * PHKS_ERROR_NO_CONVERGENCE (without a message) when the cap is hit, and
 * sets *cut_low when the cut turned out to lie below lambda_k. */
static phks_status solve(engine *eng, const filter *f, size_t k,
                         size_t guard, size_t cap, double norm,
                         const phks_options *opt,
                         double lo, double hi, double *values, double *vectors,
                         double *next, bool *cut_low)
{
    size_t n = eng->pm->n, b = BLOCK, q = k + guard;
    double tol = opt->tolerance * norm;
    *cut_low = false;
    lanczos L = {.n = n, .k = k, .b = b, .cap = cap};
    /* Room for the basis the filtered solves end with (a small multiple
     * of q: docs/benchmarks.md): growing it means copying it. */
    phks_status st = allocate(&L, 2 * q + 4 * b);
    run_ctx rc = {eng, f};
    double r[BLOCK * BLOCK], smallest;
    if (st == PHKS_OK) {
        random_block(L.v, n, b, 1);
        st = qr(&L, L.v, r, &smallest);
    }
    size_t m = b, last_check = 0;
    /* filtered Lanczos converges with a basis of somewhat more than 1.5 q
     * (a first check at 1.7 q instead of 1.5 q saves a check on most
     * meshes: docs/benchmarks.md), plain Lanczos needs several times q */
    size_t next_check = (f->degree > 1 ? 17 * q / 10 : 2 * q) / b * b;
    double last_excess = 0;
    /* The polynomial's accuracy: Ritz residuals of p(B) are relative to
     * its largest value, and the wanted vectors must be accurate to about
     * the tolerance relative to the gap between p at the guard and p at
     * lambda_k. */
    double strict = 0.1;
    while (st == PHKS_OK) {
        st = step(&L, &rc, m, r);
        if (st != PHKS_OK)
            break;
        if (m >= next_check || m + b > cap) {
            double excess = INFINITY;
            st = check(&L, r, m, q, k, strict * opt->tolerance, &excess);
            if (st == PHKS_OK)
                st = phks__progress(opt, PHKS_STAGE_EIGEN, eng->fraction);
            if (st != PHKS_OK)
                break;
            bool ok = excess <= 0;
            if (ok) {
                double worst = INFINITY;
                /* The top k Ritz vectors of T (columns q - k + 1 .. q of
                 * ritz); Rayleigh-Ritz, if it is needed, takes all q. */
                st = ritz_vectors(&L, m, 1 + q - k, k);
                if (st != PHKS_OK)
                    break;
                /* lambda_{k+1}'s estimate before ritz_vectors and
                 * Rayleigh-Ritz reuse theta: the (k+1)-th largest Ritz
                 * value of p(B) is at most p(lambda_{k+1}), so its
                 * preimage is at least lambda_{k+1}; below 1 it lies
                 * beyond the cut */
                double theta_next = L.theta[q - k];
                *next = f->degree > 1 && !(theta_next > 1)
                            ? f->c - f->e
                            : filter_inverse(f, theta_next);
                st = ritz_pairs(&L, eng, f, m, q, k, values, vectors, &worst);
                if (st == PHKS_OK &&
                    (worst > tol || (f->degree > 1 && values[k - 1] >= f->c - f->e))) {
                    st = eig_t(&L, m, m - q, m);
                    if (st == PHKS_OK)
                        st = ritz_vectors(&L, m, 1, q);
                    if (st == PHKS_OK)
                        st = rayleigh_ritz(&L, eng, m, q, k, values, vectors,
                                           &worst, next);
                }
                if (st != PHKS_OK)
                    break;
                if (f->degree > 1 && values[k - 1] >= f->c - f->e) {
                    *cut_low = true;
                    st = PHKS_ERROR_NO_CONVERGENCE;
                    break;
                }
                if (worst <= tol)
                    break;
                strict *= 0.1;
            }
            /* Next check where the log excess reaches 0, extrapolated
             * linearly from the last two checks, or from this one at
             * FIRST_SLOPE; at most m / 4 ahead. After a Rayleigh-Ritz that
             * failed, the threshold is 10 times stricter. */
            if (ok)
                excess += log(10);
            double need = (double)(m / 4);
            if (isfinite(excess)) {
                double slope = FIRST_SLOPE;
                if (last_check && excess < last_excess)
                    slope = (last_excess - excess) / (double)(m - last_check);
                need = fmin(need, excess / slope);
            }
            size_t ahead = need > (double)b ? (size_t)ceil(need / (double)b) * b : b;
            last_check = m;
            last_excess = excess;
            next_check = m + ahead;
        }
        if (m + b > cap) {
            st = PHKS_ERROR_NO_CONVERGENCE;
            break;
        }
        st = reserve(&L, m + b);
        if (st != PHKS_OK)
            break;
        memcpy(L.v + m * n, L.w, n * b * sizeof(double));
        m += b;
        double frac = (double)m / (double)(2 * q);
        eng->fraction = lo + (hi - lo) * (frac < 1 ? frac : 1);
    }
    release(&L);
    return st;
}

/* The filtered solves, then plain Lanczos when they do not converge;
 * values and vectors in the pair matrix's numbering. */
static phks_status solve_all(engine *eng, size_t k, size_t guard,
                             size_t cap, double norm, const phks_options *opt,
                             double *values, double *vectors, double *next)
{
    size_t b = BLOCK;
    double lmax = 0, cut = 0;
    bool cut_low = false;
    phks_status st = probe(eng, opt, k, (size_t)((double)(k + guard) * CUT_MARGIN),
                           &lmax, &cut);
    if (st != PHKS_OK)
        return st;
    st = PHKS_ERROR_NO_CONVERGENCE;
    for (int attempt = 0; attempt < 3 && cut > 0 && cut < lmax; attempt++) {
        double d = round(FILTER_GROWTH / acosh((lmax + cut) / (lmax - cut)));
        int degree = d < 2 ? 2 : d > MAX_DEGREE ? MAX_DEGREE : (int)d;
        filter f = {degree, (lmax + cut) / 2, (lmax - cut) / 2};
        size_t fcap = 3 * (k + guard) + 8 * b;
        fcap = fcap < cap ? fcap : cap;
        st = solve(eng, &f, k, guard, fcap, norm, opt, 0.02, 0.9, values,
                   vectors, next, &cut_low);
        if (st != PHKS_ERROR_NO_CONVERGENCE || !cut_low)
            break;
        cut = cut + 2 * (values[k - 1] - cut) + 0.05 * (lmax - cut);
    }
    if (st != PHKS_ERROR_NO_CONVERGENCE)
        return st;
    /* plain Lanczos on B */
    filter plain = {1, 0, 1};
    return solve(eng, &plain, k, guard, cap, norm, opt, 0.02, 1, values,
                 vectors, next, &cut_low);
}

phks_status phks__eigen_lanczos(const phks__operator_matrix *op, size_t k,
                               const phks_options *opt, double *values,
                               double *vectors, double *next)
{
    size_t n = op->n, b = BLOCK;
    /* Plain Lanczos may need a basis of up to about 12 k; Lanczos on the
     * filter about 2 k. When n leaves too little room, the dense solve is
     * exact and cheap. */
    size_t usable = n - n % b;
    size_t guard = k / 8 + 2 * b;
    size_t cap = 12 * k + 8 * b;
    if (cap > usable - b)
        cap = usable - b;
    if (n < 8 * b || cap < k + guard + 4 * b ||
        (PROBE_STEPS + 1) * b > usable)
        return phks__eigen_dense(op, k, opt, values, vectors, next);
    phks__operator_pairs pm;
    phks_status st = phks__operator_pairs_build(op, phks__thread_count(opt), &pm);
    if (st != PHKS_OK)
        return st;
    engine eng = {&pm, phks__cpu_avx2(), opt, 0};
    double upper = INFINITY;
    st = solve_all(&eng, k, guard, cap, op->norm_bound, opt, values, vectors,
                   &upper);
    if (next)
        *next = upper;
    if (st == PHKS_OK) {
        /* back to the operator's numbering */
        double *column = phks__malloc_array(n, sizeof *column);
        if (!column)
            st = phks__fail_oom("Lanczos");
        for (size_t e = 0; e < k && st == PHKS_OK; e++) {
            double *x = vectors + e * n;
            memcpy(column, x, n * sizeof *column);
            for (size_t r = 0; r < n; r++)
                x[pm.order[r]] = column[r];
        }
        phks__free(column);
    }
    phks__operator_pairs_release(&pm);
    /* Not expected on connected meshes; the dense solver is exact where
     * it fits. Where it does not, ARPACK: much slower, but it deflates the
     * null space exactly and checks for missed copies of a multiple
     * eigenvalue, which is what stops this solver where the kernel splits
     * a mesh into many more components than its block (hundreds of
     * separate triangles: that many zero eigenvalues). */
    if (st == PHKS_ERROR_NO_CONVERGENCE && n <= DENSE_FALLBACK_MAX_N)
        return phks__eigen_dense(op, k, opt, values, vectors, next);
    if (st == PHKS_ERROR_NO_CONVERGENCE)
        return phks__eigen_arpack(op, k, opt, values, vectors, next);
    return st;
}
