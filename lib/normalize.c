/*
 * normalize.c - scaling to the unit box, and vertex masses. tau = 0.0002
 * only means something on a mesh of unit size, so every shape is scaled
 * before the operator is built.
 */
#include "internal.h"

#include <lapacke.h>
#include <math.h>

static void centroid(const double *a, const double *b, const double *c,
                     double *g)
{
    for (int d = 0; d < 3; d++)
        g[d] = (a[d] + b[d] + c[d]) / 3;
}

/* Principal axes of the surface (area-weighted covariance of triangle
 * centroids), so that the box turns with the shape. */
static phks_status principal_axes(const phks_mesh *m, double axes[9])
{
    double mean[3] = {0, 0, 0}, total = 0;
    for (size_t t = 0; t < m->triangle_count; t++) {
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
    for (size_t t = 0; t < m->triangle_count; t++) {
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
    double axes[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    if (box == PHKS_BOX_PRINCIPAL) {
        phks_status st = principal_axes(m, axes);
        if (st != PHKS_OK)
            return st;
    }
    double lo[3] = {INFINITY, INFINITY, INFINITY};
    double hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t v = 0; v < m->vertex_count; v++) {
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
    for (size_t v = 0; v < m->vertex_count; v++)
        mass[v] = 0;
    for (size_t t = 0; t < m->triangle_count; t++) {
        const uint32_t *c = m->triangles + 3 * t;
        double a = phks_triangle_area(m->xyz + 3 * c[0], m->xyz + 3 * c[1],
                                      m->xyz + 3 * c[2]) *
                   scale * scale / 3;
        mass[c[0]] += a;
        mass[c[1]] += a;
        mass[c[2]] += a;
    }
}
