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
    return phks__progress(r->opt, r->stage,
                         r->done + r->span * (double)i / (double)n);
}

/* ---- the symmetric 3 x 3 eigenproblem: cyclic Jacobi
 *
 * Own code rather than LAPACK's dsyev, whose result (OpenBLAS 0.3.21,
 * even at 3 x 3) changes in the last bits with OPENBLAS_NUM_THREADS, and
 * with it the box and every number after it. A Jacobi rotation zeroes one off-diagonal entry
 * (Rutishauser's formulas, as in Numerical Recipes' jacobi); sweeps over
 * the three converge quadratically, and after four sweeps an entry too
 * small to change either diagonal entry it couples is set to zero, so the
 * loop ends with an exactly diagonal matrix (a million random matrices,
 * some nearly diagonal or nearly degenerate: at most five sweeps). Plain
 * arithmetic in a fixed order: the same bits on every run, and the same
 * eigenvectors for the matrix times any power of two. */

#define JACOBI_SWEEPS 60

/* Rotates rows/columns p and q of the symmetric a (and columns of v) to
 * zero a[p][q]. */
static void jacobi_rotate(double a[3][3], double v[3][3], int p, int q,
                          int sweep)
{
    double apq = a[p][q];
    if (apq == 0)
        return;
    double g = 100 * fabs(apq);
    if (sweep > 4 && fabs(a[p][p]) + g == fabs(a[p][p]) &&
        fabs(a[q][q]) + g == fabs(a[q][q])) {
        a[p][q] = a[q][p] = 0;
        return;
    }
    double h = a[q][q] - a[p][p], t;
    if (fabs(h) + g == fabs(h)) {
        t = apq / h; /* 1 / (2 theta), theta huge */
    } else {
        double theta = 0.5 * h / apq;
        t = 1 / (fabs(theta) + sqrt(1 + theta * theta));
        if (theta < 0)
            t = -t;
    }
    double c = 1 / sqrt(1 + t * t), s = t * c, tau = s / (1 + c);
    h = t * apq;
    a[p][p] -= h;
    a[q][q] += h;
    a[p][q] = a[q][p] = 0;
    int r = 3 - p - q; /* the third index */
    double arp = a[r][p], arq = a[r][q];
    a[r][p] = a[p][r] = arp - s * (arq + arp * tau);
    a[r][q] = a[q][r] = arq + s * (arp - arq * tau);
    for (int i = 0; i < 3; i++) {
        double vp = v[i][p], vq = v[i][q];
        v[i][p] = vp - s * (vq + vp * tau);
        v[i][q] = vq + s * (vp - vq * tau);
    }
}

void phks__sym3_eigen(const double matrix[9], double values[3],
                     double vectors[9])
{
    double a[3][3], v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (int i = 0; i < 3; i++)
        for (int j = i; j < 3; j++)
            a[i][j] = a[j][i] = matrix[3 * i + j]; /* the upper triangle */
    for (int sweep = 1; sweep <= JACOBI_SWEEPS; sweep++) {
        if (a[0][1] == 0 && a[0][2] == 0 && a[1][2] == 0)
            break;
        jacobi_rotate(a, v, 0, 1, sweep);
        jacobi_rotate(a, v, 0, 2, sweep);
        jacobi_rotate(a, v, 1, 2, sweep);
    }
    /* Ascending, as dsyev (a stable order: ties keep their columns). */
    int order[3] = {0, 1, 2};
    for (int i = 1; i < 3; i++)
        for (int j = i; j > 0 && a[order[j]][order[j]] < a[order[j - 1]][order[j - 1]]; j--) {
            int x = order[j];
            order[j] = order[j - 1];
            order[j - 1] = x;
        }
    for (int j = 0; j < 3; j++) {
        int k = order[j], big = 0;
        values[j] = a[k][k];
        for (int i = 1; i < 3; i++)
            if (fabs(v[i][k]) > fabs(v[big][k]))
                big = i;
        double sign = v[big][k] < 0 ? -1 : 1;
        for (int i = 0; i < 3; i++)
            vectors[3 * i + j] = sign * v[i][k];
    }
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
static phks_status principal_axes(const phks_mesh *m, const reporter *rep,
                                  double axes[9])
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
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                cov[3 * i + j] += a * (g[i] - mean[i]) * (g[j] - mean[j]);
    }
    for (int i = 0; i < 9; i++)
        if (!isfinite(cov[i]))
            return phks__fail(PHKS_ERROR_SOLVER, "principal axes: the "
                                                "covariance is not finite");
    double w[3];
    phks__sym3_eigen(cov, w, axes); /* column j (row-major) is axis j */
    return PHKS_OK;
}

phks_status phks__unit_box_scale(const phks_mesh *m, phks_box box, double *scale)
{
    return phks__unit_box_scale_progress(m, box, NULL, PHKS_STAGE_OPERATOR, 0,
                                        0, scale);
}

phks_status phks__unit_box_scale_progress(const phks_mesh *m, phks_box box,
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
        return phks__fail(PHKS_ERROR_ZERO_AREA, "the mesh has no extent");
    *scale = 1 / side;
    return PHKS_OK;
}

void phks__vertex_areas(const phks_mesh *m, double scale, double *mass)
{
    phks__vertex_areas_progress(m, scale, NULL, PHKS_STAGE_OPERATOR, 0, 0, mass);
}

phks_status phks__vertex_areas_progress(const phks_mesh *m, double scale,
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
        double a = phks__triangle_area(m->xyz + 3 * c[0], m->xyz + 3 * c[1],
                                      m->xyz + 3 * c[2]) *
                   scale * scale / 3;
        mass[c[0]] += a;
        mass[c[1]] += a;
        mass[c[2]] += a;
    }
    return PHKS_OK;
}
