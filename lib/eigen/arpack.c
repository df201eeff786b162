/*
 * arpack.c - the reference solver: ARPACK-NG's implicitly restarted
 * Lanczos in regular mode on B, smallest algebraic eigenvalues. B is
 * bounded, so no shift-invert (and no factorisation) is needed.
 *
 * ARPACK keeps its state in Fortran SAVE variables shared by all threads,
 * so every solve holds one process-wide lock from start to finish.
 *
 * B's null space is deflated first: it is known exactly (one vector per
 * component of the kernel's graph, phks__operator_components), and ARPACK
 * may return a multiple zero eigenvalue once (a cone whose cap centre lies
 * beyond the kernel's cut-off from every other vertex: 0 twice, ARPACK one
 * 0 and every later value shifted by one place). ARPACK runs on
 *     A = P B P + sigma (I - P),  P = I - Z Z^T,  sigma = |B|'s bound,
 * which has B's other eigenpairs and moves the null space to the top of
 * the spectrum, away from the wanted end; the null vectors are put in
 * front of its pairs.
 *
 * Single-vector Lanczos finds one vector per distinct eigenvalue in exact
 * arithmetic, and further copies of a multiple one only as rounding lets
 * them in: ARPACK may report convergence with a copy missing (an exactly
 * symmetric mesh: a geodesic sphere's 2l + 1, two identical parts' pairs)
 * or, where many eigenvalues crowd near zero (rings the kernel barely
 * joins), with several missing, every later value shifted. So the pairs
 * found are checked: ARPACK runs again on B with them deflated the same
 * way (moved to sigma), and whatever it finds below the largest pair kept
 * was missed; it joins the pairs, and the check repeats until nothing is
 * found below. On a mesh where the first run was right that is one more
 * run for a few pairs.
 */
#include "eigen/eigen.h"

#include <arpack.h>
#include <cblas.h>
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
    phks__free(w->resid);
    phks__free(w->v);
    phks__free(w->workd);
    phks__free(w->workl);
    phks__free(w->d);
    phks__free(w->select);
}

/* What A deflates: the null space (point i's component, entry root[i]
 * scale[c]) and `found` orthonormal vectors x (n x found), both moved to
 * sigma. */
typedef struct {
    const uint32_t *component;
    size_t count;
    const double *root, *scale;
    const double *x;
    size_t found;
    double *coef, *xcoef, *tmp; /* 2 count, 2 found, n scratch */
    double sigma;
    double shift;               /* ARPACK sees A + shift I (below) */
} deflation;

/* coef = Z^T v, xcoef = X^T v */
static void deflation_coef(const deflation *z, size_t n, const double *v,
                           double *coef, double *xcoef)
{
    memset(coef, 0, z->count * sizeof *coef);
    for (size_t i = 0; i < n; i++)
        coef[z->component[i]] += z->root[i] * v[i];
    for (size_t c = 0; c < z->count; c++)
        coef[c] *= z->scale[c];
    if (z->found)
        cblas_dgemv(CblasColMajor, CblasTrans, (int)n, (int)z->found, 1.0,
                    z->x, (int)n, v, 1, 0.0, xcoef, 1);
}

/* v += alpha Z coef + alpha X xcoef */
static void deflation_add(const deflation *z, size_t n, double alpha,
                          const double *coef, const double *xcoef, double *v)
{
    for (size_t i = 0; i < n; i++) {
        uint32_t c = z->component[i];
        v[i] += alpha * coef[c] * z->scale[c] * z->root[i];
    }
    if (z->found)
        cblas_dgemv(CblasColMajor, CblasNoTrans, (int)n, (int)z->found, alpha,
                    z->x, (int)n, xcoef, 1, 1.0, v, 1);
}

/* y = (P B P + sigma (I - P)) x, P projecting out Z and X */
static void apply_deflated(const phks__operator_matrix *op, const deflation *z,
                           const double *x, double *y, unsigned threads)
{
    size_t n = op->n;
    double *coef = z->coef, *xcoef = z->xcoef;
    double *coef2 = z->coef + z->count, *xcoef2 = z->xcoef + z->found;
    deflation_coef(z, n, x, coef, xcoef);
    memcpy(z->tmp, x, n * sizeof *x);
    deflation_add(z, n, -1, coef, xcoef, z->tmp);
    phks__operator_apply(op, z->tmp, y, 1, threads);
    deflation_coef(z, n, y, coef2, xcoef2);
    for (size_t c = 0; c < z->count; c++)
        coef2[c] = z->sigma * coef[c] - coef2[c];
    for (size_t j = 0; j < z->found; j++)
        xcoef2[j] = z->sigma * xcoef[j] - xcoef2[j];
    deflation_add(z, n, 1, coef2, xcoef2, y);
}

static phks_status iterate(const phks__operator_matrix *op, size_t k,
                           const phks_options *opt, arpack_work *w,
                           a_int *iparam, a_int *ipntr, const deflation *z)
{
    a_int n = (a_int)op->n, ido = 0, info = 1; /* info 1: use resid */
    unsigned threads = phks__thread_count(opt);
    size_t products = 0, expected = 4 * k + 100;
    for (;;) {
        dsaupd_c(&ido, "I", n, "SA", (a_int)k, opt->tolerance, w->resid,
                 w->ncv, w->v, n, iparam, ipntr, w->workd, w->workl, w->lworkl,
                 &info);
        if (ido != -1 && ido != 1)
            break;
        const double *x = w->workd + ipntr[0] - 1;
        double *y = w->workd + ipntr[1] - 1;
        apply_deflated(op, z, x, y, threads);
        for (a_int i = 0; i < n; i++)
            y[i] += z->shift * x[i];
        products++;
        if (products % 16 == 0) {
            phks_status st = phks__progress(opt, PHKS_STAGE_EIGEN,
                                           0.95 * (double)products / (double)expected);
            if (st != PHKS_OK)
                return st;
        }
    }
    if (info == 1)
        return phks__fail(PHKS_ERROR_NO_CONVERGENCE,
                         "ARPACK: no convergence after %d restarts (%d of %zu "
                         "eigenpairs converged)",
                         (int)iparam[2], (int)iparam[4], k);
    if (info < 0)
        return phks__fail(PHKS_ERROR_SOLVER, "ARPACK dsaupd: info %d", (int)info);
    return PHKS_OK;
}

/* The nev smallest pairs of the deflated operator into values, vectors
 * (n x nev), from the start vector `seed`. Takes the lock. */
static phks_status run(const phks__operator_matrix *op, size_t nev,
                       size_t ncv, a_int restarts, const phks_options *opt,
                       const deflation *z, uint64_t seed, double *values,
                       double *vectors)
{
    size_t n = op->n;
    arpack_work w = {0};
    w.ncv = (a_int)(ncv < n ? ncv : n);
    if ((size_t)w.ncv <= nev)
        return phks__fail(PHKS_ERROR_SOLVER,
                         "ARPACK: %zu pairs wanted of %zu vertices", nev, n);
    w.lworkl = w.ncv * (w.ncv + 8);
    w.resid = phks__malloc_array(n, sizeof(double));
    w.v = phks__malloc_array(n, (size_t)w.ncv * sizeof(double));
    w.workd = phks__malloc_array(3 * n, sizeof(double));
    w.workl = phks__malloc_array((size_t)w.lworkl, sizeof(double));
    w.d = phks__malloc_array(nev, sizeof(double));
    w.select = phks__calloc((size_t)w.ncv, sizeof(a_int));
    if (!w.resid || !w.v || !w.workd || !w.workl || !w.d || !w.select) {
        release(&w);
        return phks__fail_oom("ARPACK workspace");
    }
    phks__random_fill(w.resid, n, seed);
    a_int iparam[11] = {0}, ipntr[14] = {0};
    iparam[0] = 1;            /* exact shifts */
    iparam[2] = restarts;
    iparam[6] = 1;            /* mode 1: A x = lambda x */

    pthread_mutex_lock(&arpack_lock);
    phks_status st = iterate(op, nev, opt, &w, iparam, ipntr, z);
    if (st == PHKS_OK) {
        a_int info = 0;
        dseupd_c(1, "A", w.select, w.d, vectors, (a_int)n, 0, "I", (a_int)n,
                 "SA", (a_int)nev, opt->tolerance, w.resid, w.ncv, w.v, (a_int)n,
                 iparam, ipntr, w.workd, w.workl, w.lworkl, &info);
        if (info != 0)
            st = phks__fail(PHKS_ERROR_SOLVER, "ARPACK dseupd: info %d", (int)info);
    }
    pthread_mutex_unlock(&arpack_lock);
    if (st == PHKS_OK)
        for (size_t e = 0; e < nev; e++)
            values[e] = w.d[e] - z->shift;
    release(&w);
    return st;
}

/* Pairs each check asks for. A check runs with a small subspace and few
 * restarts first (enough on meshes without crowded eigenvalues), then, if
 * that does not converge, with the first run's subspace size and
 * restarts. Every check that finds something adds at least one missed
 * pair (a copy of a multiple eigenvalue per check, single-vector Lanczos
 * finding one per distinct value), so nev + 1 checks always end. */
#define CHECK_PAIRS 16
#define CHECK_RESTARTS 300

phks_status phks__eigen_arpack(const phks__operator_matrix *op, size_t k,
                              const phks_options *opt, double *values,
                              double *vectors, double *next)
{
    size_t n = op->n;
    if (k + 1 >= n) /* ARPACK needs nev < ncv <= n */
        return phks__eigen_dense(op, k, opt, values, vectors, next);
    uint32_t *component = NULL;
    deflation z = {0};
    phks_status st = phks__operator_components(op, &component, &z.count);
    if (st != PHKS_OK)
        return st;
    z.component = component;
    /* the pairs past the null space, and one more for *next */
    size_t zeros = z.count < k ? z.count : k;
    size_t nev = k - zeros + 1;
    size_t ncv = 2 * nev + 1 > nev + 20 ? 2 * nev + 1 : nev + 20;
    /* left for a check; none where the null space fills the request */
    size_t room = z.count < k && z.count + nev < n ? n - z.count - nev : 0;
    size_t extra = room > CHECK_PAIRS + 1 ? CHECK_PAIRS : room > 1 ? room - 1 : 0;
    double *root = phks__malloc_array(n, sizeof *root);
    double *scale = phks__malloc_array(z.count, sizeof *scale);
    z.coef = phks__malloc_array(z.count, 2 * sizeof *z.coef);
    z.xcoef = phks__malloc_array(nev, 2 * sizeof *z.xcoef);
    z.tmp = phks__malloc_array(n, sizeof *z.tmp);
    double *found = phks__malloc_array(n, nev * sizeof *found);
    double *fvals = phks__malloc_array(nev, sizeof *fvals);
    double *more = phks__malloc_array(n, (extra ? extra : 1) * sizeof *more);
    double *mvals = phks__malloc_array(extra ? extra : 1, sizeof *mvals);
    z.root = root;
    z.scale = scale;
    z.sigma = op->norm_bound;
    /* ARPACK's test is |r| <= tolerance |theta|, the library's |r| <=
     * tolerance |B|: the shift by B's bound makes them the same. Unshifted,
     * a crowd of eigenvalues near zero asked for residuals far below the
     * rounding errors of a product with B, and ARPACK did not converge. */
    z.shift = op->norm_bound;
    if (!root || !scale || !z.coef || !z.xcoef || !z.tmp || !found || !fvals ||
        !more || !mvals)
        st = phks__fail_oom("ARPACK workspace");
    if (st == PHKS_OK)
        st = phks__null_space(op, component, z.count, root, scale);
    /* more zeros than asked for: the k-th and the next are both 0 */
    if (st == PHKS_OK && z.count <= k)
        st = run(op, nev, ncv, MAX_RESTARTS, opt, &z, 0x5DEECE66Dull, fvals,
                 found);
    /* the checks for missed pairs */
    size_t small = 2 * extra + 1 > extra + 20 ? 2 * extra + 1 : extra + 20;
    small = small < ncv ? small : ncv;
    for (size_t check = 0; st == PHKS_OK && extra && check <= nev; check++) {
        z.x = found;
        z.found = nev;
        uint64_t seed = 0x5DEECE66Dull + 1 + (uint64_t)check;
        st = run(op, extra, small, CHECK_RESTARTS, opt, &z, seed, mvals, more);
        if (st == PHKS_ERROR_NO_CONVERGENCE && small < ncv)
            st = run(op, extra, ncv, MAX_RESTARTS, opt, &z, seed, mvals, more);
        z.found = 0;
        if (st != PHKS_OK)
            break;
        /* merge those at or below the largest pair kept: insertion from
         * the top, the largest pairs falling off */
        size_t added = 0;
        for (size_t j = 0; j < extra && mvals[j] <= fvals[nev - 1]; j++, added++) {
            size_t at = nev - 1;
            while (at > 0 && fvals[at - 1] > mvals[j]) {
                fvals[at] = fvals[at - 1];
                memcpy(found + at * n, found + (at - 1) * n, n * sizeof *found);
                at--;
            }
            fvals[at] = mvals[j];
            memcpy(found + at * n, more + j * n, n * sizeof *found);
        }
        if (!added)
            break;
        if (check == nev)
            st = phks__fail(PHKS_ERROR_NO_CONVERGENCE,
                           "ARPACK: still missing pairs after %zu checks",
                           check + 1);
    }
    if (st == PHKS_OK) {
        memset(vectors, 0, n * zeros * sizeof *vectors);
        for (size_t i = 0; i < n; i++)
            if (component[i] < zeros)
                vectors[component[i] * n + i] = root[i] * scale[component[i]];
        for (size_t e = 0; e < zeros; e++)
            values[e] = 0;
        memcpy(values + zeros, fvals, (k - zeros) * sizeof *values);
        memcpy(vectors + zeros * n, found, (k - zeros) * n * sizeof *vectors);
        if (next)
            *next = z.count > k ? 0 : fvals[nev - 1];
    }
    phks__free(component);
    phks__free(root);
    phks__free(scale);
    phks__free(z.coef);
    phks__free(z.xcoef);
    phks__free(z.tmp);
    phks__free(found);
    phks__free(fvals);
    phks__free(more);
    phks__free(mvals);
    return st;
}
