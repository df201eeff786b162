/*
 * spectrum.c - from a mesh to its smallest eigenpairs: build the operator,
 * pick a solver, and turn the eigenvectors of the symmetric B back into
 * those of the generalised problem (phi = Mh^-1/2 x). Meshes above
 * options->simplify_above vertices take the HKS-simp path (simp.h): the
 * same steps on the samples, then what the extension needs.
 */
#include "simp.h"

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
    phks_extension_free(spec->ext);
    phks_free(spec);
}

static phks_status run_solver(const phks_operator_matrix *op, size_t k,
                              const phks_options *opt, double *values,
                              double *vectors, double *next)
{
    switch (opt->solver) {
    case PHKS_SOLVER_ARPACK:
        return phks_eigen_arpack(op, k, opt, values, vectors, next);
    case PHKS_SOLVER_DENSE:
        return phks_eigen_dense(op, k, opt, values, vectors, next);
    case PHKS_SOLVER_LANCZOS:
        return phks_eigen_lanczos(op, k, opt, values, vectors, next);
    default:
        if (op->n < AUTO_DENSE_BELOW)
            return phks_eigen_dense(op, k, opt, values, vectors, next);
        return phks_eigen_lanczos(op, k, opt, values, vectors, next);
    }
}

static uint32_t find_root(uint32_t *parent, uint32_t i)
{
    while (parent[i] != i) {
        parent[i] = parent[parent[i]]; /* path halving */
        i = parent[i];
    }
    return i;
}

phks_status phks_operator_components(const phks_operator_matrix *op,
                                     uint32_t **component, size_t *count)
{
    size_t n = op->n;
    uint32_t *parent = phks_malloc_array(n, sizeof *parent);
    *component = parent;
    *count = 0;
    if (!parent)
        return phks_fail_oom("operator components");
    for (size_t i = 0; i < n; i++)
        parent[i] = (uint32_t)i;
    /* union by lower root, so every root is its component's lowest point */
    for (size_t r = 0; r < n; r++)
        for (size_t e = op->row_start[r]; e < op->row_start[r + 1]; e++) {
            if (op->col[e] <= r || op->val[e] == 0)
                continue;
            uint32_t a = find_root(parent, (uint32_t)r);
            uint32_t b = find_root(parent, op->col[e]);
            if (a != b)
                parent[a > b ? a : b] = a < b ? a : b;
        }
    for (size_t i = 0; i < n; i++)
        parent[i] = find_root(parent, (uint32_t)i);
    /* every root is its component's lowest point: in one ascending pass
     * it is numbered before the points that refer to it */
    size_t c = 0;
    for (size_t i = 0; i < n; i++)
        parent[i] = parent[i] == i ? (uint32_t)c++ : parent[parent[i]];
    *count = c;
    return PHKS_OK;
}

phks_status phks_null_space(const phks_operator_matrix *op,
                            const uint32_t *component, size_t count,
                            double *root, double *scale)
{
    for (size_t c = 0; c < count; c++)
        scale[c] = 0;
    for (size_t i = 0; i < op->n; i++) {
        root[i] = sqrt(op->mass[i]);
        scale[component[i]] += op->mass[i];
    }
    for (size_t c = 0; c < count; c++) {
        if (!(scale[c] > 0))
            return phks_fail(PHKS_ERROR_SOLVER,
                             "operator component %zu has no mass", c);
        scale[c] = 1 / sqrt(scale[c]);
    }
    return PHKS_OK;
}

static bool cluster_equal(double a, double b, const phks_options *opt)
{
    return fabs(b - a) <= PHKS_CLUSTER_TOL * fmax(fabs(b), 1 / opt->tau);
}

/* The zero eigenvalue's whole cluster, from op's components (zeros of
 * them), into spec. */
static phks_status null_pairs(const phks_operator_matrix *op,
                              const uint32_t *component, size_t zeros,
                              phks_spectrum *spec)
{
    size_t n = op->n;
    double *root = phks_malloc_array(n, sizeof *root);
    double *scale = phks_malloc_array(zeros, sizeof *scale);
    double *values = phks_realloc_array(spec->values, zeros, sizeof(double));
    if (values)
        spec->values = values;
    double *vectors = phks_realloc_array(spec->vectors, n, zeros * sizeof(double));
    if (vectors)
        spec->vectors = vectors;
    phks_status st = root && scale && values && vectors
                         ? phks_null_space(op, component, zeros, root, scale)
                         : phks_fail_oom("spectrum");
    if (st == PHKS_OK) {
        memset(vectors, 0, n * zeros * sizeof(double));
        for (size_t i = 0; i < n; i++)
            vectors[component[i] * n + i] = root[i] * scale[component[i]];
        for (size_t c = 0; c < zeros; c++)
            values[c] = 0;
        spec->count = zeros;
    }
    phks_free(root);
    phks_free(scale);
    return st;
}

/* The smallest eigenpairs of op's B into spec->values and spec->vectors
 * (op->n rows), spec->count of them: k, less the pairs of a cluster of
 * equal eigenvalues (PHKS_CLUSTER_TOL) that the k-th value would split.
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
static phks_status solve(const phks_operator_matrix *op, size_t k,
                         size_t pieces, const phks_options *opt,
                         phks_spectrum *spec)
{
    size_t n = op->n, zeros = 0;
    uint32_t *component = NULL;
    phks_status st = PHKS_OK;
    if (pieces >= k) {
        st = phks_operator_components(op, &component, &zeros);
        if (st == PHKS_OK && zeros >= k)
            st = null_pairs(op, component, zeros, spec);
        if (st != PHKS_OK || zeros >= k) {
            phks_free(component);
            return st;
        }
    }
    phks_free(component);
    component = NULL;
    spec->values = phks_malloc_array(k, sizeof(double));
    spec->vectors = phks_malloc_array(n, k * sizeof(double));
    if (!spec->values || !spec->vectors)
        return phks_fail_oom("spectrum");
    double next = INFINITY;
    st = run_solver(op, k, opt, spec->values, spec->vectors, &next);
    spec->count = k;
    if (st != PHKS_OK || k == n || !cluster_equal(spec->values[k - 1], next, opt))
        return st;
    if (cluster_equal(0, spec->values[k - 1], opt)) {
        /* the zero cluster reaches past k */
        st = phks_operator_components(op, &component, &zeros);
        if (st == PHKS_OK && zeros >= k)
            st = null_pairs(op, component, zeros, spec);
        /* else eigenvalues within the tolerance of zero but not zero
         * (components joined by a thread of tiny weights): all k kept */
        phks_free(component);
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
    double *root = phks_malloc_array(n, sizeof *root);
    if (!root)
        return phks_fail_oom("spectrum");
    for (size_t i = 0; i < n; i++)
        root[i] = sqrt(mass[i]);
    finish_ctx f = {spec->vectors, n, root};
    phks_parallel_for(spec->count, phks_thread_count(opt), finish_range, &f);
    phks_free(root);
    return PHKS_OK;
}

/* HKS-simp: samples, their operator and eigenpairs, and the extension
 * data. Progress: the sampling and the samples' operator are the operator
 * stage (the sampling takes most of it on a large mesh). */
static phks_status compute_simplified(const phks_mesh *mesh,
                                      const phks_options *opt,
                                      phks_spectrum *spec)
{
    size_t n = mesh->vertex_count;
    double scale;
    phks_samples samples = {0};
    phks_operator_matrix op = {0};
    double *sample_xyz = NULL, *sample_mass = NULL;
    double *area = phks_malloc_array(n, sizeof *area);
    phks_status st = area ? PHKS_OK : phks_fail_oom("spectrum");
    /* The unit box and the areas: three passes over the triangles, a
     * few tenths of a second on a million vertices. */
    if (st == PHKS_OK)
        st = phks_progress(opt, PHKS_STAGE_OPERATOR, 0);
    if (st == PHKS_OK)
        st = phks_unit_box_scale_progress(mesh, (phks_box)opt->box, opt,
                                          PHKS_STAGE_OPERATOR, 0, 0.02, &scale);
    if (st == PHKS_OK)
        st = phks_vertex_areas_progress(mesh, scale, opt, PHKS_STAGE_OPERATOR,
                                        0.02, 0.01, area);
    if (st == PHKS_OK)
        st = phks_simplify(mesh, scale, area, opt, 0.03, 0.82, &samples);
    size_t m = samples.count;
    if (st == PHKS_OK) {
        sample_xyz = phks_malloc_array(m, 3 * sizeof *sample_xyz);
        if (!sample_xyz)
            st = phks_fail_oom("spectrum");
    }
    if (st == PHKS_OK) {
        for (size_t s = 0; s < m; s++)
            for (int d = 0; d < 3; d++)
                sample_xyz[3 * s + d] = mesh->xyz[3 * (size_t)samples.vertex[s] + d];
        st = phks_point_operator_build(sample_xyz, m, scale, samples.area,
                                       samples.gain, opt, 0.85, 0.15, &op);
    }
    if (st == PHKS_OK) {
        spec->mass = phks_malloc_array(n, sizeof(double));
        sample_mass = phks_malloc_array(m, sizeof *sample_mass);
        if (!spec->mass || !sample_mass)
            st = phks_fail_oom("spectrum");
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
    phks_operator_release(&op);
    phks_free(area);
    phks_free(sample_xyz);
    if (st == PHKS_OK)
        st = finish_vectors(spec, m, sample_mass, opt);
    if (st == PHKS_OK) {
        st = phks_extension_create(spec, mesh, scale, &samples, sample_mass);
        sample_mass = NULL; /* handed over, even on failure */
    }
    phks_free(sample_mass);
    phks_samples_release(&samples);
    return st;
}

/* The whole mesh's operator and its eigenpairs, into spec (n set). */
static phks_status compute_exact(const phks_mesh *mesh, const phks_options *opt,
                                 phks_spectrum *spec)
{
    phks_operator_matrix op;
    phks_status st = phks_operator_build(mesh, opt, &op);
    if (st != PHKS_OK)
        return st;
    size_t n = spec->n;
    spec->mass = phks_malloc_array(n, sizeof(double));
    if (!spec->mass)
        st = phks_fail_oom("spectrum");
    if (st == PHKS_OK) {
        memcpy(spec->mass, op.mass, n * sizeof(double));
        st = solve(&op, opt->eigen_count < n ? opt->eigen_count : n,
                   mesh->component_count, opt, spec);
    }
    phks_operator_release(&op);
    if (st == PHKS_OK)
        st = finish_vectors(spec, n, spec->mass, opt);
    return st;
}

/* phks_spectrum_compute on resolved options. */
static phks_status compute(const phks_mesh *mesh, const phks_options *opt,
                           phks_spectrum **out)
{
    phks_spectrum *spec = phks_calloc(1, sizeof *spec);
    if (!spec)
        return phks_fail_oom("spectrum");
    spec->n = mesh->vertex_count;
    spec->options = *opt;
    spec->options.progress = NULL;
    spec->options.progress_user = NULL;
    phks_status st = phks_simplify_applies(opt, spec->n)
                         ? compute_simplified(mesh, opt, spec)
                         : compute_exact(mesh, opt, spec);
    if (st == PHKS_OK)
        st = phks_progress(opt, PHKS_STAGE_EIGEN, 1);
    if (st != PHKS_OK) {
        phks_spectrum_free(spec);
        return st;
    }
    *out = spec;
    return PHKS_OK;
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
    phks_team *team = phks_team_enter(phks_thread_count(&opt));
    st = compute(mesh, &opt, out);
    phks_team_leave(team);
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
