/*
 * partial.c - partial scans (depth buffer along a view direction) and
 * incomplete models (plane cuts) of a triangle mesh. See partial.h.
 *
 * Reproducibility: the only random source is splitmix64 seeded by the
 * caller; every number is computed with + - * / and sqrt (correctly
 * rounded in IEEE-754), floor and ceil, never with libm transcendentals
 * whose last bits differ between C libraries; sums run in a fixed order;
 * nothing depends on qsort's order among equal keys. ISO C mode (meson's
 * c_std=c11) keeps GCC from contracting a * b + c into an fma; clang is
 * told so below.
 */
#include "partial.h"

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#endif

#define MAX_COORDINATE 1e100
#define GRAZING 0.1          /* |unit normal . view| at or below: not seen */
#define COVER_SLACK 1e-9     /* of the size: a triangle's edges are inside */
#define DEPTH_TOLERANCE 1e-6 /* of the size: nearer than this occludes    */
#define GRID_MIN 16          /* cells per side of the bucket grid         */
#define GRID_MAX 2048
#define MAX_DRAWS 1000
#define KEEP_MIN 0.5
#define KEEP_MAX 0.9

/* ---------------------------------------------------------------------
 * Random numbers: splitmix64.
 * --------------------------------------------------------------------- */
static uint64_t rng_next(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* Uniform in [0, 1). */
static double rng_uniform(uint64_t *state)
{
    return (double)(rng_next(state) >> 11) * 0x1.0p-53;
}

/* Uniform on the unit sphere: rejection from the cube, no trigonometry. */
static void rng_direction(uint64_t *state, double d[3])
{
    for (;;) {
        double x = 2 * rng_uniform(state) - 1, y = 2 * rng_uniform(state) - 1,
               z = 2 * rng_uniform(state) - 1;
        double r2 = x * x + y * y + z * z;
        if (r2 > 1e-6 && r2 <= 1) {
            double r = sqrt(r2);
            d[0] = x / r;
            d[1] = y / r;
            d[2] = z / r;
            return;
        }
    }
}

void piece_view_direction(uint64_t seed, double dir[3])
{
    uint64_t state = seed;
    rng_direction(&state, dir);
}

/* ---------------------------------------------------------------------
 * Geometry helpers.
 * --------------------------------------------------------------------- */
/* Length of v without overflow or underflow in the squares. */
static double norm3(const double v[3])
{
    double m = fmax(fabs(v[0]), fmax(fabs(v[1]), fabs(v[2])));
    if (!(m > 0))
        return 0;
    double a = v[0] / m, b = v[1] / m, c = v[2] / m;
    return m * sqrt(a * a + b * b + c * c);
}

/* Cross product of the edges of triangle t: twice its area vector. */
static void triangle_normal(const double *xyz, const uint32_t *t, double n[3])
{
    const double *a = xyz + 3 * (size_t)t[0], *b = xyz + 3 * (size_t)t[1],
                 *c = xyz + 3 * (size_t)t[2];
    double e[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double f[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    n[0] = e[1] * f[2] - e[2] * f[1];
    n[1] = e[2] * f[0] - e[0] * f[2];
    n[2] = e[0] * f[1] - e[1] * f[0];
}

/* 0 when the mesh is usable, -1 otherwise (see partial.h). */
static int check_input(const double *xyz, size_t vertex_count,
                       const uint32_t *triangles, size_t triangle_count)
{
    if (triangle_count == 0 || !triangles || !xyz || vertex_count == 0)
        return -1;
    if (triangle_count > SIZE_MAX / (3 * sizeof(double) + 64) ||
        vertex_count > SIZE_MAX / (3 * sizeof(double) + 64))
        return -1;
    for (size_t i = 0; i < 3 * vertex_count; i++)
        if (!(fabs(xyz[i]) <= MAX_COORDINATE))   /* also NaN */
            return -1;
    for (size_t i = 0; i < 3 * triangle_count; i++)
        if (triangles[i] >= vertex_count)
            return -1;
    return 0;
}

/* ---------------------------------------------------------------------
 * Edge-connected pieces.
 * --------------------------------------------------------------------- */
typedef struct edge_rec {
    uint32_t a, b;   /* a < b */
    size_t t;
} edge_rec;

static int edge_compare(const void *x, const void *y)
{
    const edge_rec *p = x, *q = y;
    if (p->a != q->a)
        return p->a < q->a ? -1 : 1;
    if (p->b != q->b)
        return p->b < q->b ? -1 : 1;
    if (p->t != q->t)
        return p->t < q->t ? -1 : 1;
    return 0;
}

/* The non-degenerate edges of all triangles, sorted, so that the
 * triangles sharing an edge are adjacent. *count receives their number. */
static edge_rec *edges_build(const uint32_t *triangles, size_t triangle_count,
                             size_t *count)
{
    edge_rec *e = malloc(3 * triangle_count * sizeof *e);
    if (!e)
        return NULL;
    size_t n = 0;
    for (size_t t = 0; t < triangle_count; t++)
        for (int k = 0; k < 3; k++) {
            uint32_t a = triangles[3 * t + k];
            uint32_t b = triangles[3 * t + (k + 1) % 3];
            if (a == b)
                continue;
            e[n].a = a < b ? a : b;
            e[n].b = a < b ? b : a;
            e[n].t = t;
            n++;
        }
    qsort(e, n, sizeof *e, edge_compare);
    *count = n;
    return e;
}

/* Union-find whose root is always the lowest triangle of its set. */
static size_t uf_find(size_t *parent, size_t x)
{
    while (parent[x] != x) {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    return x;
}

static void uf_union(size_t *parent, size_t x, size_t y)
{
    x = uf_find(parent, x);
    y = uf_find(parent, y);
    if (x < y)
        parent[y] = x;
    else if (y < x)
        parent[x] = y;
}

/* Narrows keep[] to the largest-area edge-connected piece of the kept
 * triangles (ties: the piece holding the lowest triangle). parent and
 * piece_area are work arrays of triangle_count entries. Returns the area
 * of that piece; 0 when nothing is kept. */
static double largest_piece(size_t triangle_count, bool *keep,
                            const edge_rec *edges, size_t edge_count,
                            const double *area, size_t *parent,
                            double *piece_area)
{
    for (size_t t = 0; t < triangle_count; t++) {
        parent[t] = t;
        piece_area[t] = 0;
    }
    for (size_t i = 0; i < edge_count;) {
        size_t j = i, first = SIZE_MAX;
        for (; j < edge_count && edges[j].a == edges[i].a &&
               edges[j].b == edges[i].b;
             j++)
            if (keep[edges[j].t]) {
                if (first == SIZE_MAX)
                    first = edges[j].t;
                else
                    uf_union(parent, first, edges[j].t);
            }
        i = j;
    }
    bool any = false;
    for (size_t t = 0; t < triangle_count; t++)
        if (keep[t]) {
            piece_area[uf_find(parent, t)] += area[t];
            any = true;
        }
    if (!any)
        return 0;
    size_t best = SIZE_MAX;
    for (size_t t = 0; t < triangle_count; t++)
        if (keep[t] && parent[t] == t &&
            (best == SIZE_MAX || piece_area[t] > piece_area[best]))
            best = t;
    for (size_t t = 0; t < triangle_count; t++)
        if (keep[t] && uf_find(parent, t) != best)
            keep[t] = false;
    return piece_area[best];
}

/* Fills *out with the kept triangles and the vertices they use. */
static int piece_build(const double *xyz, size_t vertex_count,
                       const uint32_t *triangles, size_t triangle_count,
                       const bool *keep, piece *out)
{
    uint32_t *map = malloc(vertex_count * sizeof *map);
    if (!map)
        return -1;
    for (size_t v = 0; v < vertex_count; v++)
        map[v] = UINT32_MAX;
    size_t nt = 0, nv = 0;
    for (size_t t = 0; t < triangle_count; t++)
        if (keep[t]) {
            nt++;
            for (int k = 0; k < 3; k++)
                map[triangles[3 * t + k]] = 0;
        }
    for (size_t v = 0; v < vertex_count; v++)
        if (map[v] == 0)
            map[v] = (uint32_t)nv++;   /* nv <= v + 1 <= 2^32: fits */
    if (nt == 0) {
        free(map);
        return -1;
    }
    out->xyz = malloc(3 * nv * sizeof *out->xyz);
    out->triangles = malloc(3 * nt * sizeof *out->triangles);
    out->source_vertex = malloc(nv * sizeof *out->source_vertex);
    if (!out->xyz || !out->triangles || !out->source_vertex) {
        free(map);
        piece_free(out);
        return -1;
    }
    for (size_t v = 0; v < vertex_count; v++)
        if (map[v] != UINT32_MAX) {
            memcpy(out->xyz + 3 * (size_t)map[v], xyz + 3 * v,
                   3 * sizeof *xyz);
            out->source_vertex[map[v]] = (uint32_t)v;
        }
    size_t k = 0;
    for (size_t t = 0; t < triangle_count; t++)
        if (keep[t])
            for (int c = 0; c < 3; c++)
                out->triangles[k++] = map[triangles[3 * t + c]];
    out->vertex_count = nv;
    out->triangle_count = nt;
    free(map);
    return 0;
}

static double *triangle_areas(const double *xyz, const uint32_t *triangles,
                              size_t triangle_count)
{
    double *area = malloc(triangle_count * sizeof *area);
    if (!area)
        return NULL;
    for (size_t t = 0; t < triangle_count; t++) {
        double n[3];
        triangle_normal(xyz, triangles + 3 * t, n);
        area[t] = 0.5 * norm3(n);
    }
    return area;
}

/* Selection -> largest piece -> *out. Frees nothing of the caller's. */
static int finish(const double *xyz, size_t vertex_count,
                  const uint32_t *triangles, size_t triangle_count, bool *keep,
                  piece *out)
{
    size_t edge_count = 0;
    edge_rec *edges = edges_build(triangles, triangle_count, &edge_count);
    double *area = triangle_areas(xyz, triangles, triangle_count);
    size_t *parent = malloc(triangle_count * sizeof *parent);
    double *piece_area = malloc(triangle_count * sizeof *piece_area);
    int status = -1;
    if (edges && area && parent && piece_area) {
        largest_piece(triangle_count, keep, edges, edge_count, area, parent,
                      piece_area);
        status = piece_build(xyz, vertex_count, triangles, triangle_count,
                             keep, out);
    }
    free(edges);
    free(area);
    free(parent);
    free(piece_area);
    return status;
}

/* ---------------------------------------------------------------------
 * Partial scan.
 *
 * In view coordinates (x, y across the view, z = depth along it) a vertex
 * is shown when no other triangle covers its (x, y) at a smaller depth:
 * the depth buffer of unlimited resolution, evaluated at the vertices. A
 * sampled depth buffer cannot decide within a pixel of a silhouette, and
 * on thin limbs that is much of the limb; this test is exact. A grid of
 * cells over the projected bounding box lists every triangle that touches
 * each cell (conservatively), so a vertex is tested against the few
 * triangles of its own cell; the grid changes only the speed, never the
 * result.
 * --------------------------------------------------------------------- */
typedef struct cell_grid {
    size_t width, height;
    double cell;        /* side of a cell, in view units              */
    double lo[2];       /* view (x, y) of the grid's corner           */
    size_t *start;      /* width * height + 1 offsets into item       */
    size_t *item;       /* triangle indices, cell by cell             */
} cell_grid;

/* Calls visit(grid, cell index, t, ctx) for every cell that the triangle
 * (grid coordinates a, b, c) touches, widened by margin cells. */
static void for_each_cell(const cell_grid *g, const double *a, const double *b,
                          const double *c, double margin,
                          void (*visit)(const cell_grid *, size_t, size_t,
                                        void *),
                          size_t t, void *ctx)
{
    const double *corner[3] = {a, b, c};
    double ylo = fmin(a[1], fmin(b[1], c[1])) - margin;
    double yhi = fmax(a[1], fmax(b[1], c[1])) + margin;
    double jlo = fmax(floor(ylo), 0);
    double jhi = fmin(floor(yhi), (double)g->height - 1);
    for (double jd = jlo; jd <= jhi; jd++) {
        /* x extent of the triangle within the widened row strip: that of
         * its edges clipped to the strip. */
        double s0 = fmax(jd - margin, ylo), s1 = fmin(jd + 1 + margin, yhi);
        double xlo = INFINITY, xhi = -INFINITY;
        for (int k = 0; k < 3; k++) {
            const double *p = corner[k], *q = corner[(k + 1) % 3];
            double t0 = 0, t1 = 1, dy = q[1] - p[1];
            if (dy != 0) {
                t0 = (s0 - p[1]) / dy;
                t1 = (s1 - p[1]) / dy;
                if (t0 > t1) {
                    double swap = t0;
                    t0 = t1;
                    t1 = swap;
                }
                t0 = fmax(t0, 0);
                t1 = fmin(t1, 1);
            } else if (p[1] < s0 || p[1] > s1) {
                continue;
            }
            if (t0 > t1)
                continue;
            double x0 = p[0] + t0 * (q[0] - p[0]);
            double x1 = p[0] + t1 * (q[0] - p[0]);
            xlo = fmin(xlo, fmin(x0, x1));
            xhi = fmax(xhi, fmax(x0, x1));
        }
        if (!(xlo <= xhi))
            continue;
        double ilo = fmax(floor(xlo - margin), 0);
        double ihi = fmin(floor(xhi + margin), (double)g->width - 1);
        for (double id = ilo; id <= ihi; id++)
            visit(g, (size_t)jd * g->width + (size_t)id, t, ctx);
    }
}

static void count_cell(const cell_grid *g, size_t cell, size_t t, void *ctx)
{
    (void)t;
    (void)ctx;
    g->start[cell + 1]++;
}

static void fill_cell(const cell_grid *g, size_t cell, size_t t, void *ctx)
{
    size_t *next = ctx;
    g->item[next[cell]++] = t;
}

/* Whether triangle tri (view coordinates in view[]) covers the point
 * (q[0], q[1]), its boundary widened by slack, at a depth below limit
 * there. Triangles seen exactly edge-on cover nothing. */
static bool covers_nearer(const double *view, const uint32_t *tri,
                          const double *q, double slack, double limit)
{
    const double *a = view + 3 * (size_t)tri[0];
    const double *b = view + 3 * (size_t)tri[1];
    const double *c = view + 3 * (size_t)tri[2];
    double area2 =
        (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    if (area2 == 0)
        return false;
    double sign = area2 > 0 ? 1 : -1;
    const double *corner[3] = {a, b, c};
    double depth = 0;
    for (int k = 0; k < 3; k++) {
        const double *p = corner[(k + 1) % 3], *r = corner[(k + 2) % 3];
        double ex = r[0] - p[0], ey = r[1] - p[1];
        double e = sign * (ex * (q[1] - p[1]) - ey * (q[0] - p[0]));
        if (!(e >= -slack * sqrt(ex * ex + ey * ey)))
            return false;
        depth += e / fabs(area2) * corner[k][2];
    }
    return depth < limit;
}

int piece_partial_scan_dir(const double *xyz, size_t vertex_count,
                           const uint32_t *triangles, size_t triangle_count,
                           const double dir[3], piece *out)
{
    if (!out)
        return -1;
    memset(out, 0, sizeof *out);
    if (!dir || check_input(xyz, vertex_count, triangles, triangle_count))
        return -1;
    double d[3] = {dir[0], dir[1], dir[2]};
    if (!(fabs(d[0]) <= 1e300 && fabs(d[1]) <= 1e300 && fabs(d[2]) <= 1e300))
        return -1;
    double len = norm3(d);
    if (!(len > 0))
        return -1;
    for (int k = 0; k < 3; k++)
        d[k] /= len;

    /* Frame (u, w, d): u is the axis least along d, made orthogonal. */
    int axis = 0;
    for (int k = 1; k < 3; k++)
        if (fabs(d[k]) < fabs(d[axis]))
            axis = k;
    double u[3] = {0, 0, 0}, w[3];
    u[axis] = 1;
    for (int k = 0; k < 3; k++)
        u[k] -= d[axis] * d[k];
    double ul = norm3(u);
    for (int k = 0; k < 3; k++)
        u[k] /= ul;
    w[0] = d[1] * u[2] - d[2] * u[1];
    w[1] = d[2] * u[0] - d[0] * u[2];
    w[2] = d[0] * u[1] - d[1] * u[0];

    double *view = malloc(3 * vertex_count * sizeof *view);
    bool *used = calloc(vertex_count, sizeof *used);
    bool *keep = malloc(triangle_count * sizeof *keep);
    bool *shown = malloc(vertex_count * sizeof *shown);
    size_t *next = NULL;
    cell_grid g = {0, 0, 0, {0, 0}, NULL, NULL};
    int status = -1;
    if (!view || !used || !keep || !shown)
        goto done;

    for (size_t i = 0; i < 3 * triangle_count; i++)
        used[triangles[i]] = true;
    double lo[3] = {INFINITY, INFINITY, INFINITY};
    double hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t v = 0; v < vertex_count; v++) {
        if (!used[v])
            continue;
        const double *p = xyz + 3 * v;
        double *q = view + 3 * v;
        q[0] = p[0] * u[0] + p[1] * u[1] + p[2] * u[2];
        q[1] = p[0] * w[0] + p[1] * w[1] + p[2] * w[2];
        q[2] = p[0] * d[0] + p[1] * d[1] + p[2] * d[2];
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], q[k]);
            hi[k] = fmax(hi[k], q[k]);
        }
    }
    double extent = fmax(hi[0] - lo[0], hi[1] - lo[1]);
    if (!(extent > 0))
        goto done;   /* everything projects to one point: nothing is seen */
    double size = fmax(extent, hi[2] - lo[2]);
    double slack = COVER_SLACK * size;
    double depth_tolerance = DEPTH_TOLERANCE * size;

    double side = floor(sqrt((double)triangle_count) + 0.5);
    side = fmin(fmax(side, GRID_MIN), GRID_MAX);
    g.cell = extent / side;
    if (!(g.cell > 0))
        goto done;
    g.lo[0] = lo[0];
    g.lo[1] = lo[1];
    g.width = (size_t)fmin(floor((hi[0] - lo[0]) / g.cell), side) + 1;
    g.height = (size_t)fmin(floor((hi[1] - lo[1]) / g.cell), side) + 1;
    size_t cells = g.width * g.height;
    g.start = calloc(cells + 1, sizeof *g.start);
    next = malloc(cells * sizeof *next);
    if (!g.start || !next)
        goto done;

    /* Facing: |unit normal . d| > GRAZING, whatever the orientation. */
    for (size_t t = 0; t < triangle_count; t++) {
        double n[3];
        triangle_normal(xyz, triangles + 3 * t, n);
        double nl = norm3(n);
        keep[t] = nl > 0 && fabs(n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) >
                                GRAZING * nl;
    }

    /* Bucket every triangle, in grid coordinates, widened by well over the
     * cover slack so that no covering triangle is missed. */
    double margin = 4 * slack / g.cell + 1e-9;
    for (int pass = 0; pass < 2; pass++) {
        for (size_t t = 0; t < triangle_count; t++) {
            double p[3][2];
            for (int k = 0; k < 3; k++) {
                const double *q = view + 3 * (size_t)triangles[3 * t + k];
                p[k][0] = (q[0] - g.lo[0]) / g.cell;
                p[k][1] = (q[1] - g.lo[1]) / g.cell;
            }
            for_each_cell(&g, p[0], p[1], p[2], margin,
                          pass == 0 ? count_cell : fill_cell, t, next);
        }
        if (pass == 0) {
            for (size_t c = 0; c < cells; c++) {
                if (g.start[c + 1] > SIZE_MAX - g.start[c])
                    goto done;
                g.start[c + 1] += g.start[c];
                next[c] = g.start[c];
            }
            g.item = malloc((g.start[cells] ? g.start[cells] : 1) *
                            sizeof *g.item);
            if (!g.item)
                goto done;
        }
    }

    for (size_t v = 0; v < vertex_count; v++) {
        if (!used[v])
            continue;
        const double *q = view + 3 * v;
        double ci = fmin(fmax(floor((q[0] - g.lo[0]) / g.cell), 0),
                         (double)g.width - 1);
        double cj = fmin(fmax(floor((q[1] - g.lo[1]) / g.cell), 0),
                         (double)g.height - 1);
        size_t c = (size_t)cj * g.width + (size_t)ci;
        shown[v] = true;
        for (size_t k = g.start[c]; k < g.start[c + 1] && shown[v]; k++) {
            const uint32_t *tri = triangles + 3 * g.item[k];
            if (tri[0] != v && tri[1] != v && tri[2] != v &&
                covers_nearer(view, tri, q, slack, q[2] - depth_tolerance))
                shown[v] = false;
        }
    }
    for (size_t t = 0; t < triangle_count; t++)
        if (keep[t])
            for (int k = 0; k < 3; k++)
                if (!shown[triangles[3 * t + k]])
                    keep[t] = false;
    status = finish(xyz, vertex_count, triangles, triangle_count, keep, out);

done:
    free(view);
    free(used);
    free(keep);
    free(shown);
    free(next);
    free(g.start);
    free(g.item);
    return status;
}

int piece_partial_scan(const double *xyz, size_t vertex_count,
                       const uint32_t *triangles, size_t triangle_count,
                       uint64_t seed, piece *out)
{
    double dir[3];
    piece_view_direction(seed, dir);
    return piece_partial_scan_dir(xyz, vertex_count, triangles,
                                  triangle_count, dir, out);
}

/* ---------------------------------------------------------------------
 * Incomplete model.
 * --------------------------------------------------------------------- */
/* The k-th smallest of a[0..n) (0-based), reordering a: quickselect with
 * a three-way partition, so equal values cannot stall it. */
static double select_kth(double *a, size_t n, size_t k)
{
    while (n > 1) {
        double x = a[0], y = a[n / 2], z = a[n - 1];
        double pivot = x < y ? (y < z ? y : (x < z ? z : x))
                             : (x < z ? x : (y < z ? z : y));
        size_t lt = 0, i = 0, gt = n;
        while (i < gt) {
            double t = a[i];
            if (t < pivot) {
                a[i++] = a[lt];
                a[lt++] = t;
            } else if (t > pivot) {
                a[i] = a[--gt];
                a[gt] = t;
            } else {
                i++;
            }
        }
        if (k < lt) {
            n = lt;
        } else if (k >= gt) {
            a += gt;
            k -= gt;
            n -= gt;
        } else {
            return pivot;
        }
    }
    return a[0];
}

int piece_incomplete_planes(const double *xyz, size_t vertex_count,
                            const uint32_t *triangles, size_t triangle_count,
                            uint64_t seed, piece *out, double planes[8],
                            unsigned *plane_count)
{
    if (plane_count)
        *plane_count = 0;
    if (!out)
        return -1;
    memset(out, 0, sizeof *out);
    if (check_input(xyz, vertex_count, triangles, triangle_count))
        return -1;

    size_t edge_count = 0;
    edge_rec *edges = edges_build(triangles, triangle_count, &edge_count);
    double *area = triangle_areas(xyz, triangles, triangle_count);
    size_t *parent = malloc(triangle_count * sizeof *parent);
    double *piece_area = malloc(triangle_count * sizeof *piece_area);
    bool *keep = malloc(triangle_count * sizeof *keep);
    double *centroid = malloc(3 * triangle_count * sizeof *centroid);
    bool *used = calloc(vertex_count, sizeof *used);
    double *proj = malloc(vertex_count * sizeof *proj);
    int status = -1;
    if (!edges || !area || !parent || !piece_area || !keep || !centroid ||
        !used || !proj)
        goto done;

    double total = 0;
    for (size_t t = 0; t < triangle_count; t++) {
        total += area[t];
        const uint32_t *tri = triangles + 3 * t;
        for (int k = 0; k < 3; k++)
            centroid[3 * t + k] = (xyz[3 * (size_t)tri[0] + k] +
                                   xyz[3 * (size_t)tri[1] + k] +
                                   xyz[3 * (size_t)tri[2] + k]) / 3;
    }
    if (!(total > 0) || !(total < INFINITY))
        goto done;
    for (size_t i = 0; i < 3 * triangle_count; i++)
        used[triangles[i]] = true;

    uint64_t state = seed;
    for (int draw = 0; draw < MAX_DRAWS; draw++) {
        unsigned count = 1 + (unsigned)(rng_next(&state) >> 63);
        double plane[8];
        for (unsigned p = 0; p < count; p++) {
            double *n = plane + 4 * p;
            rng_direction(&state, n);
            double f = count == 1 ? 0.10 + 0.35 * rng_uniform(&state)
                                  : 0.05 + 0.25 * rng_uniform(&state);
            size_t m = 0;
            for (size_t v = 0; v < vertex_count; v++)
                if (used[v])
                    proj[m++] = xyz[3 * v] * n[0] + xyz[3 * v + 1] * n[1] +
                                xyz[3 * v + 2] * n[2];
            size_t k = (size_t)(f * (double)(m - 1));
            n[3] = -select_kth(proj, m, k);
        }
        for (size_t t = 0; t < triangle_count; t++) {
            const double *c = centroid + 3 * t;
            keep[t] = true;
            for (unsigned p = 0; p < count; p++) {
                const double *n = plane + 4 * p;
                if (!(n[0] * c[0] + n[1] * c[1] + n[2] * c[2] + n[3] >= 0))
                    keep[t] = false;
            }
        }
        double kept = largest_piece(triangle_count, keep, edges, edge_count,
                                    area, parent, piece_area);
        if (kept >= KEEP_MIN * total && kept <= KEEP_MAX * total) {
            status = piece_build(xyz, vertex_count, triangles, triangle_count,
                                 keep, out);
            if (status == 0) {
                if (planes)
                    memcpy(planes, plane, 4 * count * sizeof *plane);
                if (plane_count)
                    *plane_count = count;
            }
            break;
        }
    }

done:
    free(edges);
    free(area);
    free(parent);
    free(piece_area);
    free(keep);
    free(centroid);
    free(used);
    free(proj);
    return status;
}

int piece_incomplete(const double *xyz, size_t vertex_count,
                     const uint32_t *triangles, size_t triangle_count,
                     uint64_t seed, piece *out)
{
    return piece_incomplete_planes(xyz, vertex_count, triangles,
                                   triangle_count, seed, out, NULL, NULL);
}

void piece_free(piece *p)
{
    if (!p)
        return;
    free(p->xyz);
    free(p->triangles);
    free(p->source_vertex);
    memset(p, 0, sizeof *p);
}
