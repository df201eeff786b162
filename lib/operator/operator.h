/*
 * operator.h - the Belkin-Sun-Wang mesh-Laplacian as a sparse symmetric
 * matrix, whose smallest eigenpairs the eigen layer finds.
 */
#ifndef PHKS_OPERATOR_H
#define PHKS_OPERATOR_H

#include "geometry/geometry.h"

/* ---- sparse symmetric operator (laplacian.c) */
/* The symmetric matrix B = Mh^-1/2 S Mh^-1/2 in CSR form (both triangles
 * stored, diagonal included), where Mh is the mass diagonal (area, or
 * area times kernel density for the random-walk operator). The eigenpairs
 * of B give those of S phi = lambda Mh phi by phi = Mh^-1/2 x. */
typedef struct phks__operator_matrix {
    size_t n;
    size_t *row_start;   /* n + 1 */
    uint32_t *col;
    double *val;
    double *mass;        /* Mh, n entries */
    double norm_bound;   /* Gershgorin bound on |B| */
    uint32_t *order;     /* the points in Morton order of their positions
                            (n entries; NULL: no locality order known)  */
} phks__operator_matrix;

phks_status phks__operator_build(const phks_mesh *mesh, const phks_options *opt,
                                phks__operator_matrix *op);
void phks__operator_release(phks__operator_matrix *op);
/* The matrix phks__operator_build makes for a mesh, for points at xyz
 * (3 per point, multiplied by scale) with masses area[] in place of the
 * vertex areas, and K_pq multiplied by sqrt(gain_p gain_q) when gain is
 * not NULL. Progress in PHKS_STAGE_OPERATOR from done to done + span (the
 * final report, at done + span, included). */
phks_status phks__point_operator_build(const double *xyz, size_t n,
                                      double scale, const double *area,
                                      const double *gain,
                                      const phks_options *opt, double done,
                                      double span, phks__operator_matrix *op);
/* Y = B X for a block of k vectors stored row-major (X[i*k + j] is entry i
 * of vector j), using `threads` workers. */
void phks__operator_apply(const phks__operator_matrix *op, const double *x,
                         double *y, size_t k, unsigned threads);

#endif /* PHKS_OPERATOR_H */
