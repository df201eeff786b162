/*
 * shape_distribution.c - the shape distribution D2 of Osada, Funkhouser,
 * Chazelle and Dobkin (2002): how the straight-line distances between
 * points of the surface are distributed (docs/method.md section 16).
 *
 * The points are spread by area, not read at the vertices, so that a
 * face of two long triangles and the same face finely meshed give the
 * same distribution, and they are placed without a random generator, so
 * that the bytes are the same on every run: the k-th of n points lies at
 * (k + 1/2) / n of the way through the surface's area, taken triangle by
 * triangle in their order, and within its triangle at the k-th point of
 * Roberts' R2 sequence, the low-discrepancy sequence of the plastic
 * number, folded into the triangle. Every pair of the points then gives a
 * distance; the distances are measured in units of their mean, so that
 * neither the shape's scale nor its unit box matters.
 */
#include "geometry/geometry.h"

#include <math.h>
#include <string.h>

/* 1 / p and 1 / p^2 for the plastic number p, the real root of
 * x^3 = x + 1: the steps of the R2 sequence in the unit square. */
#define R2_STEP_U 0.7548776662466927
#define R2_STEP_V 0.5698402909980532

/* The area of the triangles up to and including each one. */
static void running_areas(const phks_mesh *mesh, double *running)
{
    double sum = 0;
    for (size_t t = 0; t < mesh->triangle_count; t++) {
        const uint32_t *c = mesh->triangles + 3 * t;
        sum += phks__triangle_area(mesh->xyz + 3 * (size_t)c[0],
                                   mesh->xyz + 3 * (size_t)c[1],
                                   mesh->xyz + 3 * (size_t)c[2]);
        running[t] = sum;
    }
}

/* The first triangle whose running area reaches `at`, the last one past
 * the end (rounding). */
static size_t triangle_at(const double *running, size_t count, double at)
{
    size_t low = 0, high = count - 1;
    while (low < high) {
        size_t mid = low + (high - low) / 2;
        if (running[mid] < at)
            low = mid + 1;
        else
            high = mid;
    }
    return low;
}

/* The k-th point of the R2 sequence folded into triangle t: a point of the
 * unit square above its diagonal is reflected through the diagonal's
 * midpoint, which keeps the points uniform over the triangle. */
static void point_in_triangle(const phks_mesh *mesh, size_t t, size_t k,
                              double *out)
{
    double u = fmod(0.5 + (double)k * R2_STEP_U, 1.0);
    double v = fmod(0.5 + (double)k * R2_STEP_V, 1.0);
    if (u + v > 1) {
        u = 1 - u;
        v = 1 - v;
    }
    const uint32_t *c = mesh->triangles + 3 * t;
    const double *a = mesh->xyz + 3 * (size_t)c[0];
    const double *b = mesh->xyz + 3 * (size_t)c[1];
    const double *d = mesh->xyz + 3 * (size_t)c[2];
    for (int i = 0; i < 3; i++)
        out[i] = a[i] + u * (b[i] - a[i]) + v * (d[i] - a[i]);
}

static double distance(const double *p, const double *q)
{
    double d2 = 0;
    for (int i = 0; i < 3; i++)
        d2 += (p[i] - q[i]) * (p[i] - q[i]);
    return sqrt(d2);
}

static double mean_distance(const double *points, size_t n)
{
    double sum = 0;
    for (size_t i = 0; i < n; i++)
        for (size_t j = 0; j < i; j++)
            sum += distance(points + 3 * i, points + 3 * j);
    return sum / ((double)n * (double)(n - 1) / 2);
}

/* Each pair's distance, in units of mean, counted into its bin. The
 * distances are computed again rather than kept from mean_distance: 2.1
 * million of them would be 17 MB for a few milliseconds saved. */
static void count_pairs(const double *points, size_t n, double mean,
                        uint64_t *count)
{
    const double per_unit = PHKS__SHAPE_BINS / PHKS__SHAPE_RANGE;
    for (size_t i = 0; i < n; i++)
        for (size_t j = 0; j < i; j++) {
            double x = mean > 0
                ? distance(points + 3 * i, points + 3 * j) / mean * per_unit
                : 0;
            count[x < PHKS__SHAPE_BINS - 1 ? (size_t)x
                                           : PHKS__SHAPE_BINS - 1]++;
        }
}

phks_status phks__shape_distribution(const phks__unit_mesh *um,
                                     uint8_t out[PHKS__SHAPE_BINS])
{
    const phks_mesh *mesh = um->mesh;
    const size_t n = PHKS__SHAPE_POINTS;
    memset(out, 0, PHKS__SHAPE_BINS);
    if (mesh->triangle_count == 0)
        return PHKS_OK;
    double *running = phks__malloc_array(mesh->triangle_count + 1,
                                         sizeof *running);
    double *points = phks__malloc_array(n, 3 * sizeof *points);
    if (!running || !points) {
        phks__free(running);
        phks__free(points);
        return phks__fail_oom("shape distribution");
    }
    running_areas(mesh, running);
    double total = running[mesh->triangle_count - 1];
    for (size_t k = 0; k < n; k++) {
        size_t t = triangle_at(running, mesh->triangle_count,
                               ((double)k + 0.5) / (double)n * total);
        point_in_triangle(mesh, t, k, points + 3 * k);
    }
    uint64_t count[PHKS__SHAPE_BINS] = {0};
    count_pairs(points, n, mean_distance(points, n), count);
    double pairs = (double)n * (double)(n - 1) / 2;
    for (size_t b = 0; b < PHKS__SHAPE_BINS; b++)
        out[b] = (uint8_t)lround(255 * sqrt((double)count[b] / pairs));
    phks__free(running);
    phks__free(points);
    return PHKS_OK;
}
