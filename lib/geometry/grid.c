/*
 * grid.c - a uniform grid of cubic cells for fixed-radius neighbour
 * queries: with the cell as large as the radius, the neighbours of a point
 * lie in its own cell and the 26 around it, which are 9 rows of 3 cells
 * consecutive in the cell order, so 9 stretches of the sorted points.
 */
#include "geometry/geometry.h"

#include <math.h>

/* More cells than points only wastes memory: the grid is coarsened until
 * the cell count is at most a small multiple of the point count. */
#define MAX_CELLS_PER_POINT 8

void phks__grid_release(phks__grid *g)
{
    phks__free(g->cell_start);
    phks__free(g->points);
    g->cell_start = NULL;
    g->points = NULL;
}

void phks__grid_cell(const phks__grid *g, const double p[3], size_t c[3])
{
    for (int d = 0; d < 3; d++) {
        double x = floor((p[d] - g->origin[d]) / g->cell);
        c[d] = x < 0 ? 0 : x >= (double)g->dims[d] ? g->dims[d] - 1 : (size_t)x;
    }
}

size_t phks__grid_neighbourhood(const phks__grid *g, const size_t c[3],
                               size_t range[9][2])
{
    size_t count = 0;
    size_t x0 = c[0] ? c[0] - 1 : 0, x1 = c[0] + 1 < g->dims[0] ? c[0] + 1 : c[0];
    for (size_t z = c[2] ? c[2] - 1 : 0; z <= c[2] + 1 && z < g->dims[2]; z++)
        for (size_t y = c[1] ? c[1] - 1 : 0; y <= c[1] + 1 && y < g->dims[1]; y++) {
            size_t row = (z * g->dims[1] + y) * g->dims[0];
            range[count][0] = g->cell_start[row + x0];
            range[count][1] = g->cell_start[row + x1 + 1];
            count++;
        }
    return count;
}

static size_t cell_of(const phks__grid *g, const double *xyz, double scale)
{
    double p[3] = {xyz[0] * scale, xyz[1] * scale, xyz[2] * scale};
    size_t c[3];
    phks__grid_cell(g, p, c);
    return phks__grid_cell_index(g, c[0], c[1], c[2]);
}

phks_status phks__grid_build(const double *xyz, size_t n, double scale,
                            double cell, phks__grid *g)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY};
    double hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < n; i++)
        for (int d = 0; d < 3; d++) {
            lo[d] = fmin(lo[d], xyz[3 * i + d] * scale);
            hi[d] = fmax(hi[d], xyz[3 * i + d] * scale);
        }
    for (;;) {
        double cells = 1;
        for (int d = 0; d < 3; d++)
            cells *= floor((hi[d] - lo[d]) / cell) + 1;
        if (cells <= (double)MAX_CELLS_PER_POINT * (double)n + 64)
            break;
        cell *= 1.25;
    }
    g->cell = cell;
    size_t total = 1;
    for (int d = 0; d < 3; d++) {
        g->origin[d] = lo[d];
        g->dims[d] = (size_t)floor((hi[d] - lo[d]) / cell) + 1;
        total *= g->dims[d];
    }
    g->cell_start = phks__calloc(total + 1, sizeof *g->cell_start);
    g->points = phks__malloc_array(n, sizeof *g->points);
    if (!g->cell_start || !g->points) {
        phks__grid_release(g);
        return phks__fail_oom("spatial grid");
    }
    for (size_t i = 0; i < n; i++)
        g->cell_start[cell_of(g, xyz + 3 * i, scale) + 1]++;
    for (size_t c = 0; c < total; c++)
        g->cell_start[c + 1] += g->cell_start[c];
    /* Fill in point order so every cell lists its points ascending. */
    for (size_t i = 0; i < n; i++)
        g->points[g->cell_start[cell_of(g, xyz + 3 * i, scale)]++] = (uint32_t)i;
    for (size_t c = total; c > 0; c--)
        g->cell_start[c] = g->cell_start[c - 1];
    g->cell_start[0] = 0;
    return PHKS_OK;
}
