/*
 * eigen.h - the eigen-solvers: the smallest eigenpairs of the operator's
 * symmetric matrix B.
 */
#ifndef PHKS_EIGEN_H
#define PHKS_EIGEN_H

#include "operator/operator.h"

/* ---- eigen-solvers (eigen_*.c): the k smallest eigenpairs of op's B.
 * values ascending (k), vectors column-major n x k, orthonormal in the
 * plain inner product. */
phks_status phks__eigen_lanczos(const phks__operator_matrix *op, size_t k,
                               const phks_options *opt, double *values,
                               double *vectors);
phks_status phks__eigen_arpack(const phks__operator_matrix *op, size_t k,
                              const phks_options *opt, double *values,
                              double *vectors);
phks_status phks__eigen_dense(const phks__operator_matrix *op, size_t k,
                             const phks_options *opt, double *values,
                             double *vectors);

#endif /* PHKS_EIGEN_H */
