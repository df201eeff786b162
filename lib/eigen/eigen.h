/*
 * eigen.h - the eigen-solvers: the smallest eigenpairs of the operator's
 * symmetric matrix B.
 */
#ifndef PHKS_EIGEN_H
#define PHKS_EIGEN_H

#include "operator/operator.h"

/* ---- eigen-solvers (eigen_*.c): the k smallest eigenpairs of op's B.
 * values ascending (k), vectors column-major n x k, orthonormal in the
 * plain inner product. *next (next may be NULL) receives an estimate of
 * lambda_{k+1} that is not below it (INFINITY when k = n or unknown), which
 * tells whether the k-th value ends a cluster (spectrum.c). */
phks_status phks__eigen_lanczos(const phks__operator_matrix *op, size_t k,
                               const phks_options *opt, double *values,
                               double *vectors, double *next);
phks_status phks__eigen_arpack(const phks__operator_matrix *op, size_t k,
                              const phks_options *opt, double *values,
                              double *vectors, double *next);
phks_status phks__eigen_dense(const phks__operator_matrix *op, size_t k,
                             const phks_options *opt, double *values,
                             double *vectors, double *next);

#endif /* PHKS_EIGEN_H */
