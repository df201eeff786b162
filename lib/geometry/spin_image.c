/*
 * spin_image.c - each point's spin images (Johnson and Hebert 1999): how
 * the area of the surface around it lies by distance from its normal line
 * and height along that normal, in balls of several radii (docs/method.md
 * section 15).
 *
 * The surface is integrated over its triangles, not read at its vertices:
 * a triangle is split in four until its pieces are smaller than a bin of
 * the smallest image or lie wholly outside the largest ball, and each
 * piece's area goes to the bin of its centroid. A long CAD triangle then
 * weighs what its area does, and a coarse and a fine triangulation of one
 * surface give about the same images; shells and unwelded seams change
 * nothing, since only positions and areas are read.
 *
 * The normal is the direction in which the area of the smallest ball
 * spreads least (the least eigenvector of its second moments about their
 * centre). Its sign is not read from the triangles' winding, which soups
 * do not keep consistent: it is turned so that the area of the largest
 * ball lies, on average, at or below the point. A cut or a pose change
 * away from a ball leaves its image alone; each image is a distribution
 * (the bins' shares of the ball's area), so a ball that a cut halves
 * keeps its shape where the surface around the normal looks alike on
 * every side.
 */
#include "geometry/geometry.h"

#include <math.h>
#include <string.h>

/* The largest radius, r_k = PHKS__SPIN_RADIUS 2^(k/2). */
#define LARGEST_RADIUS (PHKS__SPIN_RADIUS * 4)
/* Pieces are split until each corner lies within this of their centroid:
 * a fifth of the smallest image's narrowest bin (its distance bins are
 * r_0 / 4 wide), so that binning by centroid blurs the image little. */
#define PIECE_RADIUS (PHKS__SPIN_RADIUS / PHKS__SPIN_ALPHA / 5)
/* Splits of one triangle, at most: a triangle of the whole unit box's
 * size reaches PIECE_RADIUS in 8. */
#define MOST_SPLITS 12
/* A triangle whose box covers more cells of the index than this is
 * looked at for every point instead (a long CAD triangle). */
#define MOST_CELLS 64

/* A piece of the surface near a point: its centroid relative to the
 * point, in the unit box, and its area there. */
typedef struct piece {
    double at[3];
    double area;
} piece;

typedef struct pieces {
    piece *p;
    size_t count, room;
    bool failed;
} pieces;

/* The triangles by the cells of a grid their boxes meet, so that a
 * point's ball visits the triangles near it only. */
typedef struct triangle_index {
    double origin[3], cell;
    size_t dims[3];
    size_t *start;        /* cells + 1 offsets into triangles            */
    uint32_t *triangles;
    uint32_t *everywhere; /* triangles met by more than MOST_CELLS      */
    size_t everywhere_count;
    uint32_t *seen;       /* per triangle: the last point that took it   */
} triangle_index;

static void corner(const phks__unit_mesh *um, uint32_t v, double out[3])
{
    for (int d = 0; d < 3; d++)
        out[d] = um->mesh->xyz[3 * (size_t)v + d] * um->scale;
}

/* The range of cells, per axis, that the box [lo, hi] meets. */
static void cell_range(const triangle_index *ix, const double lo[3],
                       const double hi[3], size_t first[3], size_t last[3])
{
    for (int d = 0; d < 3; d++) {
        double a = floor((lo[d] - ix->origin[d]) / ix->cell);
        double b = floor((hi[d] - ix->origin[d]) / ix->cell);
        double top = (double)(ix->dims[d] - 1);
        first[d] = (size_t)fmin(fmax(a, 0), top);
        last[d] = (size_t)fmin(fmax(b, 0), top);
    }
}

static size_t cells_in(const size_t first[3], const size_t last[3])
{
    return (last[0] - first[0] + 1) * (last[1] - first[1] + 1) *
           (last[2] - first[2] + 1);
}

static void triangle_box(const phks__unit_mesh *um, size_t t, double lo[3],
                         double hi[3])
{
    const uint32_t *tri = um->mesh->triangles + 3 * t;
    corner(um, tri[0], lo);
    memcpy(hi, lo, sizeof(double[3]));
    for (int k = 1; k < 3; k++) {
        double p[3];
        corner(um, tri[k], p);
        for (int d = 0; d < 3; d++) {
            lo[d] = fmin(lo[d], p[d]);
            hi[d] = fmax(hi[d], p[d]);
        }
    }
}

/* The cells that triangle t's box meets, into first and last; false when
 * they are more than MOST_CELLS. */
static bool cells_of(const phks__unit_mesh *um, const triangle_index *ix,
                     size_t t, size_t first[3], size_t last[3])
{
    double lo[3], hi[3];
    triangle_box(um, t, lo, hi);
    cell_range(ix, lo, hi, first, last);
    return cells_in(first, last) <= MOST_CELLS;
}

static void index_release(triangle_index *ix)
{
    phks__free(ix->start);
    phks__free(ix->triangles);
    phks__free(ix->everywhere);
    phks__free(ix->seen);
}

/* The grid's extent: the mesh's box in the unit box, cells of half the
 * largest radius (a ball then visits at most 5 cells a side). */
static void index_frame(const phks__unit_mesh *um, triangle_index *ix)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3];
    for (int d = 0; d < 3; d++)
        hi[d] = -INFINITY;
    for (size_t v = 0; v < um->mesh->vertex_count; v++) {
        double p[3];
        corner(um, (uint32_t)v, p);
        for (int d = 0; d < 3; d++) {
            lo[d] = fmin(lo[d], p[d]);
            hi[d] = fmax(hi[d], p[d]);
        }
    }
    ix->cell = LARGEST_RADIUS / 2;
    for (int d = 0; d < 3; d++) {
        ix->origin[d] = lo[d];
        double cells = floor((hi[d] - lo[d]) / ix->cell) + 1;
        ix->dims[d] = (size_t)fmin(fmax(cells, 1), 1024);
    }
    /* A mesh far larger than the unit box (never one phks__unit_mesh
     * makes) would need more cells: widen them instead. */
    for (int d = 0; d < 3; d++)
        ix->cell = fmax(ix->cell, (hi[d] - lo[d]) / 1024);
}

static phks_status index_build(const phks__unit_mesh *um, triangle_index *ix)
{
    memset(ix, 0, sizeof *ix);
    index_frame(um, ix);
    size_t cells = ix->dims[0] * ix->dims[1] * ix->dims[2];
    size_t nt = um->mesh->triangle_count;
    ix->start = phks__calloc(cells + 1, sizeof *ix->start);
    ix->seen = phks__malloc_array(nt ? nt : 1, sizeof *ix->seen);
    if (!ix->start || !ix->seen)
        return PHKS_ERROR_OUT_OF_MEMORY;
    size_t far = 0, first[3], last[3];
    for (size_t t = 0; t < nt; t++) {
        ix->seen[t] = UINT32_MAX;
        if (!cells_of(um, ix, t, first, last)) {
            far++;
            continue;
        }
        for (size_t z = first[2]; z <= last[2]; z++)
            for (size_t y = first[1]; y <= last[1]; y++)
                for (size_t x = first[0]; x <= last[0]; x++)
                    ix->start[(z * ix->dims[1] + y) * ix->dims[0] + x + 1]++;
    }
    for (size_t c = 0; c < cells; c++)
        ix->start[c + 1] += ix->start[c];
    ix->triangles = phks__malloc_array(ix->start[cells] ? ix->start[cells] : 1,
                                       sizeof *ix->triangles);
    ix->everywhere = phks__malloc_array(far ? far : 1, sizeof *ix->everywhere);
    size_t *fill = phks__malloc_array(cells, sizeof *fill);
    if (!ix->triangles || !ix->everywhere || !fill) {
        phks__free(fill);
        return PHKS_ERROR_OUT_OF_MEMORY;
    }
    memcpy(fill, ix->start, cells * sizeof *fill);
    for (size_t t = 0; t < nt; t++) {
        if (!cells_of(um, ix, t, first, last)) {
            ix->everywhere[ix->everywhere_count++] = (uint32_t)t;
            continue;
        }
        for (size_t z = first[2]; z <= last[2]; z++)
            for (size_t y = first[1]; y <= last[1]; y++)
                for (size_t x = first[0]; x <= last[0]; x++)
                    ix->triangles[fill[(z * ix->dims[1] + y) * ix->dims[0] +
                                       x]++] = (uint32_t)t;
    }
    phks__free(fill);
    return PHKS_OK;
}

static void keep_piece(pieces *out, const double at[3], double area)
{
    if (out->count == out->room) {
        size_t room = out->room ? 2 * out->room : 1024;
        piece *p = phks__realloc_array(out->p, room, sizeof *p);
        if (!p) {
            out->failed = true;
            return;
        }
        out->p = p;
        out->room = room;
    }
    piece *p = out->p + out->count++;
    memcpy(p->at, at, sizeof p->at);
    p->area = area;
}

static double length3(const double v[3])
{
    return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

/* The pieces of the triangle (a, b, c), corners relative to the point,
 * of area `area`, that may lie within LARGEST_RADIUS: split at the edges'
 * midpoints into four of a quarter of the area each. */
static void split(const double a[3], const double b[3], const double c[3],
                  double area, int splits, pieces *out)
{
    double g[3], far = 0;
    for (int d = 0; d < 3; d++)
        g[d] = (a[d] + b[d] + c[d]) / 3;
    const double *corners[3] = {a, b, c};
    for (int k = 0; k < 3; k++) {
        double e[3] = {corners[k][0] - g[0], corners[k][1] - g[1],
                       corners[k][2] - g[2]};
        far = fmax(far, length3(e));
    }
    if (length3(g) - far > LARGEST_RADIUS)
        return;
    if (far <= PIECE_RADIUS || splits == MOST_SPLITS) {
        keep_piece(out, g, area);
        return;
    }
    double ab[3], bc[3], ca[3];
    for (int d = 0; d < 3; d++) {
        ab[d] = (a[d] + b[d]) / 2;
        bc[d] = (b[d] + c[d]) / 2;
        ca[d] = (c[d] + a[d]) / 2;
    }
    split(a, ab, ca, area / 4, splits + 1, out);
    split(ab, b, bc, area / 4, splits + 1, out);
    split(ca, bc, c, area / 4, splits + 1, out);
    split(ab, bc, ca, area / 4, splits + 1, out);
}

static void take_triangle(const phks__unit_mesh *um, triangle_index *ix,
                          uint32_t t, uint32_t point, const double at[3],
                          pieces *out)
{
    if (ix->seen[t] == point)
        return;
    ix->seen[t] = point;
    const uint32_t *tri = um->mesh->triangles + 3 * (size_t)t;
    double p[3][3];
    for (int k = 0; k < 3; k++) {
        corner(um, tri[k], p[k]);
        for (int d = 0; d < 3; d++)
            p[k][d] -= at[d];
    }
    split(p[0], p[1], p[2], phks__triangle_area(p[0], p[1], p[2]), 0, out);
}

/* The pieces of the surface within LARGEST_RADIUS of `at`, the point of
 * number `point` (which tells the triangles it took from those it has
 * not), in the index's order. */
static void gather(const phks__unit_mesh *um, triangle_index *ix,
                   uint32_t point, const double at[3], pieces *out)
{
    double lo[3], hi[3];
    for (int d = 0; d < 3; d++) {
        lo[d] = at[d] - LARGEST_RADIUS;
        hi[d] = at[d] + LARGEST_RADIUS;
    }
    size_t first[3], last[3];
    cell_range(ix, lo, hi, first, last);
    out->count = 0;
    for (size_t z = first[2]; z <= last[2]; z++)
        for (size_t y = first[1]; y <= last[1]; y++)
            for (size_t x = first[0]; x <= last[0]; x++) {
                size_t c = (z * ix->dims[1] + y) * ix->dims[0] + x;
                for (size_t k = ix->start[c]; k < ix->start[c + 1]; k++)
                    take_triangle(um, ix, ix->triangles[k], point, at, out);
            }
    for (size_t k = 0; k < ix->everywhere_count; k++)
        take_triangle(um, ix, ix->everywhere[k], point, at, out);
}

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* The normal (see the top comment) into n; false when the smallest ball
 * holds no area. */
static bool normal_of(const pieces *ps, double n[3])
{
    const double r2 = PHKS__SPIN_RADIUS * PHKS__SPIN_RADIUS;
    double total = 0, mean[3] = {0, 0, 0};
    for (size_t k = 0; k < ps->count; k++) {
        const piece *p = ps->p + k;
        if (dot3(p->at, p->at) > r2)
            continue;
        total += p->area;
        for (int d = 0; d < 3; d++)
            mean[d] += p->area * p->at[d];
    }
    if (!(total > 0))
        return false;
    for (int d = 0; d < 3; d++)
        mean[d] /= total;
    double m[9] = {0};
    for (size_t k = 0; k < ps->count; k++) {
        const piece *p = ps->p + k;
        if (dot3(p->at, p->at) > r2)
            continue;
        double e[3] = {p->at[0] - mean[0], p->at[1] - mean[1],
                       p->at[2] - mean[2]};
        for (int i = 0; i < 3; i++)
            for (int j = i; j < 3; j++)
                m[3 * i + j] += p->area * e[i] * e[j];
    }
    double values[3], vectors[9];
    phks__sym3_eigen(m, values, vectors);
    for (int d = 0; d < 3; d++)
        n[d] = vectors[3 * d];
    double height = 0;
    for (size_t k = 0; k < ps->count; k++)
        height += ps->p[k].area * dot3(ps->p[k].at, n);
    if (height > 0)
        for (int d = 0; d < 3; d++)
            n[d] = -n[d];
    return true;
}

/* Bin index of x in [0, 1) over `bins` bins, the ends clamped. */
static size_t bin_of(double x, size_t bins)
{
    double b = floor(x * (double)bins);
    return (size_t)fmin(fmax(b, 0), (double)(bins - 1));
}

/* The images of the pieces about normal n into out (PHKS__SPIN_BYTES). */
static void images(const pieces *ps, const double n[3], uint8_t *out)
{
    double bins[PHKS__SPIN_RADII][PHKS__SPIN_IMAGE] = {{0}};
    double total[PHKS__SPIN_RADII] = {0}, radii[PHKS__SPIN_RADII];
    for (int r = 0; r < PHKS__SPIN_RADII; r++)
        radii[r] = PHKS__SPIN_RADIUS * exp2(r / 2.0);
    for (size_t k = 0; k < ps->count; k++) {
        const piece *p = ps->p + k;
        double d2 = dot3(p->at, p->at), beta = dot3(p->at, n);
        double alpha = sqrt(fmax(d2 - beta * beta, 0));
        for (int r = 0; r < PHKS__SPIN_RADII; r++) {
            double radius = radii[r];
            if (d2 > radius * radius)
                continue;
            size_t i = bin_of(alpha / radius, PHKS__SPIN_ALPHA);
            size_t j = bin_of((beta + radius) / (2 * radius), PHKS__SPIN_BETA);
            bins[r][i * PHKS__SPIN_BETA + j] += p->area;
            total[r] += p->area;
        }
    }
    for (int r = 0; r < PHKS__SPIN_RADII; r++)
        for (int b = 0; b < PHKS__SPIN_IMAGE; b++) {
            double share = total[r] > 0 ? bins[r][b] / total[r] : 0;
            out[r * PHKS__SPIN_IMAGE + b] = (uint8_t)lround(255 * sqrt(share));
        }
}

phks_status phks__spin_images(const phks__unit_mesh *um,
                              const uint32_t *vertices, size_t count,
                              uint8_t *out)
{
    triangle_index ix;
    pieces ps = {0};
    phks_status st = index_build(um, &ix);
    for (size_t k = 0; st == PHKS_OK && k < count; k++) {
        double at[3], n[3];
        corner(um, vertices[k], at);
        gather(um, &ix, (uint32_t)k, at, &ps);
        if (ps.failed) {
            st = PHKS_ERROR_OUT_OF_MEMORY;
            break;
        }
        uint8_t *image = out + k * PHKS__SPIN_BYTES;
        memset(image, 0, PHKS__SPIN_BYTES);
        if (normal_of(&ps, n))
            images(&ps, n, image);
    }
    index_release(&ix);
    phks__free(ps.p);
    return st == PHKS_OK ? PHKS_OK : phks__fail_oom("spin images");
}
