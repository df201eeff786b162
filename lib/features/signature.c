/*
 * signature.c - the pipeline's last steps: the persistent maxima of HKS at
 * the feature scale become the feature points, and each gets the vector of
 * its HKS values at the time scales.
 */
#include "features/features.h"

#include <float.h>
#include <math.h>
#include <string.h>

void phks_signature_free(phks_signature *sig)
{
    if (!sig)
        return;
    phks__free(sig->vertex);
    phks__free(sig->position);
    phks__free(sig->persistence);
    phks__free(sig->vectors);
    phks__free(sig->geodesic);
    phks__free(sig->boundary);
    phks__free(sig->spin);
    phks__free(sig);
}

phks_status phks__signature_alloc(size_t count, size_t samples, size_t length,
                                  phks_signature **out)
{
    phks_signature *sig = phks__calloc(1, sizeof *sig);
    if (!sig)
        return phks__fail_oom("signature");
    sig->count = count;
    sig->samples = samples;
    sig->length = length;
    size_t points = count + samples;
    sig->vertex = phks__malloc_array(points, sizeof *sig->vertex);
    sig->position = phks__malloc_array(points, 3 * sizeof *sig->position);
    sig->persistence = phks__malloc_array(points, sizeof *sig->persistence);
    sig->vectors = phks__malloc_array(points, length * sizeof *sig->vectors);
    if (!sig->vertex || !sig->position || !sig->persistence || !sig->vectors) {
        phks_signature_free(sig);
        return phks__fail_oom("signature");
    }
    *out = sig;
    return PHKS_OK;
}

phks_status phks__signature_alloc_layout(phks_signature *sig)
{
    size_t points = phks__signature_points(sig), pairs = phks__pair_count(points);
    sig->geodesic = phks__malloc_array(pairs ? pairs : 1, sizeof *sig->geodesic);
    sig->boundary = phks__malloc_array(points, sizeof *sig->boundary);
    if (sig->options.local_descriptor == PHKS_LOCAL_DESCRIPTOR_SPIN)
        sig->spin = phks__calloc(points ? points : 1, PHKS__SPIN_BYTES);
    bool spin_ok = sig->spin ||
                   sig->options.local_descriptor != PHKS_LOCAL_DESCRIPTOR_SPIN;
    return sig->geodesic && sig->boundary && spin_ok
               ? PHKS_OK
               : phks__fail_oom("signature layout");
}

/* The spectrum must come from the same operator as the options describe;
 * anything else would silently mix incomparable numbers. */
static phks_status check_spectrum(const char *fn, const phks_mesh *mesh,
                                  const phks_spectrum *spec,
                                  const phks_options *opt)
{
    if (spec->n != mesh->vertex_count)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "%s: the spectrum has %zu vertices, the mesh %zu",
                         fn, spec->n, mesh->vertex_count);
    char detail[128];
    if (phks__options_difference(opt, &spec->options, true, detail,
                                 sizeof detail))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "%s: the options differ from those the spectrum "
                         "was computed with (%s)",
                         fn, detail);
    return PHKS_OK;
}

/* The factor that turns HKS_t into the mean-scaled HKS: total mass over
 * the heat trace, the inverse of the mass-weighted mean of HKS_t (the
 * eigenvectors are mass-orthonormal). 1 for the other scalings. */
static double hks_factor(const phks_spectrum *spec, const phks_options *opt,
                         double t)
{
    if (opt->hks_scaling != PHKS_HKS_SCALING_MEAN)
        return 1;
    double mass = 0, trace = 0;
    for (size_t v = 0; v < spec->n; v++)
        mass += spec->mass[v];
    for (size_t i = 0; i < spec->count; i++)
        trace += exp(-t * spec->values[i]);
    return mass / trace;
}

/* The local areas of features [begin, end), for phks__run_batched. */
typedef struct {
    phks__surface surface;
    const phks_signature *sig;
    const double *radius2;
    double *area; /* sig->count x sig->length */
} areas_ctx;

static void areas_range(void *ctx, size_t begin, size_t end)
{
    const areas_ctx *c = ctx;
    /* begin and end count points, features and samples alike. */
    for (size_t i = begin; i < end; i++)
        phks__local_areas(&c->surface, c->sig->vertex[i], c->radius2,
                          c->sig->length, c->area + i * c->sig->length);
}

/* A_t of every feature point for PHKS_HKS_SCALING_LOCAL_AREA into area
 * (sig->count x scale_count), positions scaled by the unit box's `scale`,
 * the features spread over opt->threads and progress reported
 * (PHKS_STAGE_PERSISTENCE, 0.95 to 1) between batches: each feature point
 * scans every vertex, too long on a large mesh to go without reports
 * (docs/benchmarks.md). */
static phks_status local_areas(const phks__unit_mesh *um,
                               const phks_options *opt,
                               const phks_signature *sig,
                               const double *radius2, double *area)
{
    /* A_t is a quadrature of the surface too: with
     * PHKS_QUADRATURE_TRIANGLES the corner of a face of two long triangles
     * has the area of the face within sqrt(4t) around it, not the third
     * of the whole face its vertex carries (docs/method.md section 13). */
    phks__quadrature quad = {0};
    if (opt->quadrature == PHKS_QUADRATURE_TRIANGLES) {
        phks_status st = phks__quadrature_build(um, opt, &quad);
        if (st != PHKS_OK)
            return st;
    }
    /* The quadrature's first points are the mesh's vertices, in order. */
    phks__surface surface = {um->mesh->xyz, um->area, um->mesh->vertex_count,
                             um->scale};
    if (quad.count > quad.vertex_count)
        surface = (phks__surface){quad.xyz, quad.area, quad.count, um->scale};
    areas_ctx c = {surface, sig, radius2, area};
    unsigned threads = phks__thread_count(opt);
    phks__span at = {opt, PHKS_STAGE_PERSISTENCE, 0.95, 0.05};
    size_t points = phks__signature_points(sig);
    phks_status st = phks__run_batched(points, threads, areas_range, &c, at,
                                       (points + threads - 1) / threads);
    phks__quadrature_release(&quad);
    return st;
}

/* The feature vectors of sig's points: HKS at each time scale, scaled as
 * opt->hks_scaling says. With LOCAL_AREA each value becomes
 * log(HKS_t A_t / (4 pi t)), A_t the area within sqrt(4 t) of the point
 * (local_area.c), t in the unit box: -log(4 pi t) on a plane, where
 * HKS_t A_t is 1 (a constant per scale, which every L1 distance cancels;
 * docs/method.md section 9); the logarithm weighs
 * every scale alike, where the plain values fall from about 80 at 5 tau
 * to about 1 at 1000 tau and the first scales would decide the L1
 * distance alone. */
static phks_status feature_vectors(const phks__unit_mesh *um,
                                   const phks_spectrum *spec,
                                   const phks_options *opt,
                                   phks_signature *sig)
{
    size_t S = opt->scale_count;
    double factors[PHKS_MAX_SCALES], radius2[PHKS_MAX_SCALES];
    for (size_t s = 0; s < S; s++) {
        factors[s] = hks_factor(spec, opt, opt->scales[s] * opt->tau);
        radius2[s] = 4 * opt->scales[s] * opt->tau;
    }
    bool local = opt->hks_scaling == PHKS_HKS_SCALING_LOCAL_AREA;
    size_t points = phks__signature_points(sig);
    double *area = NULL;
    if (local && points) {
        area = phks__malloc_array(points, S * sizeof *area);
        if (!area)
            return phks__fail_oom("feature vectors");
        phks_status st = local_areas(um, opt, sig, radius2, area);
        if (st != PHKS_OK) {
            phks__free(area);
            return st;
        }
    }
    for (size_t i = 0; i < points; i++) {
        uint32_t v = sig->vertex[i];
        double *out = sig->vectors + i * S;
        for (size_t s = 0; s < S; s++) {
            double h = phks__hks_at(spec, opt->scales[s] * opt->tau, v) * factors[s];
            /* HKS is positive and the point's own area is in A_t; the
             * floor only keeps a rounding-level zero finite. */
            out[s] = local ? log(fmax(h * area[i * S + s] / (PHKS__PI * radius2[s]),
                                      DBL_MIN))
                           : h;
            /* A sample is stored as a float (signature_codec.c): the
             * numbers in memory are those a blob gives back. */
            if (i >= sig->count)
                out[s] = (float)out[s];
        }
    }
    phks__free(area);
    return PHKS_OK;
}

/* Whether taper_at_boundary changes anything. */
static bool tapers(const phks_mesh *mesh, const phks_options *opt)
{
    return opt->boundary_margin != 0 && mesh->boundary_edge_count != 0;
}

/* Progress in PHKS_STAGE_PERSISTENCE: the unit box's scale and areas
 * (which the taper and the local areas need), when the caller did not
 * hand them down, from 0 to SCALE_SPAN, the taper's distances up to
 * TAPER_SPAN. */
#define SCALE_SPAN 0.05
#define TAPER_SPAN 0.3

/* Tapers h to zero at the mesh boundary: h(v) (1 - exp(-(d(v) / m)^2)),
 * d the distance to the boundary in the unit box (positions times
 * `scale`), m the margin. A cut piece's HKS rises towards the cut (heat
 * that would have crossed it stays), so without this every maximum of a
 * partial scan sits on its silhouette; with it, the boundary is a minimum
 * and the maxima are those the piece shares with its whole. */
static phks_status taper_at_boundary(const phks__unit_mesh *um,
                                     const phks_options *opt, double *h)
{
    const phks_mesh *mesh = um->mesh;
    if (!tapers(mesh, opt))
        return PHKS_OK;
    double m = opt->boundary_margin * sqrt(4 * opt->feature_scale * opt->tau);
    double *d = phks__malloc_array(mesh->vertex_count, sizeof *d);
    if (!d)
        return phks__fail_oom("boundary taper");
    /* Beyond 6 m the taper differs from 1 by less than e^-36. */
    phks__span at = {opt, PHKS_STAGE_PERSISTENCE, SCALE_SPAN,
                     TAPER_SPAN - SCALE_SPAN};
    phks_status st = phks__boundary_distance(um, 6 * m, at, d);
    for (size_t v = 0; st == PHKS_OK && v < mesh->vertex_count; v++)
        h[v] *= -expm1(-(d[v] / m) * (d[v] / m));
    phks__free(d);
    return st;
}

/* PHKS__SAMPLES vertices spread away from the maxima (fewer on a mesh
 * with fewer vertices). */
static phks_status spread_after(const phks__unit_mesh *um,
                                const phks_maximum *maxima, size_t found,
                                uint32_t spread[PHKS__SAMPLES], size_t *samples)
{
    uint32_t *given = phks__malloc_array(found + 1, sizeof *given);
    if (!given)
        return phks__fail_oom("spread samples");
    for (size_t i = 0; i < found; i++)
        given[i] = maxima[i].vertex;
    phks_status st = phks__spread_vertices(um, given, found, PHKS__SAMPLES,
                                           spread, samples);
    phks__free(given);
    return st;
}

/* The signature of the points `maxima` (found of them, vertices of
 * um->mesh): the spread samples with PHKS_MATCHING_VERIFIED, the vectors
 * and the layout, progress from 0.95 of PHKS_STAGE_PERSISTENCE on.
 * Shared by the persistent maxima and the caller's own vertices, so that
 * the two make the same numbers for the same points. */
static phks_status signature_of(const phks__unit_mesh *um,
                                const phks_spectrum *spec,
                                const phks_options *opt,
                                const phks_maximum *maxima, size_t found,
                                phks_signature **out)
{
    const phks_mesh *mesh = um->mesh;
    size_t samples = 0;
    uint32_t spread[PHKS__SAMPLES];
    phks_signature *sig = NULL;
    bool verified = opt->matching == PHKS_MATCHING_VERIFIED;
    phks_status st = PHKS_OK;
    if (verified)
        st = spread_after(um, maxima, found, spread, &samples);
    if (st == PHKS_OK)
        st = phks__signature_alloc(found, samples, opt->scale_count, &sig);
    if (st != PHKS_OK)
        return st;
    sig->options = *opt;
    sig->unit_scale = um->scale;
    sig->options.progress = NULL;
    sig->options.progress_user = NULL;
    for (size_t i = 0; i < found; i++) {
        uint32_t v = maxima[i].vertex;
        sig->vertex[i] = v;
        memcpy(sig->position + 3 * i, mesh->xyz + 3 * (size_t)v, 3 * sizeof(double));
        sig->persistence[i] = maxima[i].persistence;
    }
    for (size_t i = 0; i < samples; i++) {
        sig->vertex[found + i] = spread[i];
        for (int d = 0; d < 3; d++)
            sig->position[3 * (found + i) + d] =
                (float)mesh->xyz[3 * (size_t)spread[i] + d];
        sig->persistence[found + i] = 0;
    }
    st = feature_vectors(um, spec, opt, sig);
    if (st == PHKS_OK && verified)
        st = phks__signature_layout(um, opt, sig);
    if (st == PHKS_OK && sig->spin)
        st = phks__spin_images(um, sig->vertex, phks__signature_points(sig),
                               sig->spin);
    sig->has_shape = verified && opt->global_descriptor ==
                                     PHKS_GLOBAL_DESCRIPTOR_D2;
    if (st == PHKS_OK && sig->has_shape)
        st = phks__shape_distribution(um, sig->shape);
    if (st == PHKS_OK)
        st = phks__progress(opt, PHKS_STAGE_PERSISTENCE, 1);
    if (st != PHKS_OK) {
        phks_signature_free(sig);
        return st;
    }
    *out = sig;
    return PHKS_OK;
}

/* phks_signature_from_spectrum on resolved options and a checked
 * spectrum. The unit box's scale and areas come from `given`, or, when it
 * is NULL, are computed here where the taper or the local areas need
 * them. */
static phks_status from_spectrum(const phks_mesh *mesh,
                                 const phks__unit_mesh *given,
                                 const phks_spectrum *spec,
                                 const phks_options *opt,
                                 phks_signature **out)
{
    phks__unit_mesh own = {mesh, 1, NULL};
    const phks__unit_mesh *um = given ? given : &own;
    double from = 0;
    size_t n = mesh->vertex_count, wanted = opt->feature_count;
    if (wanted > mesh->triangle_count)
        wanted = mesh->triangle_count;
    double *h = phks__malloc_array(n, sizeof *h);
    phks_maximum *maxima = NULL;
    size_t found = 0;
    phks_status st;
    if (!h) {
        st = phks__fail_oom("signature");
        goto done;
    }
    double t_feature = opt->feature_scale * opt->tau;
    st = phks__hks_all(spec, t_feature, opt, h);
    double factor = hks_factor(spec, opt, t_feature);
    for (size_t v = 0; v < n; v++)
        h[v] *= factor;
    if (st == PHKS_OK)
        st = phks__progress(opt, PHKS_STAGE_PERSISTENCE, 0);
    if (st == PHKS_OK && !given &&
        (tapers(mesh, opt) || opt->hks_scaling == PHKS_HKS_SCALING_LOCAL_AREA ||
         opt->matching == PHKS_MATCHING_VERIFIED)) {
        phks__span at = {opt, PHKS_STAGE_PERSISTENCE, 0, SCALE_SPAN};
        st = phks__unit_mesh_for(mesh, opt, at, &own);
        from = SCALE_SPAN;
    }
    if (st == PHKS_OK)
        st = taper_at_boundary(um, opt, h);
    maxima = st == PHKS_OK ? phks__malloc_array(wanted, sizeof *maxima) : NULL;
    if (st == PHKS_OK && !maxima)
        st = phks__fail_oom("feature points");
    /* The persistence up to 0.95, the feature vectors after. */
    if (tapers(mesh, opt))
        from = TAPER_SPAN;
    phks__span at = {opt, PHKS_STAGE_PERSISTENCE, from, 0.95 - from};
    if (st == PHKS_OK)
        st = phks__persistence_run(mesh, h, wanted, 0, at, maxima, &found,
                                   NULL);
    if (st == PHKS_OK)
        st = signature_of(um, spec, opt, maxima, found, out);
done:
    phks__unit_mesh_release(&own);
    phks__free(h);
    phks__free(maxima);
    return st;
}

phks_status phks_signature_from_spectrum(const phks_mesh *mesh,
                                         const phks_spectrum *spec,
                                         const phks_options *options,
                                         phks_signature **out)
{
    if (out)
        *out = NULL;
    if (!mesh || !spec || !out)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_signature_from_spectrum: NULL argument");
    phks_options opt;
    phks_status st = phks__options_resolve(options, &opt);
    if (st == PHKS_OK)
        st = check_spectrum("phks_signature_from_spectrum", mesh, spec, &opt);
    if (st == PHKS_OK)
        st = phks__progress(&opt, PHKS_STAGE_HKS, 0);
    if (st != PHKS_OK)
        return st;
    return from_spectrum(mesh, NULL, spec, &opt, out);
}

#define AT_VERTICES "phks_signature_at_vertices"

/* The caller's points: 1..feature_count of them, each a vertex of the
 * mesh, none twice (two features at one vertex would be a pair at
 * distance zero, which no correspondence can verify). */
static phks_status check_vertices(const phks_mesh *mesh,
                                  const phks_options *opt,
                                  const uint32_t *vertices, size_t count)
{
    if (count == 0 || count > opt->feature_count)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         AT_VERTICES ": %zu vertices, not 1..%u "
                         "(options->feature_count)",
                         count, opt->feature_count);
    size_t n = mesh->vertex_count;
    unsigned char *seen = phks__calloc(n ? n : 1, 1);
    if (!seen)
        return phks__fail_oom(AT_VERTICES);
    phks_status st = PHKS_OK;
    for (size_t i = 0; st == PHKS_OK && i < count; i++) {
        uint32_t v = vertices[i];
        if (v >= n)
            st = phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                            AT_VERTICES ": vertex %u (entry %zu) is out of "
                            "range (%zu vertices)", v, i, n);
        else if (seen[v])
            st = phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                            AT_VERTICES ": vertex %u is given twice (entry "
                            "%zu)", v, i);
        else
            seen[v] = 1;
    }
    phks__free(seen);
    return st;
}

/* phks_signature_at_vertices on resolved options and checked arguments:
 * the points stand where from_spectrum's maxima would, with persistence
 * 0 since no region merging ranked them. */
static phks_status at_vertices(const phks_mesh *mesh, const phks_spectrum *spec,
                               const phks_options *opt,
                               const uint32_t *vertices, size_t count,
                               phks_signature **out)
{
    phks__unit_mesh own = {mesh, 1, NULL};
    phks_maximum *points = phks__malloc_array(count, sizeof *points);
    if (!points)
        return phks__fail_oom(AT_VERTICES);
    for (size_t i = 0; i < count; i++)
        points[i] = (phks_maximum){vertices[i], UINT32_MAX, 0, 0};
    phks_status st = phks__progress(opt, PHKS_STAGE_PERSISTENCE, 0);
    if (st == PHKS_OK && (opt->hks_scaling == PHKS_HKS_SCALING_LOCAL_AREA ||
                          opt->matching == PHKS_MATCHING_VERIFIED)) {
        phks__span at = {opt, PHKS_STAGE_PERSISTENCE, 0, SCALE_SPAN};
        st = phks__unit_mesh_for(mesh, opt, at, &own);
    }
    if (st == PHKS_OK)
        st = signature_of(&own, spec, opt, points, count, out);
    phks__unit_mesh_release(&own);
    phks__free(points);
    return st;
}

phks_status phks_signature_at_vertices(const phks_mesh *mesh,
                                       const phks_spectrum *spectrum,
                                       const phks_options *options,
                                       const uint32_t *vertices, size_t count,
                                       phks_signature **out)
{
    if (out)
        *out = NULL;
    if (!mesh || !spectrum || !vertices || !out)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         AT_VERTICES ": NULL argument");
    phks_options opt;
    phks_status st = phks__options_resolve(options, &opt);
    if (st == PHKS_OK)
        st = check_spectrum(AT_VERTICES, mesh, spectrum, &opt);
    if (st == PHKS_OK)
        st = check_vertices(mesh, &opt, vertices, count);
    if (st == PHKS_OK)
        st = phks__progress(&opt, PHKS_STAGE_HKS, 0);
    if (st != PHKS_OK)
        return st;
    return at_vertices(mesh, spectrum, &opt, vertices, count, out);
}

phks_status phks_signature_compute(const phks_mesh *mesh,
                                   const phks_options *options,
                                   phks_signature **out)
{
    if (out)
        *out = NULL;
    if (!mesh || !out)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_signature_compute: NULL argument");
    phks_options opt;
    phks_status st = phks__options_resolve(options, &opt);
    if (st != PHKS_OK)
        return st;
    /* The unit box and the areas once, for the operator, the taper and
     * the local areas alike. */
    phks__unit_mesh um;
    phks_spectrum *spec = NULL;
    st = phks__spectrum_unit_mesh(mesh, &opt, &um);
    if (st != PHKS_OK)
        return st;
    st = phks__spectrum_compute(&um, &opt, &spec);
    if (st == PHKS_OK)
        st = phks__progress(&opt, PHKS_STAGE_HKS, 0);
    if (st == PHKS_OK)
        st = from_spectrum(mesh, &um, spec, &opt, out);
    phks_spectrum_free(spec);
    phks__unit_mesh_release(&um);
    return st;
}

size_t phks_signature_feature_count(const phks_signature *s) { return s ? s->count : 0; }
size_t phks_signature_sample_count(const phks_signature *s) { return s ? s->samples : 0; }
size_t phks_signature_vector_length(const phks_signature *s) { return s ? s->length : 0; }

uint32_t phks_signature_feature_vertex(const phks_signature *s, size_t i)
{
    return s && i < phks__signature_points(s) ? s->vertex[i] : UINT32_MAX;
}

phks_status phks_signature_feature_position(const phks_signature *s, size_t i,
                                            double xyz[3])
{
    if (!s || !xyz || i >= phks__signature_points(s))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_signature_feature_position: no feature %zu", i);
    memcpy(xyz, s->position + 3 * i, 3 * sizeof(double));
    return PHKS_OK;
}

double phks_signature_feature_persistence(const phks_signature *s, size_t i)
{
    return s && i < phks__signature_points(s) ? s->persistence[i] : NAN;
}

const double *phks_signature_feature_vector(const phks_signature *s, size_t i)
{
    return s && i < phks__signature_points(s) ? s->vectors + i * s->length : NULL;
}

phks_status phks_signature_options(const phks_signature *s, phks_options *options)
{
    if (!s || !options)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_signature_options: NULL argument");
    *options = s->options;
    return PHKS_OK;
}
