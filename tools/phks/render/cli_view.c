/*
 * cli_view.c - a mesh's view and its drawing for `phks` pictures: the
 * principal-axes frame, the fixed oblique orthographic projection, a
 * z-buffered rasteriser with two-sided Lambert shading by face normal at
 * up to 3x3 samples per pixel, the feature markers and the region palette.
 */
#include "render/cli_pictures.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Samples per pixel along each axis: 3, fewer on large tiles, so that a
 * tile never takes more than 16M samples. */
static int samples(int w, int h)
{
    double px = (double)w * h;
    return px * 9 <= 16e6 ? 3 : px * 4 <= 16e6 ? 2 : 1;
}

const unsigned char cli_marker_rgb[3] = {0, 0, 0};

/* Kelly's colours of maximum contrast without white, black and grey; then
 * hues spaced by the golden angle: the regions of `phks render` and of
 * `phks segment`'s PLY alike. */
void cli_region_colour(uint32_t r, unsigned char rgb[3])
{
    static const unsigned char kelly[][3] = {
        {243, 195, 0},   {135, 86, 146},  {243, 132, 0},   {161, 202, 241},
        {190, 0, 50},    {194, 178, 128}, {0, 136, 86},    {230, 143, 172},
        {0, 103, 165},   {249, 147, 121}, {96, 78, 151},   {246, 166, 0},
        {179, 68, 108},  {220, 211, 0},   {136, 45, 23},   {141, 182, 0},
        {101, 69, 34},   {226, 88, 34},   {43, 61, 38},
    };
    enum { K = sizeof kelly / sizeof kelly[0] };
    if (r == UINT32_MAX) {
        rgb[0] = rgb[1] = rgb[2] = 128;
        return;
    }
    if (r < K) {
        memcpy(rgb, kelly[r], 3);
        return;
    }
    double h = fmod((r - K) * 0.618033988749895, 1.0) * 6, f = h - floor(h);
    double v[6][3] = {{1, f, 0}, {1 - f, 1, 0}, {0, 1, f},
                      {0, 1 - f, 1}, {f, 0, 1}, {1, 0, 1 - f}};
    for (int c = 0; c < 3; c++)
        rgb[c] = (unsigned char)(40 + 170 * v[(int)h % 6][c]);
}

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

/* The principal frame: rows of f are unit axes, largest second moment
 * first. The surface's third moment along the first is made not positive
 * (an upright human then stands head up), along the third not negative
 * (the side where feet and nose stick out faces the viewer); the second
 * completes a right-handed frame (no mirror images). */
static void principal_frame(const phks_mesh *mesh, double centre[3],
                            double f[3][3])
{
    size_t m = phks_mesh_triangle_count(mesh);
    const double *xyz = phks_mesh_vertices(mesh);
    const uint32_t *tri = phks_mesh_triangles(mesh);
    double cov[3][3] = {{0}}, d[3], v[3][3];
    for (size_t t = 0; t < m; t++) {
        const double *a = xyz + 3 * (size_t)tri[3 * t],
                     *b = xyz + 3 * (size_t)tri[3 * t + 1],
                     *e = xyz + 3 * (size_t)tri[3 * t + 2];
        double area = triangle_area(a, b, e), g[3];
        for (int k = 0; k < 3; k++)
            g[k] = (a[k] + b[k] + e[k]) / 3 - centre[k];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                cov[i][j] += area * g[i] * g[j];
    }
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
    f[1][0] = f[0][1] * f[2][2] - f[0][2] * f[2][1];  /* f0 x f2 */
    f[1][1] = f[0][2] * f[2][0] - f[0][0] * f[2][2];
    f[1][2] = f[0][0] * f[2][1] - f[0][1] * f[2][0];
}

/* The view's rotation: the principal frame (x second, y largest, z
 * smallest), turned 30 degrees about y, then tilted 20 degrees about x. */
static void view_rotation(const phks_mesh *mesh, cli_view *view)
{
    double f[3][3], pf[3][3];
    area_centroid(mesh, view->centre);
    principal_frame(mesh, view->centre, f);
    memcpy(pf[0], f[1], sizeof pf[0]);  /* screen right: second axis    */
    memcpy(pf[1], f[0], sizeof pf[1]);  /* screen up: largest axis      */
    memcpy(pf[2], f[2], sizeof pf[2]);  /* towards the viewer: smallest */
    const double pi = 3.14159265358979323846;
    double ca = cos(30 * pi / 180), sa = sin(30 * pi / 180);
    double cb = cos(20 * pi / 180), sb = sin(20 * pi / 180);
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
                view->rot[i][j] += r[i][k] * pf[k][j];
        }
}

/* p in the view's frame, unscaled. */
static void rotate(const cli_view *view, const double p[3], double q[3])
{
    double d[3] = {p[0] - view->centre[0], p[1] - view->centre[1],
                   p[2] - view->centre[2]};
    for (int i = 0; i < 3; i++)
        q[i] = view->rot[i][0] * d[0] + view->rot[i][1] * d[1] +
               view->rot[i][2] * d[2];
}

/* Tile-local pixel position and depth (pixels, larger is nearer). */
static void local(const cli_view *view, const double p[3], double out[3])
{
    double q[3];
    rotate(view, p, q);
    out[0] = view->ox - view->x + view->scale * q[0];
    out[1] = view->oy - view->y - view->scale * q[1];
    out[2] = view->scale * q[2];
}

static void fit(const phks_mesh *mesh, cli_view *view)
{
    size_t n = phks_mesh_vertex_count(mesh);
    const double *xyz = phks_mesh_vertices(mesh);
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (size_t v = 0; v < n; v++) {
        double q[3];
        rotate(view, xyz + 3 * v, q);
        for (int k = 0; k < 2; k++) {
            lo[k] = fmin(lo[k], q[k]);
            hi[k] = fmax(hi[k], q[k]);
        }
    }
    double sx = hi[0] > lo[0] ? 0.9 * view->w / (hi[0] - lo[0]) : 1;
    double sy = hi[1] > lo[1] ? 0.9 * view->h / (hi[1] - lo[1]) : 1;
    view->scale = fmin(sx, sy);
    view->ox = view->x + view->w / 2.0 - view->scale * (lo[0] + hi[0]) / 2;
    view->oy = view->y + view->h / 2.0 + view->scale * (lo[1] + hi[1]) / 2;
}

static void raster(cli_image *fine, double *depth, const double a[3],
                   const double b[3], const double c[3],
                   const unsigned char rgb[3])
{
    double area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    if (!(fabs(area) > 0))
        return;
    int i0 = (int)floor(fmin(a[0], fmin(b[0], c[0])));
    int i1 = (int)ceil(fmax(a[0], fmax(b[0], c[0])));
    int j0 = (int)floor(fmin(a[1], fmin(b[1], c[1])));
    int j1 = (int)ceil(fmax(a[1], fmax(b[1], c[1])));
    i0 = i0 < 0 ? 0 : i0;
    j0 = j0 < 0 ? 0 : j0;
    i1 = i1 >= fine->width ? fine->width - 1 : i1;
    j1 = j1 >= fine->height ? fine->height - 1 : j1;
    for (int j = j0; j <= j1; j++)
        for (int i = i0; i <= i1; i++) {
            double x = i + 0.5, y = j + 0.5;
            double w0 = ((b[0] - x) * (c[1] - y) - (b[1] - y) * (c[0] - x)) / area;
            double w1 = ((c[0] - x) * (a[1] - y) - (c[1] - y) * (a[0] - x)) / area;
            double w2 = 1 - w0 - w1;
            if (w0 < 0 || w1 < 0 || w2 < 0)
                continue;
            double z = w0 * a[2] + w1 * b[2] + w2 * c[2];
            size_t at = (size_t)j * (size_t)fine->width + (size_t)i;
            if (z > depth[at]) {
                depth[at] = z;
                memcpy(fine->rgb + 3 * at, rgb, 3);
            }
        }
}

static void shade(const double a[3], const double b[3], const double c[3],
                  const unsigned char base[3], unsigned char rgb[3])
{
    /* Screen y points down: flip it for the normal. */
    double u[3] = {b[0] - a[0], a[1] - b[1], b[2] - a[2]};
    double w[3] = {c[0] - a[0], a[1] - c[1], c[2] - a[2]};
    double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                   u[0] * w[1] - u[1] * w[0]};
    double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    static const double l[3] = {-0.36, 0.48, 0.8};  /* unit, upper left front */
    double lambert = len > 0 ? fabs(n[0] * l[0] + n[1] * l[1] + n[2] * l[2]) / len
                             : 1;
    double k = 0.35 + 0.65 * lambert;
    for (int i = 0; i < 3; i++)
        rgb[i] = (unsigned char)(base[i] * k + 0.5);
}

int cli_draw_mesh(cli_image *im, int x, int y, int w, int h,
                  const phks_mesh *mesh, const unsigned char *face_rgb,
                  cli_view *view)
{
    memset(view, 0, sizeof *view);
    view->x = x;
    view->y = y;
    view->w = w;
    view->h = h;
    view->ss = samples(w, h);
    view_rotation(mesh, view);
    fit(mesh, view);
    size_t n = phks_mesh_vertex_count(mesh), m = phks_mesh_triangle_count(mesh);
    const double *xyz = phks_mesh_vertices(mesh);
    const uint32_t *tri = phks_mesh_triangles(mesh);
    const int ss = view->ss;
    cli_image fine;
    double *p = malloc(3 * n * sizeof *p);
    view->depth = malloc((size_t)ss * w * ss * h * sizeof *view->depth);
    if (!p || !view->depth || cli_image_init(&fine, ss * w, ss * h) != 0) {
        free(p);
        cli_view_free(view);
        return -1;
    }
    for (size_t i = 0; i < (size_t)ss * w * ss * h; i++)
        view->depth[i] = -INFINITY;
    for (size_t v = 0; v < n; v++) {
        local(view, xyz + 3 * v, p + 3 * v);
        for (int k = 0; k < 3; k++)
            p[3 * v + k] *= ss;
    }
    static const unsigned char grey[3] = {200, 200, 205};
    for (size_t t = 0; t < m; t++) {
        const double *a = p + 3 * (size_t)tri[3 * t],
                     *b = p + 3 * (size_t)tri[3 * t + 1],
                     *c = p + 3 * (size_t)tri[3 * t + 2];
        unsigned char rgb[3];
        shade(a, b, c, face_rgb ? face_rgb + 3 * t : grey, rgb);
        raster(&fine, view->depth, a, b, c, rgb);
    }
    cli_downsample(im, x, y, &fine, ss);
    cli_image_free(&fine);
    free(p);
    return 0;
}

void cli_view_free(cli_view *view)
{
    free(view->depth);
    view->depth = NULL;
}

int cli_view_project(const cli_view *view, const double p[3], double *px,
                     double *py)
{
    double q[3];
    const int ss = view->ss;
    local(view, p, q);
    *px = q[0] + view->x;
    *py = q[1] + view->y;
    if (!view->depth)
        return 1;
    /* Visible when, somewhere within 3 samples, the surface is not in front
     * of it by more than 1% of the tile. */
    double tol = 0.01 * ss * (view->w > view->h ? view->w : view->h);
    int ci = (int)floor(q[0] * ss), cj = (int)floor(q[1] * ss);
    for (int j = cj - 3; j <= cj + 3; j++)
        for (int i = ci - 3; i <= ci + 3; i++) {
            if (i < 0 || j < 0 || i >= ss * view->w || j >= ss * view->h)
                continue;
            if (view->depth[(size_t)j * ss * view->w + i] <= q[2] * ss + tol)
                return 1;
        }
    return 0;
}

void cli_draw_marker(cli_image *im, const cli_view *view, const double p[3],
                     double radius)
{
    static const unsigned char white[3] = {255, 255, 255};
    double x, y;
    if (cli_view_project(view, p, &x, &y)) {
        cli_draw_disc(im, x, y, radius + 1.5, white);
        cli_draw_disc(im, x, y, radius, cli_marker_rgb);
    } else {
        cli_draw_ring(im, x, y, radius, 1.5, cli_marker_rgb);
    }
}
