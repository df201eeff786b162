/*
 * boundary.c - which vertices lie close to the mesh boundary. A cut or a
 * scan's silhouette inflates the heat kernel signature next to it (heat
 * that would have flowed across the cut stays), so feature points can be
 * kept away from it.
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

static bool any_within(const phks_grid *g, const double *points,
                       const double *q, double radius)
{
    long c[3];
    for (int d = 0; d < 3; d++)
        c[d] = (long)floor((q[d] - g->origin[d]) / g->cell);
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
                    if (dx * dx + dy * dy + dz * dz < radius * radius)
                        return true;
                }
            }
    return false;
}

phks_status phks_near_boundary(const phks_mesh *mesh, double scale,
                               double radius, const uint32_t *vertices,
                               size_t count, bool *near)
{
    for (size_t i = 0; i < count; i++)
        near[i] = false;
    if (mesh->boundary_edge_count == 0 || !(radius > 0))
        return PHKS_OK;
    double *points = NULL;
    size_t found = 0;
    phks_status st = boundary_points(mesh, scale, &points, &found);
    if (st != PHKS_OK)
        return st;
    /* The grid may coarsen its cells; they never get smaller than radius,
     * so the 27 cells around a point still hold every point within it. */
    phks_grid grid = {0};
    st = phks_grid_build(points, found, 1, radius, &grid);
    for (size_t i = 0; st == PHKS_OK && i < count; i++) {
        double q[3];
        for (int d = 0; d < 3; d++)
            q[d] = mesh->xyz[3 * (size_t)vertices[i] + d] * scale;
        near[i] = any_within(&grid, points, q, radius);
    }
    phks_grid_release(&grid);
    phks_free(points);
    return st;
}
