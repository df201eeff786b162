/*
 * householder.h - the eigen layer's own Householder kernels (householder.c):
 * the QR of a tall, narrow block and the reduction of a dense symmetric
 * matrix to tridiagonal form, with the application of its reflectors.
 *
 * Why not LAPACK. These are the calls whose results moved with the BLAS's
 * thread count (OPENBLAS_NUM_THREADS): LAPACK's unblocked QR and
 * tridiagonal reduction run on matrix-vector products that OpenBLAS splits
 * over its threads, each thread summing a part of every dot product, and
 * the BLAS offers no per-call thread count. Here every sum runs in one
 * fixed order, so the bits depend on the inputs alone. The algorithms and
 * the storage of the reflectors are LAPACK's (dgeqr2 and dorg2r, dsytd2
 * with UPLO = 'U', dormtr), and so is their accuracy.
 */
#ifndef PHKS_HOUSEHOLDER_H
#define PHKS_HOUSEHOLDER_H

#include <stdbool.h>
#include <stddef.h>

/* x^T y, summed in a fixed order. */
double phks__dot(const double *x, const double *y, size_t n);

/* Householder QR of the n x b column-major block a (n >= b): a becomes Q
 * (orthonormal columns), r (b x b column-major, may be NULL) receives R,
 * tau (b) is scratch. */
void phks__householder_qr(double *a, size_t n, size_t b, double *r,
                          double *tau);

/* Reduces the symmetric m x m column-major matrix a, both triangles set,
 * to tridiagonal form Q^T a Q: diag (m) and off (m - 1, off[i] couples i
 * and i + 1). Q = H(m-2) ... H(0) as with dsytrd's UPLO = 'U': the
 * reflector H(i) = I - tau[i] v v^T acts on rows 0..i, v[i] = 1 and
 * v[0..i) is kept in column i + 1 of a, above the diagonal. tau has m
 * entries (the last is set to 0); work has m. */
void phks__tridiagonal_reduce(double *a, size_t m, double *diag, double *off,
                              double *tau, double *work);

/* c := Q c, or Q^T c when transpose, for the m x cols column-major c and
 * the Q of phks__tridiagonal_reduce (a and tau as it left them). */
void phks__tridiagonal_apply(const double *a, size_t m, const double *tau,
                             bool transpose, double *c, size_t cols);

#endif /* PHKS_HOUSEHOLDER_H */
