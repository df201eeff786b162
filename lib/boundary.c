/*
 * boundary.c - distances to the mesh boundary. A cut or a scan's
 * silhouette inflates the heat kernel signature next to it (heat that would
 * have flowed across the cut stays), so the function that picks feature
 * points is tapered to zero there.
 */
#include "internal.h"

#include <math.h>

/* Positions of the vertices on boundary edges, each once, scaled. */
static phks_status boundary_points(const phks_mesh *mesh, double scale,
                                   double **points, size_t *count)
{
    size_t n = mesh->vertex_count, found = 0;
    bool *on = phks_calloc(n, sizeof *on);
    double *p = phks_malloc_array(2 * mesh->boundary_edge_count, 3 * sizeof *p);
    if (!on || !p) {
        phks_free(on);
        phks_free(p);
        return phks_fail_oom("boundary distances");
    }
    for (size_t e = 0; e < 2 * mesh->boundary_edge_count; e++) {
        uint32_t v = mesh->boundary_edges[e];
        if (on[v])
            continue;
        on[v] = true;
        for (int d = 0; d < 3; d++)
            p[3 * found + d] = mesh->xyz[3 * (size_t)v + d] * scale;
        found++;
    }
    phks_free(on);
    *points = p;
    *count = found;
    return PHKS_OK;
}

/* Distance from q to the nearest point of the grid, or cap if none is
 * nearer (the grid's cells are at least cap wide). */
static double nearest_within(const phks_grid *g, const double *points,
                             const double *q, double cap)
{
    long c[3];
    for (int d = 0; d < 3; d++)
        c[d] = (long)floor((q[d] - g->origin[d]) / g->cell);
    double best = cap * cap;
    for (long z = c[2] - 1; z <= c[2] + 1; z++)
        for (long y = c[1] - 1; y <= c[1] + 1; y++)
            for (long x = c[0] - 1; x <= c[0] + 1; x++) {
                if (x < 0 || y < 0 || z < 0 || x >= (long)g->dims[0] ||
                    y >= (long)g->dims[1] || z >= (long)g->dims[2])
                    continue;
                size_t cell = ((size_t)z * g->dims[1] + (size_t)y) * g->dims[0] +
                              (size_t)x;
                for (size_t k = g->cell_start[cell]; k < g->cell_start[cell + 1];
                     k++) {
                    const double *p = points + 3 * (size_t)g->points[k];
                    double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
                    best = fmin(best, dx * dx + dy * dy + dz * dz);
                }
            }
    return sqrt(best);
}

phks_status phks_boundary_distance(const phks_mesh *mesh, double scale,
                                   double cap, double *distance)
{
    size_t n = mesh->vertex_count;
    for (size_t v = 0; v < n; v++)
        distance[v] = cap;
    if (mesh->boundary_edge_count == 0)
        return PHKS_OK;
    double *points = NULL;
    size_t found = 0;
    phks_status st = boundary_points(mesh, scale, &points, &found);
    if (st != PHKS_OK)
        return st;
    /* The grid may coarsen its cells; they never get smaller than cap, so
     * the 27 cells around a point hold every point within cap of it. */
    phks_grid grid = {0};
    st = phks_grid_build(points, found, 1, cap, &grid);
    for (size_t v = 0; st == PHKS_OK && v < n; v++) {
        double q[3];
        for (int d = 0; d < 3; d++)
            q[d] = mesh->xyz[3 * v + d] * scale;
        distance[v] = nearest_within(&grid, points, q, cap);
    }
    phks_grid_release(&grid);
    phks_free(points);
    return st;
}
