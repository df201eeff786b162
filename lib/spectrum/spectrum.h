/*
 * spectrum.h - a mesh's spectrum (exact, or through HKS-simp on large
 * meshes) and the heat kernel signature computed from it.
 */
#ifndef PHKS_SPECTRUM_H
#define PHKS_SPECTRUM_H

#include "eigen/eigen.h"

/* ---- spectrum (spectrum.c, hks.c; HKS-simp in simp.h) */
struct phks_spectrum {
    size_t n, count;      /* n: the mesh's vertex count               */
    double *values;       /* count, ascending                         */
    double *vectors;      /* rows x count column-major, Mh-orthonormal;
                             rows = n, or ext->m with HKS-simp        */
    double *mass;         /* n: Mh of every mesh vertex (with HKS-simp
                             its area times Mh / A of its sample), so
                             the sum is the total mass either way     */
    phks_options options; /* resolved options it was computed with    */
    struct phks__extension *ext; /* HKS-simp: the samples and what the
                             extension to every vertex needs; NULL for
                             an exact spectrum                        */
};

/* HKS_t at one vertex: sum_i exp(-t lambda_i) phi_i(v)^2 (through the
 * extension with HKS-simp). */
double phks__hks_at(const phks_spectrum *spec, double t, size_t v);
/* HKS_t at every vertex into out (n values), reporting PHKS_STAGE_HKS
 * progress through opt (its threads too); t finite and >= 0. */
phks_status phks__hks_all(const phks_spectrum *spec, double t,
                         const phks_options *opt, double *out);

/* Eigenvalues within this fraction of max(|lambda|, 1 / tau) of each
 * other are equal: a spectrum keeps whole clusters of them (phks.h). */
#define PHKS__CLUSTER_TOL 1e-6

/* The part of PHKS_STAGE_OPERATOR in which a computation's top finds the
 * unit box and the areas before the operator. */
#define PHKS__UNIT_MESH_SPAN 0.03

/* The unit box and the areas of mesh as a spectrum computation starts
 * (progress: PHKS_STAGE_OPERATOR from 0 to PHKS__UNIT_MESH_SPAN), for
 * phks__spectrum_compute and whatever else the caller needs them for. */
phks_status phks__spectrum_unit_mesh(const phks_mesh *mesh,
                                     const phks_options *opt,
                                     phks__unit_mesh *um);

/* phks_spectrum_compute on resolved options, for the mesh seen through um
 * (its unit box's scale and areas, computed once by the caller). Enters
 * the library's thread team for the solve. */
phks_status phks__spectrum_compute(const phks__unit_mesh *um,
                                   const phks_options *opt,
                                   phks_spectrum **out);

#endif /* PHKS_SPECTRUM_H */
