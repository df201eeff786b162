/*
 * eigen_arpack.c - the reference solver: ARPACK-NG's implicitly restarted
 * Lanczos in regular mode on B, smallest algebraic eigenvalues. B is
 * bounded, so no shift-invert (and no factorisation) is needed.
 *
 * ARPACK keeps its state in Fortran SAVE variables shared by all threads,
 * so every solve holds one process-wide lock from start to finish.
 *
 * B's null space is deflated first: it is known exactly (one vector per
 * component of the kernel's graph, phks_operator_components), and ARPACK
 * may return a multiple zero eigenvalue once (a cone whose cap centre lies
 * beyond the kernel's cut-off from every other vertex: 0 twice, ARPACK one
 * 0 and every later value shifted by one place). ARPACK runs on
 *     A = P B P + sigma (I - P),  P = I - Z Z^T,  sigma = |B|'s bound,
 * which has B's other eigenpairs and moves the null space to the top of
 * the spectrum, away from the wanted end; the null vectors are put in
 * front of its pairs.
 */
#include "internal.h"

#include <arpack.h>
#include <math.h>
#include <pthread.h>
#include <string.h>

#define MAX_RESTARTS 10000

static pthread_mutex_t arpack_lock = PTHREAD_MUTEX_INITIALIZER;

typedef struct {
    a_int ncv, lworkl;
    double *resid, *v, *workd, *workl, *d;
    a_int *select;
} arpack_work;

static void release(arpack_work *w)
{
    phks_free(w->resid);
    phks_free(w->v);
    phks_free(w->workd);
    phks_free(w->workl);
    phks_free(w->d);
    phks_free(w->select);
}

/* The null space: point i's component and entry root[i] scale[c]. */
typedef struct {
    const uint32_t *component;
    size_t count;
    const double *root, *scale;
    double *coef, *x;       /* count, n scratch */
    double sigma;
} null_space;

/* Z^T v into z->coef. */
static void null_coef(const null_space *z, size_t n, const double *v)
{
    memset(z->coef, 0, z->count * sizeof *z->coef);
    for (size_t i = 0; i < n; i++)
        z->coef[z->component[i]] += z->root[i] * v[i];
    for (size_t c = 0; c < z->count; c++)
        z->coef[c] *= z->scale[c];
}

/* y = (P B P + sigma Z Z^T) x */
static void apply_deflated(const phks_operator_matrix *op, const null_space *z,
                           const double *x, double *y, unsigned threads)
{
    size_t n = op->n;
    null_coef(z, n, x);
    for (size_t i = 0; i < n; i++) {
        uint32_t c = z->component[i];
        z->x[i] = x[i] - z->coef[c] * z->scale[c] * z->root[i];
    }
    double *keep = z->coef + z->count; /* Z^T x, kept for the shift */
    memcpy(keep, z->coef, z->count * sizeof *keep);
    phks_operator_apply(op, z->x, y, 1, threads);
    null_coef(z, n, y);
    for (size_t i = 0; i < n; i++) {
        uint32_t c = z->component[i];
        y[i] += (z->sigma * keep[c] - z->coef[c]) * z->scale[c] * z->root[i];
    }
}

static phks_status iterate(const phks_operator_matrix *op, size_t k,
                           const phks_options *opt, arpack_work *w,
                           a_int *iparam, a_int *ipntr, const null_space *z)
{
    a_int n = (a_int)op->n, ido = 0, info = 1; /* info 1: use resid */
    unsigned threads = phks_thread_count(opt);
    size_t products = 0, expected = 4 * k + 100;
    for (;;) {
        dsaupd_c(&ido, "I", n, "SA", (a_int)k, opt->tolerance, w->resid,
                 w->ncv, w->v, n, iparam, ipntr, w->workd, w->workl, w->lworkl,
                 &info);
        if (ido != -1 && ido != 1)
            break;
        apply_deflated(op, z, w->workd + ipntr[0] - 1, w->workd + ipntr[1] - 1,
                       threads);
        products++;
        if (products % 16 == 0) {
            phks_status st = phks_progress(opt, PHKS_STAGE_EIGEN,
                                           0.95 * (double)products / (double)expected);
            if (st != PHKS_OK)
                return st;
        }
    }
    if (info == 1)
        return phks_fail(PHKS_ERROR_NO_CONVERGENCE,
                         "ARPACK: no convergence after %d restarts (%d of %zu "
                         "eigenpairs converged)",
                         (int)iparam[2], (int)iparam[4], k);
    if (info < 0)
        return phks_fail(PHKS_ERROR_SOLVER, "ARPACK dsaupd: info %d", (int)info);
    return PHKS_OK;
}

phks_status phks_eigen_arpack(const phks_operator_matrix *op, size_t k,
                              const phks_options *opt, double *values,
                              double *vectors, double *next)
{
    size_t n = op->n;
    if (k + 1 >= n) /* ARPACK needs nev < ncv <= n */
        return phks_eigen_dense(op, k, opt, values, vectors, next);
    uint32_t *component = NULL;
    null_space z = {0};
    phks_status st = phks_operator_components(op, &component, &z.count);
    if (st != PHKS_OK)
        return st;
    z.component = component;
    double *root = phks_malloc_array(n, sizeof *root);
    double *scale = phks_malloc_array(z.count, sizeof *scale);
    z.coef = phks_malloc_array(z.count, 2 * sizeof *z.coef);
    z.x = phks_malloc_array(n, sizeof *z.x);
    z.root = root;
    z.scale = scale;
    z.sigma = op->norm_bound;
    /* the pairs past the null space, and one more for *next */
    size_t zeros = z.count < k ? z.count : k;
    size_t nev = k - zeros + 1;
    double *found = phks_malloc_array(n, nev * sizeof *found);
    arpack_work w = {0};
    size_t ncv = 2 * nev + 1 > nev + 20 ? 2 * nev + 1 : nev + 20;
    w.ncv = (a_int)(ncv < n ? ncv : n);
    w.lworkl = w.ncv * (w.ncv + 8);
    w.resid = phks_malloc_array(n, sizeof(double));
    w.v = phks_malloc_array(n, (size_t)w.ncv * sizeof(double));
    w.workd = phks_malloc_array(3 * n, sizeof(double));
    w.workl = phks_malloc_array((size_t)w.lworkl, sizeof(double));
    w.d = phks_malloc_array(nev, sizeof(double));
    w.select = phks_calloc((size_t)w.ncv, sizeof(a_int));
    if (!root || !scale || !z.coef || !z.x || !found || !w.resid || !w.v ||
        !w.workd || !w.workl || !w.d || !w.select)
        st = phks_fail_oom("ARPACK workspace");
    if (st == PHKS_OK)
        st = phks_null_space(op, component, z.count, root, scale);
    if (st == PHKS_OK && (size_t)w.ncv <= nev)
        st = phks_fail(PHKS_ERROR_SOLVER,
                       "ARPACK: %zu pairs wanted of %zu vertices", nev, n);
    if (st != PHKS_OK)
        goto done;
    phks_random_fill(w.resid, n, 0x5DEECE66Dull);
    a_int iparam[11] = {0}, ipntr[14] = {0};
    iparam[0] = 1;            /* exact shifts */
    iparam[2] = MAX_RESTARTS;
    iparam[6] = 1;            /* mode 1: A x = lambda x */

    pthread_mutex_lock(&arpack_lock);
    st = iterate(op, nev, opt, &w, iparam, ipntr, &z);
    if (st == PHKS_OK) {
        a_int info = 0;
        dseupd_c(1, "A", w.select, w.d, found, (a_int)n, 0, "I", (a_int)n,
                 "SA", (a_int)nev, opt->tolerance, w.resid, w.ncv, w.v, (a_int)n,
                 iparam, ipntr, w.workd, w.workl, w.lworkl, &info);
        if (info != 0)
            st = phks_fail(PHKS_ERROR_SOLVER, "ARPACK dseupd: info %d", (int)info);
    }
    pthread_mutex_unlock(&arpack_lock);
    if (st == PHKS_OK) {
        memset(vectors, 0, n * zeros * sizeof *vectors);
        for (size_t i = 0; i < n; i++)
            if (component[i] < zeros)
                vectors[component[i] * n + i] = root[i] * scale[component[i]];
        for (size_t e = 0; e < zeros; e++)
            values[e] = 0;
        memcpy(values + zeros, w.d, (k - zeros) * sizeof *values);
        memcpy(vectors + zeros * n, found, (k - zeros) * n * sizeof *vectors);
        if (next)
            *next = z.count > k ? 0 : w.d[nev - 1];
    }
done:
    release(&w);
    phks_free(component);
    phks_free(root);
    phks_free(scale);
    phks_free(z.coef);
    phks_free(z.x);
    phks_free(found);
    return st;
}
