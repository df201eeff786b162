/*
 * arpack.c - the reference solver: ARPACK-NG's implicitly restarted
 * Lanczos in regular mode on B, smallest algebraic eigenvalues. B is
 * bounded, so no shift-invert (and no factorisation) is needed.
 *
 * ARPACK keeps its state in Fortran SAVE variables shared by all threads,
 * so every solve holds one process-wide lock from start to finish.
 */
#include "eigen/eigen.h"

#include <arpack.h>
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

static phks_status iterate(const phks__operator_matrix *op, size_t k,
                           const phks_options *opt, arpack_work *w,
                           a_int *iparam, a_int *ipntr)
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
        phks__operator_apply(op, w->workd + ipntr[0] - 1, w->workd + ipntr[1] - 1,
                            1, threads);
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

phks_status phks__eigen_arpack(const phks__operator_matrix *op, size_t k,
                              const phks_options *opt, double *values,
                              double *vectors)
{
    size_t n = op->n;
    if (k + 1 >= n) /* ARPACK needs nev < ncv <= n */
        return phks__eigen_dense(op, k, opt, values, vectors);
    arpack_work w = {0};
    size_t ncv = 2 * k + 1 > k + 20 ? 2 * k + 1 : k + 20;
    w.ncv = (a_int)(ncv < n ? ncv : n);
    w.lworkl = w.ncv * (w.ncv + 8);
    w.resid = phks__malloc_array(n, sizeof(double));
    w.v = phks__malloc_array(n, (size_t)w.ncv * sizeof(double));
    w.workd = phks__malloc_array(3 * n, sizeof(double));
    w.workl = phks__malloc_array((size_t)w.lworkl, sizeof(double));
    w.d = phks__malloc_array(k, sizeof(double));
    w.select = phks__calloc((size_t)w.ncv, sizeof(a_int));
    if (!w.resid || !w.v || !w.workd || !w.workl || !w.d || !w.select) {
        release(&w);
        return phks__fail_oom("ARPACK workspace");
    }
    phks__random_fill(w.resid, n, 0x5DEECE66Dull);
    a_int iparam[11] = {0}, ipntr[14] = {0};
    iparam[0] = 1;            /* exact shifts */
    iparam[2] = MAX_RESTARTS;
    iparam[6] = 1;            /* mode 1: B x = lambda x */

    pthread_mutex_lock(&arpack_lock);
    phks_status st = iterate(op, k, opt, &w, iparam, ipntr);
    if (st == PHKS_OK) {
        a_int info = 0;
        dseupd_c(1, "A", w.select, w.d, vectors, (a_int)n, 0, "I", (a_int)n,
                 "SA", (a_int)k, opt->tolerance, w.resid, w.ncv, w.v, (a_int)n,
                 iparam, ipntr, w.workd, w.workl, w.lworkl, &info);
        if (info != 0)
            st = phks__fail(PHKS_ERROR_SOLVER, "ARPACK dseupd: info %d", (int)info);
    }
    pthread_mutex_unlock(&arpack_lock);
    if (st == PHKS_OK)
        memcpy(values, w.d, k * sizeof *values);
    release(&w);
    return st;
}
