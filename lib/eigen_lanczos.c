/*
 * eigen_lanczos.c - the fast solver: block Lanczos with full
 * re-orthogonalisation, without restarts.
 *
 * Why this shape: B is bounded and its low end is what we want, so plain
 * Krylov iteration converges in about as many operator applications as
 * ARPACK needs, but ARPACK spends most of its time orthogonalising one
 * vector at a time (memory-bound BLAS2). Here the operator is applied to a
 * block of vectors at once (one pass over the matrix serves the whole
 * block) and every orthogonalisation is a matrix-matrix product (BLAS3).
 * Rayleigh-Ritz uses T = V^T B V as accumulated by the projections (the
 * three-term recurrence is never used explicitly), so the eigenvalues are
 * those of B restricted to the Krylov space.
 */
#include "internal.h"

#include <cblas.h>
#include <lapacke.h>
#include <math.h>
#include <string.h>

#define BLOCK 8
/* A new direction this much smaller than |B| is numerically in the span of
 * the basis already: the Krylov space has (nearly) closed. */
#define BREAKDOWN 1e-12

typedef struct {
    size_t n, k, b;
    size_t cap;             /* most basis columns ever allowed               */
    size_t room;            /* basis columns allocated so far                */
    double *v;              /* n x room, column-major basis                  */
    double *t;              /* V^T B V, upper triangle packed by columns:
                               column j holds rows 0..j at j (j + 1) / 2     */
    double *w;              /* n x b residual block                          */
    double *xr, *yr;        /* n x b row-major blocks for the operator       */
    double *c;              /* room x b projection coefficients              */
    double *tau;            /* b Householder scalars                         */
    double *ritz;           /* room x k Ritz vectors of T                    */
    double *theta;          /* room Ritz values                              */
    lapack_int *support;    /* 2 room, for dsyevr                            */
    double *tfull;          /* room x room copy of T for dsyevr              */
} lanczos;

static void release(lanczos *L)
{
    phks_free(L->v);
    phks_free(L->t);
    phks_free(L->w);
    phks_free(L->xr);
    phks_free(L->yr);
    phks_free(L->c);
    phks_free(L->tau);
    phks_free(L->ritz);
    phks_free(L->theta);
    phks_free(L->support);
    phks_free(L->tfull);
}

#define GROW(field, count)                                                   \
    do {                                                                     \
        void *p_ = phks_realloc_array(L->field, (count), sizeof *L->field);  \
        if (!p_)                                                             \
            return phks_fail_oom("Lanczos workspace");                       \
        L->field = p_;                                                       \
    } while (0)

/* Makes room for `columns` basis vectors. The basis grows geometrically:
 * how many vectors convergence needs is only known at the end, and
 * allocating the worst case up front would cost several times the memory
 * that typical meshes use. */
static phks_status reserve(lanczos *L, size_t columns)
{
    if (columns <= L->room)
        return PHKS_OK;
    size_t room = L->room * 2 > columns ? L->room * 2 : columns;
    room = room < L->cap ? room : L->cap;
    room -= room % L->b;
    GROW(v, L->n * room);
    GROW(t, room * (room + 1) / 2);
    GROW(c, room * L->b);
    GROW(ritz, room * L->k);
    GROW(theta, room);
    GROW(support, 2 * room);
    GROW(tfull, room * room);
    memset(L->t + L->room * (L->room + 1) / 2, 0,
           (room * (room + 1) / 2 - L->room * (L->room + 1) / 2) * sizeof *L->t);
    L->room = room;
    return PHKS_OK;
}

static phks_status allocate(lanczos *L)
{
    size_t n = L->n, b = L->b;
    L->w = phks_malloc_array(n, b * sizeof(double));
    L->xr = phks_malloc_array(n, b * sizeof(double));
    L->yr = phks_malloc_array(n, b * sizeof(double));
    L->tau = phks_malloc_array(b, sizeof(double));
    if (!L->w || !L->xr || !L->yr || !L->tau)
        return phks_fail_oom("Lanczos workspace");
    return reserve(L, 3 * L->k + 8 * b < L->cap ? 3 * L->k + 8 * b : L->cap);
}

/* A fixed pseudo-random block, so that every run starts alike. */
static void random_block(double *w, size_t n, size_t b, uint64_t seed)
{
    uint64_t s = seed * 0x9E3779B97F4A7C15ull + 1;
    for (size_t i = 0; i < n * b; i++) {
        s = s * 6364136223846793005ull + 1442695040888963407ull;
        w[i] = (double)(s >> 11) * 0x1.0p-53 - 0.5;
    }
}

/* W -= V[:, 0:m] (V[:, 0:m]^T W), twice (classical Gram-Schmidt with one
 * re-orthogonalisation: "twice is enough"). When col is given, W is B times
 * the basis block at columns [col, col + b), and the coefficients on and
 * above the diagonal go to T. */
static void orthogonalise(lanczos *L, size_t m, double *w, long col)
{
    size_t n = L->n, b = L->b;
    if (m == 0)
        return;
    for (int pass = 0; pass < 2; pass++) {
        cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, (int)m, (int)b,
                    (int)n, 1.0, L->v, (int)n, w, (int)n, 0.0, L->c, (int)m);
        cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, (int)n, (int)b,
                    (int)m, -1.0, L->v, (int)n, L->c, (int)m, 1.0, w, (int)n);
        if (col >= 0)
            for (size_t j = 0; j < b; j++) {
                size_t column = (size_t)col + j;
                double *t = L->t + column * (column + 1) / 2;
                for (size_t i = 0; i <= column; i++)
                    t[i] += L->c[j * m + i];
            }
    }
}

/* Householder QR of the n x b block w: w becomes Q, r (b x b, column-major)
 * receives R. Returns the smallest |R_ii|. */
static phks_status qr(lanczos *L, double *w, double *r, double *smallest)
{
    size_t n = L->n, b = L->b;
    lapack_int info = LAPACKE_dgeqrf(LAPACK_COL_MAJOR, (lapack_int)n,
                                     (lapack_int)b, w, (lapack_int)n, L->tau);
    if (info != 0)
        return phks_fail(PHKS_ERROR_SOLVER, "Lanczos: dgeqrf info %d", (int)info);
    double s = INFINITY;
    for (size_t j = 0; j < b; j++)
        for (size_t i = 0; i < b; i++) {
            r[j * b + i] = i <= j ? w[j * n + i] : 0;
            if (i == j)
                s = fmin(s, fabs(w[j * n + i]));
        }
    info = LAPACKE_dorgqr(LAPACK_COL_MAJOR, (lapack_int)n, (lapack_int)b,
                          (lapack_int)b, w, (lapack_int)n, L->tau);
    if (info != 0)
        return phks_fail(PHKS_ERROR_SOLVER, "Lanczos: dorgqr info %d", (int)info);
    *smallest = s;
    return PHKS_OK;
}

/* Next basis block from the residual w of the block at columns
 * [m - b, m): w = Q R with Q orthogonal to V[:, 0:m]. When the residual is
 * (nearly) rank-deficient, Householder's Q may leave the span it should
 * avoid, so Q is re-orthogonalised against the basis and R recomputed as
 * the exact projection Q^T w. */
static phks_status next_block(lanczos *L, size_t m, double norm, double *r)
{
    size_t n = L->n, b = L->b;
    double smallest;
    memcpy(L->xr, L->w, n * b * sizeof(double)); /* keep w for a repair */
    phks_status st = qr(L, L->w, r, &smallest);
    if (st != PHKS_OK || smallest > BREAKDOWN * norm)
        return st;
    double *q = L->w, *residual = L->xr;
    random_block(L->yr, n, b, m);
    for (size_t j = 0; j < b; j++)
        if (fabs(r[j * b + j]) <= BREAKDOWN * norm)
            memcpy(q + j * n, L->yr + j * n, n * sizeof(double));
    orthogonalise(L, m, q, -1);
    double dummy[BLOCK * BLOCK];
    st = qr(L, q, dummy, &smallest);
    if (st != PHKS_OK)
        return st;
    orthogonalise(L, m, q, -1);
    st = qr(L, q, dummy, &smallest);
    if (st != PHKS_OK)
        return st;
    cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, (int)b, (int)b, (int)n,
                1.0, q, (int)n, residual, (int)n, 0.0, r, (int)b);
    return PHKS_OK;
}

static void apply_block(const phks_operator_matrix *op, lanczos *L,
                        const double *block, unsigned threads)
{
    size_t n = L->n, b = L->b;
    for (size_t i = 0; i < n; i++)
        for (size_t j = 0; j < b; j++)
            L->xr[i * b + j] = block[j * n + i];
    phks_operator_apply(op, L->xr, L->yr, b, threads);
    for (size_t i = 0; i < n; i++)
        for (size_t j = 0; j < b; j++)
            L->w[j * n + i] = L->yr[i * b + j];
}

/* Ritz pairs of T[0:m, 0:m] (its upper triangle: the projections
 * V_i^T B V_j for i <= j, which is all of V^T B V); returns the largest residual |B y - theta y|
 * of the k wanted ones, which is |R s_last| for the coupling R to the next
 * block. */
static phks_status ritz(lanczos *L, size_t m, const double *r, double *worst)
{
    size_t k = L->k, b = L->b;
    for (size_t j = 0; j < m; j++)
        memcpy(L->tfull + j * m, L->t + j * (j + 1) / 2, (j + 1) * sizeof(double));
    lapack_int found = 0;
    lapack_int info = LAPACKE_dsyevr(LAPACK_COL_MAJOR, 'V', 'I', 'U',
                                     (lapack_int)m, L->tfull, (lapack_int)m, 0,
                                     0, 1, (lapack_int)k, 0, &found, L->theta,
                                     L->ritz, (lapack_int)m, L->support);
    if (info != 0 || (size_t)found != k)
        return phks_fail(PHKS_ERROR_SOLVER, "Lanczos: dsyevr info %d", (int)info);
    double w = 0;
    for (size_t e = 0; e < k; e++) {
        const double *s = L->ritz + e * m + (m - b);
        double sum = 0;
        for (size_t i = 0; i < b; i++) {
            double x = 0;
            for (size_t j = 0; j < b; j++)
                x += r[j * b + i] * s[j];
            sum += x * x;
        }
        w = fmax(w, sqrt(sum));
    }
    *worst = w;
    return PHKS_OK;
}

phks_status phks_eigen_lanczos(const phks_operator_matrix *op, size_t k,
                               const phks_options *opt, double *values,
                               double *vectors)
{
    size_t n = op->n, b = BLOCK;
    /* The Krylov space needs room well beyond k (about 3k on real meshes,
     * up to 12k when the wanted eigenvalues are a tiny fraction of |B|).
     * When n leaves too little room, the dense solve is exact and cheap. */
    size_t cap = 12 * k + 8 * b;
    if (cap > n - n % b - b)
        cap = n - n % b - b;
    if (n < 4 * b || cap < k + 4 * b)
        return phks_eigen_dense(op, k, opt, values, vectors);
    lanczos L = {.n = n, .k = k, .b = b, .cap = cap};
    phks_status st = allocate(&L);
    if (st != PHKS_OK) {
        release(&L);
        return st;
    }
    double norm = op->norm_bound, r[BLOCK * BLOCK], smallest;
    unsigned threads = phks_thread_count(opt);
    random_block(L.v, n, b, 0);
    st = qr(&L, L.v, r, &smallest);

    size_t m = b, next_check = k + 2 * b;
    double worst = INFINITY;
    while (st == PHKS_OK) {
        apply_block(op, &L, L.v + (m - b) * n, threads);
        orthogonalise(&L, m, L.w, (long)(m - b));
        st = next_block(&L, m, norm, r);
        if (st != PHKS_OK)
            break;
        if (m >= next_check || m + b > cap - b) {
            st = ritz(&L, m, r, &worst);
            if (st != PHKS_OK || worst <= opt->tolerance * norm)
                break;
            next_check = m + (m / 8 > b ? m / 8 : b);
        }
        if (m + b > cap - b) {
            st = phks_fail(PHKS_ERROR_NO_CONVERGENCE,
                           "Lanczos: residual %.3g above %.3g with a basis of "
                           "%zu vectors",
                           worst / norm, opt->tolerance, m);
            break;
        }
        st = reserve(&L, m + b);
        if (st != PHKS_OK)
            break;
        memcpy(L.v + m * n, L.w, n * b * sizeof(double));
        m += b;
        st = phks_progress(opt, PHKS_STAGE_EIGEN,
                           0.95 * (double)m / (double)(3 * k + 4 * b));
    }
    if (st == PHKS_OK) {
        memcpy(values, L.theta, k * sizeof *values);
        cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, (int)n, (int)k,
                    (int)m, 1.0, L.v, (int)n, L.ritz, (int)m, 0.0, vectors,
                    (int)n);
    }
    release(&L);
    return st;
}
