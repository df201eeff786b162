/*
 * normalize.c - scaling to the unit box, and vertex masses. tau = 0.0002
 * only means something on a mesh of unit size, so every shape is scaled
 * before the operator is built.
 */
#include "internal.h"

#include <lapacke.h>
#include <math.h>

/* Loops over a million triangles take a tenth of a second: they report
 * progress every STEP triangles or vertices. */
#define STEP ((size_t)1 << 18)

/* Where a loop reports: fractions of opt's stage (opt NULL: nowhere). */
typedef struct reporter {
    const phks_options *opt;
    phks_stage stage;
    double done, span;
} reporter;

/* Reports fraction i / n of the reporter's span, when i is a multiple of
 * STEP above 0. */
static phks_status tick(const reporter *r, size_t i, size_t n)
{
    if (!r->opt || i == 0 || i % STEP != 0)
        return PHKS_OK;
    return phks_progress(r->opt, r->stage,
                         r->done + r->span * (double)i / (double)n);
}

static void centroid(const double *a, const double *b, const double *c,
                     double *g)
{
    for (int d = 0; d < 3; d++)
        g[d] = (a[d] + b[d] + c[d]) / 3;
}

/* Principal axes of the surface (area-weighted covariance of triangle
 * centroids), so that the box turns with the shape. Two passes over the
 * triangles, reported as halves of rep's span. */
static phks_status principal_axes(const phks_mesh *m, const reporter *rep,
                                  double axes[9])
{
    double mean[3] = {0, 0, 0}, total = 0;
    size_t n_t = m->triangle_count;
    phks_status st;
    for (size_t t = 0; t < n_t; t++) {
        if ((st = tick(rep, t, 2 * n_t)) != PHKS_OK)
            return st;
        const uint32_t *c = m->triangles + 3 * t;
        const double *p = m->xyz + 3 * c[0], *q = m->xyz + 3 * c[1],
                     *r = m->xyz + 3 * c[2];
        double g[3], a = phks_triangle_area(p, q, r);
        centroid(p, q, r, g);
        total += a;
        for (int d = 0; d < 3; d++)
            mean[d] += a * g[d];
    }
    for (int d = 0; d < 3; d++)
        mean[d] /= total;
    double cov[9] = {0};
    for (size_t t = 0; t < n_t; t++) {
        if ((st = tick(rep, n_t + t, 2 * n_t)) != PHKS_OK)
            return st;
        const uint32_t *c = m->triangles + 3 * t;
        const double *p = m->xyz + 3 * c[0], *q = m->xyz + 3 * c[1],
                     *r = m->xyz + 3 * c[2];
        double g[3], a = phks_triangle_area(p, q, r);
        centroid(p, q, r, g);
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                cov[3 * i + j] += a * (g[i] - mean[i]) * (g[j] - mean[j]);
    }
    double w[3];
    if (LAPACKE_dsyev(LAPACK_ROW_MAJOR, 'V', 'U', 3, cov, 3, w) != 0)
        return phks_fail(PHKS_ERROR_SOLVER, "principal axes: dsyev failed");
    for (int i = 0; i < 9; i++)
        axes[i] = cov[i]; /* column j of the row-major result is axis j */
    return PHKS_OK;
}

phks_status phks_unit_box_scale(const phks_mesh *m, phks_box box, double *scale)
{
    return phks_unit_box_scale_progress(m, box, NULL, PHKS_STAGE_OPERATOR, 0,
                                        0, scale);
}

phks_status phks_unit_box_scale_progress(const phks_mesh *m, phks_box box,
                                         const phks_options *opt,
                                         phks_stage stage, double done,
                                         double span, double *scale)
{
    double axes[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    /* The axes' two passes over the triangles, then one over the
     * vertices (twice as many triangles as vertices). */
    reporter r = {opt, stage, done, span * 2 / 3};
    phks_status st;
    if (box == PHKS_BOX_PRINCIPAL) {
        st = principal_axes(m, &r, axes);
        if (st != PHKS_OK)
            return st;
        r.done = done + span * 2 / 3;
        r.span = span / 3;
    } else {
        r.span = span;
    }
    double lo[3] = {INFINITY, INFINITY, INFINITY};
    double hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t v = 0; v < m->vertex_count; v++) {
        if ((st = tick(&r, v, m->vertex_count)) != PHKS_OK)
            return st;
        const double *p = m->xyz + 3 * v;
        for (int j = 0; j < 3; j++) {
            double s = p[0] * axes[j] + p[1] * axes[3 + j] + p[2] * axes[6 + j];
            lo[j] = fmin(lo[j], s);
            hi[j] = fmax(hi[j], s);
        }
    }
    double side = fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2]));
    if (!(side > 0) || !isfinite(1 / side))
        return phks_fail(PHKS_ERROR_ZERO_AREA, "the mesh has no extent");
    *scale = 1 / side;
    return PHKS_OK;
}

void phks_vertex_areas(const phks_mesh *m, double scale, double *mass)
{
    phks_vertex_areas_progress(m, scale, NULL, PHKS_STAGE_OPERATOR, 0, 0, mass);
}

phks_status phks_vertex_areas_progress(const phks_mesh *m, double scale,
                                       const phks_options *opt,
                                       phks_stage stage, double done,
                                       double span, double *mass)
{
    reporter r = {opt, stage, done, span};
    phks_status st;
    for (size_t v = 0; v < m->vertex_count; v++)
        mass[v] = 0;
    for (size_t t = 0; t < m->triangle_count; t++) {
        if ((st = tick(&r, t, m->triangle_count)) != PHKS_OK)
            return st;
        const uint32_t *c = m->triangles + 3 * t;
        double a = phks_triangle_area(m->xyz + 3 * c[0], m->xyz + 3 * c[1],
                                      m->xyz + 3 * c[2]) *
                   scale * scale / 3;
        mass[c[0]] += a;
        mass[c[1]] += a;
        mass[c[2]] += a;
    }
    return PHKS_OK;
}
