/*
 * spectrum.c - from a mesh to its smallest eigenpairs: build the operator,
 * pick a solver, and turn the eigenvectors of the symmetric B back into
 * those of the generalised problem (phi = Mh^-1/2 x). Meshes above
 * options->simplify_above vertices take the HKS-simp path (simp.h): the
 * same steps on the samples, then what the extension needs.
 */
#include "spectrum/simp.h"

#include <math.h>
#include <string.h>

/* Below this many vertices a dense solve is exact and at least as fast. */
#define AUTO_DENSE_BELOW 1000

void phks_spectrum_free(phks_spectrum *spec)
{
    if (!spec)
        return;
    phks__free(spec->values);
    phks__free(spec->vectors);
    phks__free(spec->mass);
    phks__extension_free(spec->ext);
    phks__free(spec);
}

static phks_status run_solver(const phks__operator_matrix *op, size_t k,
                              const phks_options *opt, double *values,
                              double *vectors, double *next)
{
    switch (opt->solver) {
    case PHKS_SOLVER_ARPACK:
        return phks__eigen_arpack(op, k, opt, values, vectors, next);
    case PHKS_SOLVER_DENSE:
        return phks__eigen_dense(op, k, opt, values, vectors, next);
    case PHKS_SOLVER_LANCZOS:
        return phks__eigen_lanczos(op, k, opt, values, vectors, next);
    default:
        if (op->n < AUTO_DENSE_BELOW)
            return phks__eigen_dense(op, k, opt, values, vectors, next);
        return phks__eigen_lanczos(op, k, opt, values, vectors, next);
    }
}

static bool cluster_equal(double a, double b, const phks_options *opt)
{
    return fabs(b - a) <= PHKS__CLUSTER_TOL * fmax(fabs(b), 1 / opt->tau);
}

/* The zero eigenvalue's whole cluster, from op's components (zeros of
 * them), into spec. */
static phks_status null_pairs(const phks__operator_matrix *op,
                              const uint32_t *component, size_t zeros,
                              phks_spectrum *spec)
{
    size_t n = op->n;
    double *root = phks__malloc_array(n, sizeof *root);
    double *scale = phks__malloc_array(zeros, sizeof *scale);
    double *values = phks__realloc_array(spec->values, zeros, sizeof(double));
    if (values)
        spec->values = values;
    double *vectors = phks__realloc_array(spec->vectors, n, zeros * sizeof(double));
    if (vectors)
        spec->vectors = vectors;
    phks_status st = root && scale && values && vectors
                         ? phks__null_space(op, component, zeros, root, scale)
                         : phks__fail_oom("spectrum");
    if (st == PHKS_OK) {
        memset(vectors, 0, n * zeros * sizeof(double));
        for (size_t i = 0; i < n; i++)
            vectors[component[i] * n + i] = root[i] * scale[component[i]];
        for (size_t c = 0; c < zeros; c++)
            values[c] = 0;
        spec->count = zeros;
    }
    phks__free(root);
    phks__free(scale);
    return st;
}

/* The smallest eigenpairs of op's B into spec->values and spec->vectors
 * (op->n rows), spec->count of them: k, less the pairs of a cluster of
 * equal eigenvalues (PHKS__CLUSTER_TOL) that the k-th value would split.
 * Within such a cluster a solver returns any orthonormal basis, and HKS
 * sums phi_i(x)^2 over the pairs kept, which is the same for every basis
 * of a whole cluster only; on an exactly symmetric mesh the cut at k
 * would otherwise make HKS depend on the solver and on the mesh's
 * orientation. The zero eigenvalue's cluster (one per component of the
 * kernel's graph) is known exactly and kept whole even beyond k.
 * Finding the components reads every entry of op, a measurable part of
 * a signature's time (docs/benchmarks.md), so it is done only where the
 * zero cluster may reach k:
 * beforehand where the mesh has at least k components (`pieces`; Krylov
 * solvers find a cluster many times wider than their block only slowly,
 * if at all), afterwards where the solver's k-th value and its next are
 * both zero. */
static phks_status solve(const phks__operator_matrix *op, size_t k,
                         size_t pieces, const phks_options *opt,
                         phks_spectrum *spec)
{
    size_t n = op->n, zeros = 0;
    uint32_t *component = NULL;
    phks_status st = PHKS_OK;
    if (pieces >= k) {
        st = phks__operator_components(op, &component, &zeros);
        if (st == PHKS_OK && zeros >= k)
            st = null_pairs(op, component, zeros, spec);
        if (st != PHKS_OK || zeros >= k) {
            phks__free(component);
            return st;
        }
    }
    phks__free(component);
    component = NULL;
    spec->values = phks__malloc_array(k, sizeof(double));
    spec->vectors = phks__malloc_array(n, k * sizeof(double));
    if (!spec->values || !spec->vectors)
        return phks__fail_oom("spectrum");
    double next = INFINITY;
    st = run_solver(op, k, opt, spec->values, spec->vectors, &next);
    spec->count = k;
    if (st != PHKS_OK || k == n || !cluster_equal(spec->values[k - 1], next, opt))
        return st;
    if (cluster_equal(0, spec->values[k - 1], opt)) {
        /* the zero cluster reaches past k */
        st = phks__operator_components(op, &component, &zeros);
        if (st == PHKS_OK && zeros >= k)
            st = null_pairs(op, component, zeros, spec);
        /* else eigenvalues within the tolerance of zero but not zero
         * (components joined by a thread of tiny weights): all k kept */
        phks__free(component);
        return st;
    }
    size_t count = k - 1;
    while (count > 0 &&
           cluster_equal(spec->values[count - 1], spec->values[count], opt))
        count--;
    /* a chain of equal values down into the zero cluster: as above */
    if (count > 0 && !cluster_equal(0, spec->values[count], opt))
        spec->count = count;
    return PHKS_OK;
}

/* Mh^-1/2 scaling, and a sign convention so that results do not depend on
 * which of +phi and -phi a solver happened to return: the entry of largest
 * magnitude (the first such) is positive. Eigenvectors split over threads. */
typedef struct {
    double *vectors;
    size_t n;
    const double *root;   /* sqrt(mass) */
} finish_ctx;

static void finish_range(void *ctx, size_t begin, size_t end)
{
    const finish_ctx *f = ctx;
    for (size_t e = begin; e < end; e++) {
        double *phi = f->vectors + e * f->n;
        size_t big = 0;
        for (size_t i = 0; i < f->n; i++) {
            phi[i] /= f->root[i];
            if (fabs(phi[i]) > fabs(phi[big]))
                big = i;
        }
        if (phi[big] < 0)
            for (size_t i = 0; i < f->n; i++)
                phi[i] = -phi[i];
    }
}

static phks_status finish_vectors(phks_spectrum *spec, size_t n,
                                  const double *mass, const phks_options *opt)
{
    double *root = phks__malloc_array(n, sizeof *root);
    if (!root)
        return phks__fail_oom("spectrum");
    for (size_t i = 0; i < n; i++)
        root[i] = sqrt(mass[i]);
    finish_ctx f = {spec->vectors, n, root};
    phks__parallel_for(spec->count, phks__thread_count(opt), finish_range, &f);
    phks__free(root);
    return PHKS_OK;
}

/* HKS-simp: samples, their operator and eigenpairs, and the extension
 * data. Progress: the sampling and the samples' operator are the operator
 * stage (the sampling takes most of it on a large mesh). */
static phks_status compute_simplified(const phks__unit_mesh *um,
                                      const phks_options *opt,
                                      phks_spectrum *spec)
{
    const phks_mesh *mesh = um->mesh;
    const double *area = um->area;
    size_t n = mesh->vertex_count;
    phks__samples samples = {0};
    phks__operator_matrix op = {0};
    double *sample_xyz = NULL, *sample_mass = NULL;
    phks__span at = {opt, PHKS_STAGE_OPERATOR, PHKS__UNIT_MESH_SPAN,
                     0.85 - PHKS__UNIT_MESH_SPAN};
    phks_status st = phks__simplify(um, opt, at, &samples);
    size_t m = samples.count;
    if (st == PHKS_OK) {
        sample_xyz = phks__malloc_array(m, 3 * sizeof *sample_xyz);
        if (!sample_xyz)
            st = phks__fail_oom("spectrum");
    }
    if (st == PHKS_OK) {
        for (size_t s = 0; s < m; s++)
            for (int d = 0; d < 3; d++)
                sample_xyz[3 * s + d] = mesh->xyz[3 * (size_t)samples.vertex[s] + d];
        phks__points points = {sample_xyz, m, um->scale, samples.area,
                               samples.gain};
        phks__span op_at = {opt, PHKS_STAGE_OPERATOR, 0.85, 0.15};
        st = phks__operator_build_points(&points, opt, op_at, &op);
    }
    if (st == PHKS_OK) {
        spec->mass = phks__malloc_array(n, sizeof(double));
        sample_mass = phks__malloc_array(m, sizeof *sample_mass);
        if (!spec->mass || !sample_mass)
            st = phks__fail_oom("spectrum");
    }
    if (st == PHKS_OK) {
        memcpy(sample_mass, op.mass, m * sizeof *sample_mass);
        /* Each vertex's share of its sample's mass: for the literal
         * operator its own area. */
        for (size_t v = 0; v < n; v++) {
            uint32_t s = samples.of_vertex[v];
            spec->mass[v] = area[v] * (sample_mass[s] / samples.area[s]);
        }
        st = solve(&op, opt->eigen_count < m ? opt->eigen_count : m,
                   mesh->component_count, opt, spec);
    }
    phks__operator_release(&op);
    phks__free(sample_xyz);
    if (st == PHKS_OK)
        st = finish_vectors(spec, m, sample_mass, opt);
    if (st == PHKS_OK) {
        st = phks__extension_create(spec, um, &samples, sample_mass);
        sample_mass = NULL; /* handed over, even on failure */
    }
    phks__free(sample_mass);
    phks__samples_release(&samples);
    return st;
}

/* PHKS_QUADRATURE_TRIANGLES on a mesh with long triangles: the operator
 * of the quadrature points (vertices first), its eigenpairs, and their
 * rows at the vertices (docs/method.md section 13). The points' masses are
 * lumped onto the vertices that interpolate them, so spec->mass still sums
 * to the total mass. */
static phks_status compute_quadrature(const phks__unit_mesh *um,
                                      const phks__quadrature *quad,
                                      const phks_options *opt,
                                      phks_spectrum *spec)
{
    phks__operator_matrix op;
    phks__span at = {opt, PHKS_STAGE_OPERATOR, PHKS__UNIT_MESH_SPAN,
                     1 - PHKS__UNIT_MESH_SPAN};
    phks__points points = {quad->xyz, quad->count, um->scale, quad->area,
                           NULL};
    phks_status st = phks__operator_build_points(&points, opt, at, &op);
    if (st != PHKS_OK)
        return st;
    size_t n = spec->n, m = quad->count;
    spec->mass = phks__malloc_array(n, sizeof(double));
    if (!spec->mass)
        st = phks__fail_oom("spectrum");
    if (st == PHKS_OK) {
        phks__quadrature_lump(quad, op.mass, spec->mass);
        st = solve(&op, opt->eigen_count < m ? opt->eigen_count : m,
                   um->mesh->component_count, opt, spec);
    }
    if (st == PHKS_OK)
        st = finish_vectors(spec, m, op.mass, opt);
    phks__operator_release(&op);
    if (st == PHKS_OK) {
        /* the vertices' rows, column by column */
        double *rows = phks__malloc_array(n, spec->count * sizeof(double));
        if (!rows)
            st = phks__fail_oom("spectrum");
        for (size_t e = 0; rows && e < spec->count; e++)
            memcpy(rows + e * n, spec->vectors + e * m, n * sizeof(double));
        if (rows) {
            phks__free(spec->vectors);
            spec->vectors = rows;
        }
    }
    return st;
}

/* The whole mesh's operator and its eigenpairs, into spec (n set). */
static phks_status compute_exact(const phks__unit_mesh *um,
                                 const phks_options *opt, phks_spectrum *spec)
{
    phks__operator_matrix op;
    phks__span at = {opt, PHKS_STAGE_OPERATOR, PHKS__UNIT_MESH_SPAN,
                     1 - PHKS__UNIT_MESH_SPAN};
    if (opt->quadrature == PHKS_QUADRATURE_TRIANGLES) {
        phks__quadrature quad;
        phks_status st = phks__quadrature_build(um, opt, &quad);
        if (st != PHKS_OK)
            return st;
        if (quad.count > quad.vertex_count) {
            st = compute_quadrature(um, &quad, opt, spec);
            phks__quadrature_release(&quad);
            return st;
        }
        /* no long triangle: the vertices' operator, the same bits */
    }
    phks_status st = phks__operator_build(um, opt, at, &op);
    if (st != PHKS_OK)
        return st;
    size_t n = spec->n;
    spec->mass = phks__malloc_array(n, sizeof(double));
    if (!spec->mass)
        st = phks__fail_oom("spectrum");
    if (st == PHKS_OK) {
        memcpy(spec->mass, op.mass, n * sizeof(double));
        st = solve(&op, opt->eigen_count < n ? opt->eigen_count : n,
                   um->mesh->component_count, opt, spec);
    }
    phks__operator_release(&op);
    if (st == PHKS_OK)
        st = finish_vectors(spec, n, spec->mass, opt);
    return st;
}

phks_status phks__spectrum_compute(const phks__unit_mesh *um,
                                   const phks_options *opt,
                                   phks_spectrum **out)
{
    *out = NULL;
    phks_spectrum *spec = phks__calloc(1, sizeof *spec);
    if (!spec)
        return phks__fail_oom("spectrum");
    spec->n = um->mesh->vertex_count;
    spec->options = *opt;
    spec->options.progress = NULL;
    spec->options.progress_user = NULL;
    phks__team *team = phks__team_enter(phks__thread_count(opt));
    phks_status st = phks__simplify_applies(opt, spec->n)
                         ? compute_simplified(um, opt, spec)
                         : compute_exact(um, opt, spec);
    phks__team_leave(team);
    if (st == PHKS_OK)
        st = phks__progress(opt, PHKS_STAGE_EIGEN, 1);
    if (st != PHKS_OK) {
        phks_spectrum_free(spec);
        return st;
    }
    *out = spec;
    return PHKS_OK;
}

phks_status phks__spectrum_unit_mesh(const phks_mesh *mesh,
                                     const phks_options *opt,
                                     phks__unit_mesh *um)
{
    phks__span at = {opt, PHKS_STAGE_OPERATOR, 0, PHKS__UNIT_MESH_SPAN};
    phks_status st = phks__progress(opt, PHKS_STAGE_OPERATOR, 0);
    return st == PHKS_OK
               ? phks__unit_mesh_for(mesh, opt, at, um)
               : st;
}

phks_status phks_spectrum_compute(const phks_mesh *mesh,
                                  const phks_options *options,
                                  phks_spectrum **out)
{
    if (out)
        *out = NULL;
    if (!mesh || !out)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_spectrum_compute: NULL argument");
    phks_options opt;
    phks_status st = phks__options_resolve(options, &opt);
    if (st != PHKS_OK)
        return st;
    phks__unit_mesh um;
    st = phks__spectrum_unit_mesh(mesh, &opt, &um);
    if (st != PHKS_OK)
        return st;
    st = phks__spectrum_compute(&um, &opt, out);
    phks__unit_mesh_release(&um);
    return st;
}

size_t phks_spectrum_count(const phks_spectrum *s) { return s ? s->count : 0; }
size_t phks_spectrum_vertex_count(const phks_spectrum *s) { return s ? s->n : 0; }
const double *phks_spectrum_eigenvalues(const phks_spectrum *s) { return s ? s->values : NULL; }

size_t phks_spectrum_sample_count(const phks_spectrum *s)
{
    return !s ? 0 : s->ext ? s->ext->m : s->n;
}

const uint32_t *phks_spectrum_sample_vertices(const phks_spectrum *s)
{
    return s && s->ext ? s->ext->vertex : NULL;
}

const double *phks_spectrum_mass(const phks_spectrum *s)
{
    return !s ? NULL : s->ext ? s->ext->mass : s->mass;
}

const double *phks_spectrum_eigenvector(const phks_spectrum *s, size_t i)
{
    return s && i < s->count ? s->vectors + i * phks_spectrum_sample_count(s)
                             : NULL;
}
