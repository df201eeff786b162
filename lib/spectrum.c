/*
 * spectrum.c - from a mesh to its smallest eigenpairs: build the operator,
 * pick a solver, and turn the eigenvectors of the symmetric B back into
 * those of the generalised problem (phi = Mh^-1/2 x).
 */
#include "internal.h"

#include <math.h>
#include <string.h>

/* Below this many vertices a dense solve is exact and at least as fast. */
#define AUTO_DENSE_BELOW 1000

void phks_spectrum_free(phks_spectrum *spec)
{
    if (!spec)
        return;
    phks_free(spec->values);
    phks_free(spec->vectors);
    phks_free(spec->mass);
    phks_free(spec);
}

static phks_status solve(const phks_operator_matrix *op, size_t k,
                         const phks_options *opt, double *values,
                         double *vectors)
{
    switch (opt->solver) {
    case PHKS_SOLVER_ARPACK:
        return phks_eigen_arpack(op, k, opt, values, vectors);
    case PHKS_SOLVER_DENSE:
        return phks_eigen_dense(op, k, opt, values, vectors);
    case PHKS_SOLVER_LANCZOS:
        return phks_eigen_lanczos(op, k, opt, values, vectors);
    default:
        if (op->n < AUTO_DENSE_BELOW)
            return phks_eigen_dense(op, k, opt, values, vectors);
        return phks_eigen_lanczos(op, k, opt, values, vectors);
    }
}

/* Mh^-1/2 scaling, and a sign convention so that results do not depend on
 * which of +phi and -phi a solver happened to return: the entry of largest
 * magnitude (the first such) is positive. */
static void finish_vectors(phks_spectrum *spec)
{
    size_t n = spec->n;
    for (size_t e = 0; e < spec->count; e++) {
        double *phi = spec->vectors + e * n;
        size_t big = 0;
        for (size_t i = 0; i < n; i++) {
            phi[i] /= sqrt(spec->mass[i]);
            if (fabs(phi[i]) > fabs(phi[big]))
                big = i;
        }
        if (phi[big] < 0)
            for (size_t i = 0; i < n; i++)
                phi[i] = -phi[i];
    }
}

phks_status phks_spectrum_compute(const phks_mesh *mesh,
                                  const phks_options *options,
                                  phks_spectrum **out)
{
    if (out)
        *out = NULL;
    if (!mesh || !out)
        return phks_fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_spectrum_compute: NULL argument");
    phks_options opt;
    phks_status st = phks_options_resolve(options, &opt);
    if (st != PHKS_OK)
        return st;
    phks_spectrum *spec = phks_calloc(1, sizeof *spec);
    if (!spec)
        return phks_fail_oom("spectrum");
    phks_operator_matrix op;
    st = phks_operator_build(mesh, &opt, &op);
    if (st != PHKS_OK) {
        phks_free(spec);
        return st;
    }
    size_t n = mesh->vertex_count;
    spec->n = n;
    spec->count = opt.eigen_count < n ? opt.eigen_count : n;
    spec->options = opt;
    spec->options.progress = NULL;
    spec->options.progress_user = NULL;
    spec->values = phks_malloc_array(spec->count, sizeof(double));
    spec->vectors = phks_malloc_array(n, spec->count * sizeof(double));
    spec->mass = phks_malloc_array(n, sizeof(double));
    if (!spec->values || !spec->vectors || !spec->mass)
        st = phks_fail_oom("spectrum");
    if (st == PHKS_OK) {
        memcpy(spec->mass, op.mass, n * sizeof(double));
        st = solve(&op, spec->count, &opt, spec->values, spec->vectors);
    }
    phks_operator_release(&op);
    if (st != PHKS_OK) {
        phks_spectrum_free(spec);
        return st;
    }
    finish_vectors(spec);
    st = phks_progress(&opt, PHKS_STAGE_EIGEN, 1);
    if (st != PHKS_OK) {
        phks_spectrum_free(spec);
        return st;
    }
    *out = spec;
    return PHKS_OK;
}

size_t phks_spectrum_count(const phks_spectrum *s) { return s ? s->count : 0; }
size_t phks_spectrum_vertex_count(const phks_spectrum *s) { return s ? s->n : 0; }
const double *phks_spectrum_eigenvalues(const phks_spectrum *s) { return s ? s->values : NULL; }
const double *phks_spectrum_mass(const phks_spectrum *s) { return s ? s->mass : NULL; }

const double *phks_spectrum_eigenvector(const phks_spectrum *s, size_t i)
{
    return s && i < s->count ? s->vectors + i * s->n : NULL;
}
