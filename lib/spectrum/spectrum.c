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

static phks_status solve(const phks__operator_matrix *op, size_t k,
                         const phks_options *opt, double *values,
                         double *vectors)
{
    switch (opt->solver) {
    case PHKS_SOLVER_ARPACK:
        return phks__eigen_arpack(op, k, opt, values, vectors);
    case PHKS_SOLVER_DENSE:
        return phks__eigen_dense(op, k, opt, values, vectors);
    case PHKS_SOLVER_LANCZOS:
        return phks__eigen_lanczos(op, k, opt, values, vectors);
    default:
        if (op->n < AUTO_DENSE_BELOW)
            return phks__eigen_dense(op, k, opt, values, vectors);
        return phks__eigen_lanczos(op, k, opt, values, vectors);
    }
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
static phks_status compute_simplified(const phks_mesh *mesh,
                                      const phks_options *opt,
                                      phks_spectrum *spec)
{
    size_t n = mesh->vertex_count;
    double scale;
    phks__samples samples = {0};
    phks__operator_matrix op = {0};
    double *sample_xyz = NULL, *sample_mass = NULL;
    double *area = phks__malloc_array(n, sizeof *area);
    phks_status st = area ? PHKS_OK : phks__fail_oom("spectrum");
    /* The unit box and the areas: three passes over the triangles, long
     * enough on a large mesh to report (docs/benchmarks.md). */
    if (st == PHKS_OK)
        st = phks__progress(opt, PHKS_STAGE_OPERATOR, 0);
    if (st == PHKS_OK)
        st = phks__unit_box_scale_progress(mesh, (phks_box)opt->box, opt,
                                          PHKS_STAGE_OPERATOR, 0, 0.02, &scale);
    if (st == PHKS_OK)
        st = phks__vertex_areas_progress(mesh, scale, opt, PHKS_STAGE_OPERATOR,
                                        0.02, 0.01, area);
    if (st == PHKS_OK)
        st = phks__simplify(mesh, scale, area, opt, 0.03, 0.82, &samples);
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
        st = phks__point_operator_build(sample_xyz, m, scale, samples.area,
                                       samples.gain, opt, 0.85, 0.15, &op);
    }
    if (st == PHKS_OK) {
        spec->count = opt->eigen_count < m ? opt->eigen_count : m;
        spec->values = phks__malloc_array(spec->count, sizeof(double));
        spec->vectors = phks__malloc_array(m, spec->count * sizeof(double));
        spec->mass = phks__malloc_array(n, sizeof(double));
        sample_mass = phks__malloc_array(m, sizeof *sample_mass);
        if (!spec->values || !spec->vectors || !spec->mass || !sample_mass)
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
        st = solve(&op, spec->count, opt, spec->values, spec->vectors);
    }
    phks__operator_release(&op);
    phks__free(area);
    phks__free(sample_xyz);
    if (st == PHKS_OK)
        st = finish_vectors(spec, m, sample_mass, opt);
    if (st == PHKS_OK) {
        st = phks__extension_create(spec, mesh, scale, &samples, sample_mass);
        sample_mass = NULL; /* handed over, even on failure */
    }
    phks__free(sample_mass);
    phks__samples_release(&samples);
    return st;
}

/* The whole mesh's operator and its eigenpairs, into spec (n set). */
static phks_status compute_exact(const phks_mesh *mesh, const phks_options *opt,
                                 phks_spectrum *spec)
{
    phks__operator_matrix op;
    phks_status st = phks__operator_build(mesh, opt, &op);
    if (st != PHKS_OK)
        return st;
    size_t n = spec->n;
    spec->count = opt->eigen_count < n ? opt->eigen_count : n;
    spec->values = phks__malloc_array(spec->count, sizeof(double));
    spec->vectors = phks__malloc_array(n, spec->count * sizeof(double));
    spec->mass = phks__malloc_array(n, sizeof(double));
    if (!spec->values || !spec->vectors || !spec->mass)
        st = phks__fail_oom("spectrum");
    if (st == PHKS_OK) {
        memcpy(spec->mass, op.mass, n * sizeof(double));
        st = solve(&op, spec->count, opt, spec->values, spec->vectors);
    }
    phks__operator_release(&op);
    if (st == PHKS_OK)
        st = finish_vectors(spec, n, spec->mass, opt);
    return st;
}

/* phks_spectrum_compute on resolved options. */
static phks_status compute(const phks_mesh *mesh, const phks_options *opt,
                           phks_spectrum **out)
{
    phks_spectrum *spec = phks__calloc(1, sizeof *spec);
    if (!spec)
        return phks__fail_oom("spectrum");
    spec->n = mesh->vertex_count;
    spec->options = *opt;
    spec->options.progress = NULL;
    spec->options.progress_user = NULL;
    phks_status st = phks__simplify_applies(opt, spec->n)
                         ? compute_simplified(mesh, opt, spec)
                         : compute_exact(mesh, opt, spec);
    if (st == PHKS_OK)
        st = phks__progress(opt, PHKS_STAGE_EIGEN, 1);
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
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_spectrum_compute: NULL argument");
    phks_options opt;
    phks_status st = phks__options_resolve(options, &opt);
    if (st != PHKS_OK)
        return st;
    phks__team *team = phks__team_enter(phks__thread_count(&opt));
    st = compute(mesh, &opt, out);
    phks__team_leave(team);
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
