/*
 * dense.c - the smallest eigenpairs of B from a dense solve: the
 * library's own tridiagonal reduction (householder.c), LAPACK's bisection
 * and inverse iteration on the tridiagonal form (dstebz, dstein), and the
 * reflectors applied to the vectors: what dsyevr does for a subset of the
 * pairs, with the steps whose bits depend on the BLAS's thread count (the
 * reduction and the back-transformation) done in a fixed order. Exact to
 * rounding, O(n^2) memory and O(n^3) time: the right tool for small meshes
 * and the yardstick for the iterative solvers.
 */
#include "eigen/eigen.h"
#include "eigen/householder.h"

#include <lapacke.h>
#include <math.h>
#include <string.h>

/* 16k x 16k doubles is 2 GiB; beyond that the iterative solvers win by
 * orders of magnitude anyway. */
#define DENSE_MAX_N 16384

/* The workspace of one solve: n x n for B and its reflectors, n x want
 * for the vectors. */
typedef struct {
    double *a, *values, *vectors, *diag, *off, *tau, *work;
    lapack_int *block, *split, *failed;
} dense_work;

static void dense_release(dense_work *d)
{
    phks__free(d->a);
    phks__free(d->values);
    phks__free(d->vectors);
    phks__free(d->diag);
    phks__free(d->off);
    phks__free(d->tau);
    phks__free(d->work);
    phks__free(d->block);
    phks__free(d->split);
    phks__free(d->failed);
}

static bool dense_allocate(dense_work *d, size_t n, size_t want)
{
    d->a = phks__calloc(n * n, sizeof *d->a);
    /* zeroed: LAPACKE checks all n values of dstein's input for NaNs,
     * where dstebz sets the first `want` only */
    d->values = phks__calloc(n, sizeof *d->values);
    d->vectors = phks__malloc_array(n, want * sizeof *d->vectors);
    d->diag = phks__malloc_array(n, sizeof *d->diag);
    d->off = phks__malloc_array(n, sizeof *d->off);
    d->tau = phks__malloc_array(n, sizeof *d->tau);
    d->work = phks__malloc_array(n, sizeof *d->work);
    d->block = phks__malloc_array(n, sizeof *d->block);
    d->split = phks__malloc_array(n, sizeof *d->split);
    d->failed = phks__malloc_array(want, sizeof *d->failed);
    return d->a && d->values && d->vectors && d->diag && d->off && d->tau &&
           d->work && d->block && d->split && d->failed;
}

/* B into a, full: its lower triangle, mirrored (the one LAPACK read). */
static void dense_fill(const phks__operator_matrix *op, double *a)
{
    size_t n = op->n;
    for (size_t r = 0; r < n; r++)
        for (size_t i = op->row_start[r]; i < op->row_start[r + 1]; i++)
            a[op->col[i] * n + r] = op->val[i];
    for (size_t j = 0; j < n; j++)
        for (size_t i = j + 1; i < n; i++)
            a[i * n + j] = a[j * n + i];
}

/* dstebz orders the values block by block of the split tridiagonal form;
 * ascending overall, with their vectors, as dsyevr sorts them. */
static void sort_pairs(double *values, double *vectors, size_t n, size_t count)
{
    for (size_t j = 0; j + 1 < count; j++) {
        size_t low = j;
        for (size_t i = j + 1; i < count; i++)
            if (values[i] < values[low])
                low = i;
        if (low == j)
            continue;
        double v = values[j];
        values[j] = values[low];
        values[low] = v;
        for (size_t r = 0; r < n; r++) {
            double x = vectors[j * n + r];
            vectors[j * n + r] = vectors[low * n + r];
            vectors[low * n + r] = x;
        }
    }
}

/* The pairs 1..want of B (op) into d->values and d->vectors. */
static phks_status dense_pairs(const phks__operator_matrix *op, size_t want,
                               dense_work *d)
{
    lapack_int n = (lapack_int)op->n, found = 0, blocks = 0;
    dense_fill(op, d->a);
    phks__tridiagonal_reduce(d->a, op->n, d->diag, d->off, d->tau, d->work);
    lapack_int info = LAPACKE_dstebz('I', 'B', n, 0, 0, 1, (lapack_int)want, 0,
                                     d->diag, d->off, &found, &blocks,
                                     d->values, d->block, d->split);
    if (info != 0 || (size_t)found != want)
        return phks__fail(PHKS_ERROR_SOLVER, "dense eigen-solver: dstebz info %d",
                         (int)info);
    info = LAPACKE_dstein(LAPACK_COL_MAJOR, n, d->diag, d->off, found,
                          d->values, d->block, d->split, d->vectors, n,
                          d->failed);
    if (info != 0)
        return phks__fail(PHKS_ERROR_SOLVER, "dense eigen-solver: dstein info %d",
                         (int)info);
    sort_pairs(d->values, d->vectors, op->n, want);
    phks__tridiagonal_apply(d->a, op->n, d->tau, false, d->vectors, want);
    return PHKS_OK;
}

phks_status phks__eigen_dense(const phks__operator_matrix *op, size_t k,
                             const phks_options *opt, double *values,
                             double *vectors, double *next)
{
    size_t n = op->n;
    if (n > DENSE_MAX_N)
        return phks__fail(PHKS_ERROR_TOO_LARGE,
                         "dense eigen-solver: %zu vertices, more than %d", n,
                         DENSE_MAX_N);
    /* one pair more than asked where there is one, for *next: the vectors
     * and values for 1..k do not depend on how many follow */
    size_t want = next && k < n ? k + 1 : k;
    dense_work d = {0};
    phks_status st = dense_allocate(&d, n, want)
                         ? phks__progress(opt, PHKS_STAGE_EIGEN, 0)
                         : phks__fail_oom("dense eigen-solver");
    if (st == PHKS_OK)
        st = dense_pairs(op, want, &d);
    if (st == PHKS_OK) {
        memcpy(values, d.values, k * sizeof *values);
        memcpy(vectors, d.vectors, n * k * sizeof *vectors);
        if (next)
            *next = want > k ? d.values[k] : INFINITY;
        st = phks__progress(opt, PHKS_STAGE_EIGEN, 1);
    }
    dense_release(&d);
    return st;
}
