/*
 * dense.c - the smallest eigenpairs of B from a dense LAPACK solve
 * (dsyevr, MRRR). Exact to rounding, O(n^2) memory and O(n^3) time: the
 * right tool for small meshes and the yardstick for the iterative solvers.
 */
#include "eigen/eigen.h"

#include <lapacke.h>
#include <math.h>
#include <string.h>

/* 16k x 16k doubles is 2 GiB; beyond that the iterative solvers win by
 * orders of magnitude anyway. */
#define DENSE_MAX_N 16384

phks_status phks__eigen_dense(const phks__operator_matrix *op, size_t k,
                             const phks_options *opt, double *values,
                             double *vectors, double *next)
{
    size_t n = op->n;
    if (n > DENSE_MAX_N)
        return phks__fail(PHKS_ERROR_TOO_LARGE,
                         "dense eigen-solver: %zu vertices, more than %d", n,
                         DENSE_MAX_N);
    /* one pair more than asked where there is one, for *next: dsyevr's
     * vectors and values for 1..k do not depend on how many follow */
    size_t want = next && k < n ? k + 1 : k;
    double *a = phks__calloc(n * n, sizeof *a);
    double *w = phks__malloc_array(n, sizeof *w);
    double *z = want > k ? phks__malloc_array(n, want * sizeof *z) : vectors;
    lapack_int *support = phks__malloc_array(2 * want, sizeof *support);
    phks_status st = PHKS_OK;
    if (!a || !w || !z || !support) {
        st = phks__fail_oom("dense eigen-solver");
        goto done;
    }
    for (size_t r = 0; r < n; r++)
        for (size_t i = op->row_start[r]; i < op->row_start[r + 1]; i++)
            a[op->col[i] * n + r] = op->val[i];
    st = phks__progress(opt, PHKS_STAGE_EIGEN, 0);
    if (st != PHKS_OK)
        goto done;
    lapack_int found = 0;
    lapack_int info = LAPACKE_dsyevr(LAPACK_COL_MAJOR, 'V', 'I', 'L',
                                     (lapack_int)n, a, (lapack_int)n, 0, 0, 1,
                                     (lapack_int)want, 0, &found, w, z,
                                     (lapack_int)n, support);
    if (info != 0 || (size_t)found != want) {
        st = phks__fail(PHKS_ERROR_SOLVER, "dense eigen-solver: dsyevr info %d",
                       (int)info);
        goto done;
    }
    memcpy(values, w, k * sizeof *values);
    if (z != vectors)
        memcpy(vectors, z, n * k * sizeof *z);
    if (next)
        *next = want > k ? w[k] : INFINITY;
    st = phks__progress(opt, PHKS_STAGE_EIGEN, 1);
done:
    phks__free(a);
    phks__free(w);
    if (z != vectors)
        phks__free(z);
    phks__free(support);
    return st;
}
