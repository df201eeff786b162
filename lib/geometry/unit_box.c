/*
 * unit_box.c - scaling to the unit box, and vertex masses. tau = 0.0002
 * only means something on a mesh of unit size, so every shape is scaled
 * before the operator is built.
 */
#include "geometry/geometry.h"

#include <math.h>

/* Loops over millions of triangles are long enough to need progress
 * reports (docs/benchmarks.md): they report every STEP triangles or
 * vertices. */
#define STEP ((size_t)1 << 18)

/* Reports fraction i / n of the span, when i is a multiple of STEP above
 * 0. */
static phks_status tick(const phks__span *at, size_t i, size_t n)
{
    if (i == 0 || i % STEP != 0)
        return PHKS_OK;
    return phks__span_report(*at, (double)i / (double)n);
}

static void centroid(const double *a, const double *b, const double *c,
                     double *g)
{
    for (int d = 0; d < 3; d++)
        g[d] = (a[d] + b[d] + c[d]) / 3;
}

/* Corners of triangle t times unit (a power of two: exact). */
static void scaled_corners(const phks_mesh *m, size_t t, double unit,
                           double p[3][3])
{
    const uint32_t *c = m->triangles + 3 * t;
    for (int k = 0; k < 3; k++)
        for (int d = 0; d < 3; d++)
            p[k][d] = m->xyz[3 * (size_t)c[k] + d] * unit;
}

/* Principal axes of the surface (area-weighted covariance of triangle
 * centroids), so that the box turns with the shape. The covariance goes
 * with the fourth power of the size: it is taken on the positions times
 * the power of two that brings the largest coordinate into [0.5, 1),
 * which changes no axis (every step commutes with it exactly) but keeps
 * meshes at 1e100 from overflowing and at 1e-100 from underflowing. Two
 * passes over the triangles, reported as halves of rep's span. */
static phks_status principal_axes(const phks_mesh *m, const phks__span *rep,
                                  bool exact, double axes[9])
{
    double mean[3] = {0, 0, 0}, total = 0, big = 0;
    size_t n_t = m->triangle_count;
    phks_status st;
    for (size_t i = 0; i < 3 * m->vertex_count; i++)
        big = fmax(big, fabs(m->xyz[i]));
    int e;
    frexp(big, &e);
    double unit = ldexp(1, -e);
    for (size_t t = 0; t < n_t; t++) {
        if ((st = tick(rep, t, 2 * n_t)) != PHKS_OK)
            return st;
        double p[3][3], g[3];
        scaled_corners(m, t, unit, p);
        double a = phks__triangle_area(p[0], p[1], p[2]);
        centroid(p[0], p[1], p[2], g);
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
        double p[3][3], g[3];
        scaled_corners(m, t, unit, p);
        double a = phks__triangle_area(p[0], p[1], p[2]);
        centroid(p[0], p[1], p[2], g);
        if (!exact) {
            for (int i = 0; i < 3; i++)
                for (int j = 0; j < 3; j++)
                    cov[3 * i + j] += a * (g[i] - mean[i]) * (g[j] - mean[j]);
            continue;
        }
        /* The integral of x x^T over a triangle with corners p_k (here
         * about the mean) is A / 12 (sum_k p_k p_k^T + 9 g g^T): the
         * centroid's term alone misses the spread within the triangle,
         * which is all there is on a face of two long triangles. */
        double q[4][3];
        for (int d = 0; d < 3; d++) {
            for (int k = 0; k < 3; k++)
                q[k][d] = p[k][d] - mean[d];
            q[3][d] = g[d] - mean[d];
        }
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                cov[3 * i + j] += a / 12 *
                                  (q[0][i] * q[0][j] + q[1][i] * q[1][j] +
                                   q[2][i] * q[2][j] + 9 * q[3][i] * q[3][j]);
    }
    for (int i = 0; i < 9; i++)
        if (!isfinite(cov[i]))
            return phks__fail(PHKS_ERROR_SOLVER, "principal axes: the "
                                                "covariance is not finite");
    double w[3];
    phks__sym3_eigen(cov, w, axes); /* column j (row-major) is axis j */
    return PHKS_OK;
}

phks_status phks__unit_box_scale(const phks_mesh *m, phks_box box,
                                 phks__span at, double *scale)
{
    double axes[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    /* The axes' two passes over the triangles, then one over the
     * vertices (twice as many triangles as vertices). */
    phks__span r = at;
    phks_status st;
    if (box == PHKS_BOX_PRINCIPAL || box == PHKS__BOX_PRINCIPAL_EXACT) {
        r = phks__span_part(at, 0, 2.0 / 3);
        st = principal_axes(m, &r, box == PHKS__BOX_PRINCIPAL_EXACT, axes);
        if (st != PHKS_OK)
            return st;
        r = phks__span_part(at, 2.0 / 3, 1);
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
        return phks__fail(PHKS_ERROR_ZERO_AREA, "the mesh has no extent");
    *scale = 1 / side;
    return PHKS_OK;
}

phks_status phks__vertex_areas(const phks_mesh *m, double scale,
                               phks__span at, double *mass)
{
    phks__span r = at;
    phks_status st;
    for (size_t v = 0; v < m->vertex_count; v++)
        mass[v] = 0;
    for (size_t t = 0; t < m->triangle_count; t++) {
        if ((st = tick(&r, t, m->triangle_count)) != PHKS_OK)
            return st;
        const uint32_t *c = m->triangles + 3 * t;
        double a = phks__triangle_area(m->xyz + 3 * c[0], m->xyz + 3 * c[1],
                                      m->xyz + 3 * c[2]) *
                   scale * scale / 3;
        mass[c[0]] += a;
        mass[c[1]] += a;
        mass[c[2]] += a;
    }
    return PHKS_OK;
}

phks_status phks__unit_mesh_init(const phks_mesh *mesh, phks_box box,
                                 phks__span at, phks__unit_mesh *out)
{
    out->mesh = mesh;
    out->scale = 1;
    out->area = phks__malloc_array(mesh->vertex_count, sizeof *out->area);
    if (!out->area)
        return phks__fail_oom("vertex areas");
    /* Two or three passes over the triangles for the box, one for the
     * areas. */
    phks_status st = phks__unit_box_scale(mesh, box,
                                          phks__span_part(at, 0, 2.0 / 3),
                                          &out->scale);
    if (st == PHKS_OK)
        st = phks__vertex_areas(mesh, out->scale,
                                phks__span_part(at, 2.0 / 3, 1), out->area);
    if (st != PHKS_OK)
        phks__unit_mesh_release(out);
    return st;
}

bool phks__long_triangles(const phks_mesh *m, double scale, double width)
{
    for (size_t t = 0; t < m->triangle_count; t++) {
        const uint32_t *c = m->triangles + 3 * t;
        for (int k = 0; k < 3; k++) {
            const double *a = m->xyz + 3 * (size_t)c[k];
            const double *b = m->xyz + 3 * (size_t)c[(k + 1) % 3];
            double d2 = 0;
            for (int d = 0; d < 3; d++)
                d2 += (b[d] - a[d]) * (b[d] - a[d]);
            if (sqrt(d2) * scale > width)
                return true;
        }
    }
    return false;
}

phks_status phks__unit_mesh_for(const phks_mesh *mesh, const phks_options *opt,
                                phks__span at, phks__unit_mesh *out)
{
    phks_status st = phks__unit_mesh_init(mesh, (phks_box)opt->box, at, out);
    if (st != PHKS_OK || opt->quadrature != PHKS_QUADRATURE_TRIANGLES ||
        opt->box != PHKS_BOX_PRINCIPAL ||
        !phks__long_triangles(mesh, out->scale, sqrt(4 * opt->tau)))
        return st;
    /* The centroids' covariance of a face of two long triangles is not
     * the face's: its axes, and the box, turn with the triangulation. */
    st = phks__unit_box_scale(mesh, PHKS__BOX_PRINCIPAL_EXACT,
                              PHKS__SPAN_NONE, &out->scale);
    if (st == PHKS_OK)
        st = phks__vertex_areas(mesh, out->scale, PHKS__SPAN_NONE, out->area);
    if (st != PHKS_OK)
        phks__unit_mesh_release(out);
    return st;
}

void phks__unit_mesh_release(phks__unit_mesh *u)
{
    phks__free(u->area);
    u->area = NULL;
}
