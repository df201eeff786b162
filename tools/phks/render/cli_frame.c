/*
 * cli_frame.c - which way a mesh is seen in `phks` pictures: the frame of
 * its principal axes (the longest upright), turned so that its largest
 * open boundary (a scan's cut, a cup's rim) lies on the far side, or the
 * frame of the file's own axes when an up axis is given; then the
 * azimuth and elevation of the view.
 */
#include "render/cli_pictures.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const double pi = 3.14159265358979323846;

/* The default view: turned 30 degrees about the vertical, seen from 20
 * degrees above. */
static const double default_azimuth = 30, default_elevation = 20;

/* Eigenvectors of the symmetric 3x3 a (cyclic Jacobi) as the columns of v,
 * eigenvalues in d. */
static void jacobi3(double a[3][3], double d[3], double v[3][3])
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            v[i][j] = i == j;
    for (int sweep = 0; sweep < 50; sweep++) {
        double off = fabs(a[0][1]) + fabs(a[0][2]) + fabs(a[1][2]);
        if (off == 0)
            break;
        for (int p = 0; p < 2; p++)
            for (int q = p + 1; q < 3; q++) {
                if (a[p][q] == 0)
                    continue;
                double theta = (a[q][q] - a[p][p]) / (2 * a[p][q]);
                double t = (theta >= 0 ? 1 : -1) /
                           (fabs(theta) + sqrt(theta * theta + 1));
                double c = 1 / sqrt(t * t + 1), s = t * c;
                for (int k = 0; k < 3; k++) {  /* a = J^T a J */
                    double akp = a[k][p], akq = a[k][q];
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for (int k = 0; k < 3; k++) {
                    double apk = a[p][k], aqk = a[q][k];
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
                for (int k = 0; k < 3; k++) {
                    double vkp = v[k][p], vkq = v[k][q];
                    v[k][p] = c * vkp - s * vkq;
                    v[k][q] = s * vkp + c * vkq;
                }
            }
    }
    for (int i = 0; i < 3; i++)
        d[i] = a[i][i];
}

static double triangle_area(const double a[3], const double b[3],
                            const double c[3])
{
    double u[3], w[3];
    for (int k = 0; k < 3; k++) {
        u[k] = b[k] - a[k];
        w[k] = c[k] - a[k];
    }
    double nx = u[1] * w[2] - u[2] * w[1], ny = u[2] * w[0] - u[0] * w[2],
           nz = u[0] * w[1] - u[1] * w[0];
    return sqrt(nx * nx + ny * ny + nz * nz) / 2;
}

static void area_centroid(const phks_mesh *mesh, double centre[3])
{
    size_t m = phks_mesh_triangle_count(mesh);
    const double *xyz = phks_mesh_vertices(mesh);
    const uint32_t *tri = phks_mesh_triangles(mesh);
    double total = 0, c[3] = {0, 0, 0};
    for (size_t t = 0; t < m; t++) {
        const double *a = xyz + 3 * (size_t)tri[3 * t],
                     *b = xyz + 3 * (size_t)tri[3 * t + 1],
                     *e = xyz + 3 * (size_t)tri[3 * t + 2];
        double area = triangle_area(a, b, e);
        total += area;
        for (int k = 0; k < 3; k++)
            c[k] += area * (a[k] + b[k] + e[k]) / 3;
    }
    for (int k = 0; k < 3; k++)
        centre[k] = total > 0 ? c[k] / total : 0;
}

static void cross(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static double dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* The principal frame: rows of f are unit axes, largest second moment
 * first. The surface's third moment along the first is made not positive
 * (an upright human then stands head up), along the third not negative
 * (the side where feet and nose stick out faces the viewer); the second
 * completes a right-handed frame (no mirror images). *rms receives the
 * root mean square distance of the surface from the centre. */
static void principal_frame(const phks_mesh *mesh, const double centre[3],
                            double f[3][3], double *rms)
{
    size_t m = phks_mesh_triangle_count(mesh);
    const double *xyz = phks_mesh_vertices(mesh);
    const uint32_t *tri = phks_mesh_triangles(mesh);
    double cov[3][3] = {{0}}, d[3], v[3][3], total = 0;
    for (size_t t = 0; t < m; t++) {
        const double *a = xyz + 3 * (size_t)tri[3 * t],
                     *b = xyz + 3 * (size_t)tri[3 * t + 1],
                     *e = xyz + 3 * (size_t)tri[3 * t + 2];
        double area = triangle_area(a, b, e), g[3];
        total += area;
        for (int k = 0; k < 3; k++)
            g[k] = (a[k] + b[k] + e[k]) / 3 - centre[k];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                cov[i][j] += area * g[i] * g[j];
    }
    *rms = total > 0 ? sqrt((cov[0][0] + cov[1][1] + cov[2][2]) / total) : 0;
    jacobi3(cov, d, v);
    int order[3] = {0, 1, 2};
    for (int i = 0; i < 3; i++)
        for (int j = i + 1; j < 3; j++)
            if (d[order[j]] > d[order[i]]) {
                int s = order[i];
                order[i] = order[j];
                order[j] = s;
            }
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++)
            f[i][k] = v[k][order[i]];
    for (int i = 0; i < 3; i += 2) {
        double third = 0;
        for (size_t t = 0; t < m; t++) {
            const double *a = xyz + 3 * (size_t)tri[3 * t],
                         *b = xyz + 3 * (size_t)tri[3 * t + 1],
                         *e = xyz + 3 * (size_t)tri[3 * t + 2];
            double s = 0;
            for (int k = 0; k < 3; k++)
                s += f[i][k] * ((a[k] + b[k] + e[k]) / 3 - centre[k]);
            third += triangle_area(a, b, e) * s * s * s;
        }
        if (i == 0 ? third > 0 : third < 0)
            for (int k = 0; k < 3; k++)
                f[i][k] = -f[i][k];
    }
    cross(f[0], f[2], f[1]);
}

static uint32_t find_root(uint32_t *parent, uint32_t v)
{
    while (parent[v] != v)
        v = parent[v] = parent[parent[v]];
    return v;
}

/* The centre of the mesh's largest open boundary, the connected boundary
 * edges of greatest total length (the lowest vertex's on a tie), as the
 * length-weighted mean of its edges' midpoints: 1 and the centre in c, 0
 * for a closed mesh, -1 when out of memory. */
static int largest_boundary_centre(const phks_mesh *mesh, double c[3])
{
    size_t n = phks_mesh_vertex_count(mesh);
    size_t e = phks_mesh_boundary_edge_count(mesh);
    const uint32_t *edge = phks_mesh_boundary_edges(mesh);
    const double *xyz = phks_mesh_vertices(mesh);
    if (e == 0)
        return 0;
    uint32_t *parent = malloc(n * sizeof *parent);
    double *length = calloc(n, sizeof *length);
    double *sum = calloc(3 * n, sizeof *sum);
    if (!parent || !length || !sum) {
        free(parent);
        free(length);
        free(sum);
        return -1;
    }
    for (size_t v = 0; v < n; v++)
        parent[v] = (uint32_t)v;
    for (size_t i = 0; i < e; i++) {
        uint32_t a = find_root(parent, edge[2 * i]);
        uint32_t b = find_root(parent, edge[2 * i + 1]);
        /* The lower root stays: a loop is named by its lowest vertex. */
        parent[a > b ? a : b] = a < b ? a : b;
    }
    for (size_t i = 0; i < e; i++) {
        const double *p = xyz + 3 * (size_t)edge[2 * i],
                     *q = xyz + 3 * (size_t)edge[2 * i + 1];
        uint32_t r = find_root(parent, edge[2 * i]);
        double d[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]};
        double len = sqrt(dot(d, d));
        length[r] += len;
        for (int k = 0; k < 3; k++)
            sum[3 * (size_t)r + k] += len * (p[k] + q[k]) / 2;
    }
    size_t best = edge[0];
    for (size_t v = 0; v < n; v++)
        if (length[v] > length[best])
            best = v;
    for (int k = 0; k < 3; k++)
        c[k] = length[best] > 0 ? sum[3 * best + k] / length[best]
                                : xyz[3 * best + k];
    free(parent);
    free(length);
    free(sum);
    return 1;
}

/* The frame of the file's axes for --up: up is the axis, and the front
 * (towards the viewer) the one a modelling program shows in its front
 * view: +z for y up (OpenGL), -y for z up (CAD), +y for x up; negated
 * axes turn the picture upside down about the same front. */
static void axis_frame(int up, double frame[3][3])
{
    static const double front_for_up[3][3] = {{0, 1, 0}, {0, 0, 1},
                                              {0, -1, 0}};
    int axis = abs(up) - 1;
    memset(frame, 0, 9 * sizeof(double));
    frame[1][axis] = up > 0 ? 1 : -1;
    memcpy(frame[2], front_for_up[axis], sizeof frame[2]);
    cross(frame[1], frame[2], frame[0]);
}

/* The automatic frame: up the longest principal axis, the front the
 * principal frame's; with an open boundary, the largest one is put on
 * the far side: below when its centre lies along the up axis (the view
 * looks from above), and behind when it lies beside it, each by more than
 * 5% of the surface's RMS radius (a scan's cut, where it stood, goes
 * down; a scan's open back goes behind). 0, or -1 when out of memory. */
static int auto_frame(const phks_mesh *mesh, const double centre[3],
                      double frame[3][3])
{
    double f[3][3], rms, b[3];
    principal_frame(mesh, centre, f, &rms);
    memcpy(frame[1], f[0], sizeof frame[1]);
    memcpy(frame[2], f[2], sizeof frame[2]);
    int boundary = largest_boundary_centre(mesh, b);
    if (boundary < 0)
        return -1;
    if (boundary) {
        double offset[3], side[3];
        for (int k = 0; k < 3; k++)
            offset[k] = b[k] - centre[k];
        double along = dot(offset, frame[1]);
        for (int k = 0; k < 3; k++)
            side[k] = offset[k] - along * frame[1][k];
        double len = sqrt(dot(side, side));
        if (along > 0.05 * rms)
            for (int k = 0; k < 3; k++)
                frame[1][k] = -frame[1][k];
        if (len > 0.05 * rms)
            for (int k = 0; k < 3; k++)
                frame[2][k] = -side[k] / len;
    }
    cross(frame[1], frame[2], frame[0]);
    return 0;
}

/* view->rot: frame (rows right, up, front) turned by the azimuth about
 * up and tilted by the elevation about right. */
static void turn(cli_view *view, double frame[3][3])
{
    double ca = cos(view->azimuth * pi / 180), sa = sin(view->azimuth * pi / 180);
    double cb = cos(view->elevation * pi / 180),
           sb = sin(view->elevation * pi / 180);
    double yaw[3][3] = {{ca, 0, sa}, {0, 1, 0}, {-sa, 0, ca}};
    double tilt[3][3] = {{1, 0, 0}, {0, cb, -sb}, {0, sb, cb}};
    double r[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            r[i][j] = 0;
            for (int k = 0; k < 3; k++)
                r[i][j] += tilt[i][k] * yaw[k][j];
        }
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            view->rot[i][j] = 0;
            for (int k = 0; k < 3; k++)
                view->rot[i][j] += r[i][k] * frame[k][j];
        }
}

int cli_view_orient(cli_view *view, const phks_mesh *mesh,
                    const cli_view_options *o)
{
    double frame[3][3];
    area_centroid(mesh, view->centre);
    if (o && o->up)
        axis_frame(o->up, frame);
    else if (auto_frame(mesh, view->centre, frame) != 0)
        return -1;
    int given = o && o->angles_given;
    view->azimuth = given ? o->azimuth : default_azimuth;
    view->elevation = given ? o->elevation : default_elevation;
    turn(view, frame);
    return 0;
}
