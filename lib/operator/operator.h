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

/* The points an operator is built on: n positions (3 each, multiplied by
 * scale), their masses area[] (unit-box units), and, when gain is not
 * NULL, kernel gains: K_pq is multiplied by sqrt(gain_p gain_q). */
typedef struct phks__points {
    const double *xyz;
    size_t n;
    double scale;
    const double *area;
    const double *gain;
} phks__points;

/* The operator of a mesh: its vertices with their areas. Progress in `at`
 * (the final report, at its end, included). */
phks_status phks__operator_build(const phks__unit_mesh *um,
                                 const phks_options *opt, phks__span at,
                                 phks__operator_matrix *op);
/* The same for any points (HKS-simp's samples). */
phks_status phks__operator_build_points(const phks__points *points,
                                        const phks_options *opt,
                                        phks__span at,
                                        phks__operator_matrix *op);
void phks__operator_release(phks__operator_matrix *op);
/* Y = B X for a block of k vectors stored row-major (X[i*k + j] is entry i
 * of vector j), using `threads` workers. */
void phks__operator_apply(const phks__operator_matrix *op, const double *x,
                         double *y, size_t k, unsigned threads);

/* ---- B's null space (null_space.c) */
/* The connected components of the graph of op's non-zero off-diagonal
 * entries (the kernel's, which may split a connected mesh): *component
 * (a library allocation, n entries) numbers them 0.. in order of lowest
 * point, *count is their number. */
phks_status phks__operator_components(const phks__operator_matrix *op,
                                      uint32_t **component, size_t *count);
/* root[i] = sqrt(Mh_i) and scale[c] = 1 / sqrt(Mh of component c): the
 * unit null vector of component c is root[i] scale[c] on its points. */
phks_status phks__null_space(const phks__operator_matrix *op,
                             const uint32_t *component, size_t count,
                             double *root, double *scale);

#endif /* PHKS_OPERATOR_H */
