/*
 * cli_view.c - a mesh's drawing for `phks` pictures: the orthographic
 * projection of its view (cli_frame.c turns it), a z-buffered rasteriser
 * with two-sided Lambert shading by face normal at up to 3x3 samples per
 * pixel, the boundary edges over it, and the feature markers.
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
const unsigned char cli_boundary_rgb[3] = {20, 20, 20};

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

/* Pixel bounds i0..i1 x j0..j1 cut to the image. */
static void clip_box(const cli_image *fine, int *i0, int *i1, int *j0,
                     int *j1)
{
    *i0 = *i0 < 0 ? 0 : *i0;
    *j0 = *j0 < 0 ? 0 : *j0;
    *i1 = *i1 >= fine->width ? fine->width - 1 : *i1;
    *j1 = *j1 >= fine->height ? fine->height - 1 : *j1;
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
    clip_box(fine, &i0, &i1, &j0, &j1);
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

/* The boundary edge a-b (fine pixels, depth in a[2] and b[2]) as a line
 * of the given width, in the pixels where the surface is not in front of
 * it by more than tol: a cut seen through the mesh is not drawn. */
static void boundary_edge(cli_image *fine, const double *depth,
                          const double a[3], const double b[3], double width,
                          double tol)
{
    double r = width / 2, dx = b[0] - a[0], dy = b[1] - a[1];
    double len2 = dx * dx + dy * dy;
    int i0 = (int)floor(fmin(a[0], b[0]) - r), i1 = (int)ceil(fmax(a[0], b[0]) + r);
    int j0 = (int)floor(fmin(a[1], b[1]) - r), j1 = (int)ceil(fmax(a[1], b[1]) + r);
    clip_box(fine, &i0, &i1, &j0, &j1);
    for (int j = j0; j <= j1; j++)
        for (int i = i0; i <= i1; i++) {
            double px = i + 0.5 - a[0], py = j + 0.5 - a[1];
            double s = len2 > 0 ? (px * dx + py * dy) / len2 : 0;
            s = s < 0 ? 0 : s > 1 ? 1 : s;
            double ex = px - s * dx, ey = py - s * dy;
            size_t at = (size_t)j * (size_t)fine->width + (size_t)i;
            if (ex * ex + ey * ey <= r * r &&
                a[2] + s * (b[2] - a[2]) + tol >= depth[at])
                memcpy(fine->rgb + 3 * at, cli_boundary_rgb, 3);
        }
}

/* Every boundary edge of the mesh (p: its vertices in fine pixels), a
 * line 1/200 of the tile's smaller side wide, at least 1.5 pixels. */
static void draw_boundary(cli_image *fine, const cli_view *view,
                          const phks_mesh *mesh, const double *p)
{
    size_t e = phks_mesh_boundary_edge_count(mesh);
    const uint32_t *edge = phks_mesh_boundary_edges(mesh);
    int side = view->w < view->h ? view->w : view->h;
    double width = view->ss * fmax(1.5, side / 200.0);
    /* The tolerance of cli_view_project: 1% of the tile. */
    double tol = 0.01 * view->ss * (view->w > view->h ? view->w : view->h);
    for (size_t i = 0; i < e; i++)
        boundary_edge(fine, view->depth, p + 3 * (size_t)edge[2 * i],
                      p + 3 * (size_t)edge[2 * i + 1], width, tol);
}

int cli_draw_mesh(cli_image *im, int x, int y, int w, int h,
                  const phks_mesh *mesh, const unsigned char *face_rgb,
                  const cli_view_options *options, cli_view *view)
{
    memset(view, 0, sizeof *view);
    view->x = x;
    view->y = y;
    view->w = w;
    view->h = h;
    view->ss = samples(w, h);
    if (cli_view_orient(view, mesh, options) != 0)
        return -1;
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
    draw_boundary(&fine, view, mesh, p);
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
