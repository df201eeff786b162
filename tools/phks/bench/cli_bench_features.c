/*
 * cli_bench_features.c - the comparison rows of `phks bench` (docs/cli.md,
 * "bench"; the paper's Table 5 and its EVD): feature points at the
 * persistent maxima of the average geodesic distance (AGD) or of Gaussian
 * curvature (GC) instead of HKS, with the same vectors and score; and an
 * eigenvalue descriptor, a ranking by the first eigenvalues alone.
 */
#include "bench/cli_bench_parts.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#define TWO_PI 6.283185307179586476925

const char *const bench_feature_name[BENCH_FEATURES_COUNT] = {"hks", "agd",
                                                              "gc"};

/* ---- feature functions --------------------------------------------------- */
/* AGD(v), the mean distance along the surface from v to the sources, into
 * f. The sources are spread by farthest-point sampling along the surface
 * (each the vertex farthest from those before it, the first vertex 0), so
 * each stands for about the same area and the plain mean approximates the
 * area-weighted one without weights. Each source's distances serve the
 * mean and the choice of the next source alike. Pieces out of each
 * other's reach are INFINITY apart: such a source leaves v's mean alone,
 * and the next source goes to an unreached piece first. */
static phks_status average_geodesic(const phks_mesh *mesh,
                                    const phks_options *o, double *f)
{
    size_t n = phks_mesh_vertex_count(mesh);
    double *d = malloc(n * sizeof *d), *nearest = malloc(n * sizeof *nearest);
    size_t *reached = calloc(n, sizeof *reached);
    phks_status st = d && nearest && reached ? PHKS_OK
                                             : PHKS_ERROR_OUT_OF_MEMORY;
    for (size_t v = 0; v < n; v++) {
        f[v] = 0;
        if (nearest)
            nearest[v] = INFINITY;
    }
    uint32_t source = 0;
    for (int k = 0; st == PHKS_OK && k < BENCH_AGD_SOURCES; k++) {
        st = phks_mesh_geodesic_distances(mesh, o, source, d);
        for (size_t v = 0; st == PHKS_OK && v < n; v++) {
            if (isfinite(d[v])) {
                f[v] += d[v];
                reached[v]++;
            }
            nearest[v] = fmin(nearest[v], d[v]);
        }
        for (size_t v = 0; st == PHKS_OK && v < n; v++)
            if (nearest[v] > nearest[source])
                source = (uint32_t)v;
        if (!(nearest[source] > 0))
            break;  /* every vertex is a source */
    }
    for (size_t v = 0; st == PHKS_OK && v < n; v++)
        f[v] = reached[v] ? f[v] / (double)reached[v] : 0;
    free(d);
    free(nearest);
    free(reached);
    return st;
}

/* The angle at corner `at` of the triangle (at, p, q); *cross gets the
 * length of the cross product of its sides, twice the triangle's area. */
static double corner(const double *at, const double *p, const double *q,
                     double *cross)
{
    double a[3], b[3], c[3];
    for (int i = 0; i < 3; i++) {
        a[i] = p[i] - at[i];
        b[i] = q[i] - at[i];
    }
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
    *cross = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    return atan2(*cross, a[0] * b[0] + a[1] * b[1] + a[2] * b[2]);
}

/* GC(v): the angle defect 2 pi - (the angles of v's triangles at v) over
 * a third of their area (Meyer et al.'s discrete Gaussian curvature with
 * the barycentric area), into f. A boundary vertex has no full ring of
 * angles: its defect measures the cut, not the surface, so it gets 0, as
 * does a vertex without area. */
static phks_status gaussian_curvature(const phks_mesh *mesh, double *f)
{
    size_t n = phks_mesh_vertex_count(mesh), m = phks_mesh_triangle_count(mesh);
    const double *xyz = phks_mesh_vertices(mesh);
    const uint32_t *t = phks_mesh_triangles(mesh);
    const uint32_t *edge = phks_mesh_boundary_edges(mesh);
    double *area = calloc(n, sizeof *area);
    if (!area)
        return PHKS_ERROR_OUT_OF_MEMORY;
    for (size_t v = 0; v < n; v++)
        f[v] = TWO_PI;
    for (size_t j = 0; j < m; j++) {
        const double *p[3];
        for (int c = 0; c < 3; c++)
            p[c] = xyz + 3 * (size_t)t[3 * j + c];
        for (int c = 0; c < 3; c++) {
            double cross;
            uint32_t v = t[3 * j + c];
            f[v] -= corner(p[c], p[(c + 1) % 3], p[(c + 2) % 3], &cross);
            area[v] += cross / 6;
        }
    }
    for (size_t e = 0; e < 2 * phks_mesh_boundary_edge_count(mesh); e++)
        area[edge[e]] = 0;
    for (size_t v = 0; v < n; v++)
        f[v] = area[v] > 0 ? f[v] / area[v] : 0;
    free(area);
    return PHKS_OK;
}

/* The signature at the persistent maxima of f: as many as the library
 * takes of HKS (feature_count, at most one per triangle; threshold 0). */
static phks_status at_maxima(const phks_mesh *mesh, const phks_spectrum *spec,
                             const phks_options *o, const double *f,
                             phks_signature **sig)
{
    size_t wanted = o->feature_count, count = 0;
    if (wanted > phks_mesh_triangle_count(mesh))
        wanted = phks_mesh_triangle_count(mesh);
    phks_maximum *max = malloc((wanted + 1) * sizeof *max);
    uint32_t *vertex = malloc((wanted + 1) * sizeof *vertex);
    phks_status st = max && vertex ? phks_persistent_maxima(mesh, f, wanted, 0,
                                                           max, &count, NULL)
                                   : PHKS_ERROR_OUT_OF_MEMORY;
    /* Pieces that touch at one vertex keep a maximum each, and that
     * vertex may be the maximum of both: it is one feature point. */
    size_t kept = 0;
    for (size_t i = 0; st == PHKS_OK && i < count; i++) {
        size_t j = 0;
        while (j < kept && vertex[j] != max[i].vertex)
            j++;
        if (j == kept)
            vertex[kept++] = max[i].vertex;
    }
    if (st == PHKS_OK)
        st = phks_signature_at_vertices(mesh, spec, o, vertex, kept, sig);
    free(max);
    free(vertex);
    return st;
}

static phks_status feature_signature(const bench_plan *p, int features,
                                     const phks_mesh *mesh,
                                     const phks_spectrum *spec,
                                     phks_signature **sig)
{
    if (features == BENCH_FEATURES_HKS)
        return phks_signature_from_spectrum(mesh, spec, &p->options, sig);
    size_t n = phks_mesh_vertex_count(mesh);
    double *f = malloc((n + 1) * sizeof *f);
    phks_status st = !f ? PHKS_ERROR_OUT_OF_MEMORY
                     : features == BENCH_FEATURES_AGD
                         ? average_geodesic(mesh, &p->options, f)
                         : gaussian_curvature(mesh, f);
    if (st == PHKS_OK)
        st = at_maxima(mesh, spec, &p->options, f, sig);
    free(f);
    return st;
}

/* ---- the eigenvalue descriptor ------------------------------------------ */
/* The first BENCH_EVD_COUNT nonzero eigenvalues, or NULL when there are
 * fewer. Zero is the library's equality of eigenvalues, 1e-6 / tau
 * (phks.h, phks_spectrum_compute): one zero per piece of the kernel's
 * graph, which says how many pieces, not what shape. */
static double *evd_values(const phks_spectrum *spec, const phks_options *o)
{
    const double *lambda = phks_spectrum_eigenvalues(spec);
    size_t count = phks_spectrum_count(spec), k = 0;
    double *v = malloc(BENCH_EVD_COUNT * sizeof *v);
    for (size_t i = 0; v && i < count && k < BENCH_EVD_COUNT; i++)
        if (lambda[i] > 1e-6 / o->tau)
            v[k++] = lambda[i];
    if (k < BENCH_EVD_COUNT) {
        free(v);
        return NULL;
    }
    return v;
}

phks_status bench_outputs_compute(const bench_plan *p, const phks_mesh *mesh,
                                  unsigned features, int evd,
                                  bench_outputs *out)
{
    if (features == 1u << BENCH_FEATURES_HKS && !evd)
        return phks_signature_compute(mesh, &p->options,
                                      &out->sig[BENCH_FEATURES_HKS]);
    phks_spectrum *spec = NULL;
    phks_status st = phks_spectrum_compute(mesh, &p->options, &spec);
    if (st == PHKS_OK && evd)
        out->evd = evd_values(spec, &p->options);
    for (int f = 0; st == PHKS_OK && f < BENCH_FEATURES_COUNT; f++)
        if (features >> f & 1)
            st = feature_signature(p, f, mesh, spec, &out->sig[f]);
    if (st != PHKS_OK)
        bench_outputs_free(out);
    phks_spectrum_free(spec);
    return st;
}

void bench_outputs_free(bench_outputs *out)
{
    for (int f = 0; f < BENCH_FEATURES_COUNT; f++) {
        phks_signature_free(out->sig[f]);
        out->sig[f] = NULL;
    }
    free(out->evd);
    out->evd = NULL;
}

/* L1: the sum the paper's own score uses for its vectors, and one
 * eigenvalue that a cut moves far weighs less in it than in L2. */
static double evd_distance(const double *a, const double *b)
{
    double d = 0;
    for (int i = 0; i < BENCH_EVD_COUNT; i++)
        d += fabs(a[i] - b[i]);
    return d;
}

typedef struct ranked {
    double distance;
    size_t index;
} ranked;

static int ranked_cmp(const void *x, const void *y)
{
    const ranked *a = x, *b = y;
    if (a->distance != b->distance)
        return a->distance < b->distance ? -1 : 1;
    return (a->index > b->index) - (a->index < b->index);
}

/* The k nearest entries of db by evd_distance, ties to the earlier entry,
 * as phks_db_query's hits (id: the entry's position from 1; score: the
 * distance). */
static phks_status evd_query(const bench_evd_db *db, const double *values,
                             size_t k, phks_hit *hits, size_t *count)
{
    ranked *r = malloc((db->count + 1) * sizeof *r);
    if (!r)
        return PHKS_ERROR_OUT_OF_MEMORY;
    for (size_t i = 0; i < db->count; i++)
        r[i] = (ranked){evd_distance(values, db->entries[i].values), i};
    qsort(r, db->count, sizeof *r, ranked_cmp);
    *count = db->count < k ? db->count : k;
    for (size_t i = 0; i < *count; i++) {
        const bench_evd_entry *e = &db->entries[r[i].index];
        hits[i].id = (int64_t)r[i].index + 1;
        hits[i].score = r[i].distance;
        snprintf(hits[i].name, sizeof hits[i].name, "%s", e->name);
        snprintf(hits[i].label, sizeof hits[i].label, "%s", e->label);
    }
    free(r);
    return PHKS_OK;
}

void bench_evd_add(bench_evd_db *db, const bench_item *it, const char *name,
                   const char *label)
{
    if (db->entries && it->evd)
        db->entries[db->count++] = (bench_evd_entry){it->evd, name, label};
}

phks_status bench_query(const bench_plan *p, phks_db *db,
                        const bench_evd_db *evd, const bench_item *it,
                        size_t depth, phks_hit *hits, size_t *count)
{
    *count = 0;
    if (p->evd)
        return it->evd ? evd_query(evd, it->evd, depth, hits, count)
                       : PHKS_ERROR_INVALID_ARGUMENT;
    return it->sig ? phks_db_query(db, it->sig, depth, hits, count)
                   : PHKS_ERROR_INVALID_ARGUMENT;
}
