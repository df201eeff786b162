/*
 * boundary.c - distances to the mesh boundary. A cut or a scan's
 * silhouette inflates the heat kernel signature next to it (heat that would
 * have flowed across the cut stays), so the function that picks feature
 * points is tapered to zero there.
 */
#include "geometry/geometry.h"

#include <math.h>
#include <stdlib.h>

/* Positions of the vertices on boundary edges, each once, scaled. */
static phks_status boundary_points(const phks_mesh *mesh, double scale,
                                   double **points, size_t *count)
{
    size_t n = mesh->vertex_count, found = 0;
    bool *on = phks__calloc(n, sizeof *on);
    double *p = phks__malloc_array(2 * mesh->boundary_edge_count, 3 * sizeof *p);
    if (!on || !p) {
        phks__free(on);
        phks__free(p);
        return phks__fail_oom("boundary distances");
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
    phks__free(on);
    *points = p;
    *count = found;
    return PHKS_OK;
}

/* Squared distance from q to the nearest point in the cell (x, y, z),
 * folded into best; cells outside the grid hold nothing. */
static double nearest_in_cell(const phks__grid *g, const double *points,
                              const double *q, long x, long y, long z,
                              double best)
{
    if (x < 0 || y < 0 || z < 0 || x >= (long)g->dims[0] ||
        y >= (long)g->dims[1] || z >= (long)g->dims[2])
        return best;
    size_t cell = phks__grid_cell_index(g, (size_t)x, (size_t)y, (size_t)z);
    for (size_t k = g->cell_start[cell]; k < g->cell_start[cell + 1]; k++) {
        const double *p = points + 3 * (size_t)g->points[k];
        double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
        best = fmin(best, dx * dx + dy * dy + dz * dz);
    }
    return best;
}

/* Distance from q to the nearest grid point, or cap if none is nearer.
 * Shells of cells at growing Chebyshev distance r are searched until the
 * best distance found is below r cells (nothing farther out can beat it)
 * or the shell lies beyond cap, so the cost follows the distance found,
 * not cap. */
static double nearest_within(const phks__grid *g, const double *points,
                             const double *q, double cap)
{
    long c[3];
    for (int d = 0; d < 3; d++)
        c[d] = (long)floor((q[d] - g->origin[d]) / g->cell);
    double best = cap * cap;
    for (long r = 0;; r++) {
        for (long z = c[2] - r; z <= c[2] + r; z++)
            for (long y = c[1] - r; y <= c[1] + r; y++)
                for (long x = c[0] - r; x <= c[0] + r; x++) {
                    bool shell = labs(z - c[2]) == r || labs(y - c[1]) == r ||
                                 labs(x - c[0]) == r;
                    if (shell)
                        best = nearest_in_cell(g, points, q, x, y, z, best);
                }
        double reach = (double)r * g->cell;
        if (reach * reach >= best)
            break;
    }
    return sqrt(best);
}

typedef struct {
    const phks_mesh *mesh;
    const phks__grid *grid;
    const double *points;
    double scale, cap;
    double *distance;
} distance_ctx;

static void distance_rows(void *ctx, size_t begin, size_t end)
{
    const distance_ctx *c = ctx;
    for (size_t v = begin; v < end; v++) {
        double q[3];
        for (int d = 0; d < 3; d++)
            q[d] = c->mesh->xyz[3 * v + d] * c->scale;
        c->distance[v] = nearest_within(c->grid, c->points, q, c->cap);
    }
}

/* Vertices per batch between progress reports: a few milliseconds' work
 * when the boundary is near, more where its reach is wide. */
#define BATCH 16384

phks_status phks__boundary_distance(const phks__unit_mesh *um, double cap,
                                    phks__span at, double *distance)
{
    const phks_mesh *mesh = um->mesh;
    const double scale = um->scale;
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
    /* Cells a sixteenth of cap keep the shells near a vertex small; the
     * grid coarsens them where the boundary is sparse. */
    phks__grid grid = {0};
    st = phks__grid_build(points, found, 1, cap / 16, &grid);
    if (st == PHKS_OK) {
        distance_ctx c = {mesh, &grid, points, scale, cap, distance};
        /* Each vertex's distance is its own: any split gives the same. */
        st = phks__run_batched(n, at.opt ? phks__thread_count(at.opt) : 1,
                               distance_rows, &c, at, (n + BATCH - 1) / BATCH);
    }
    phks__grid_release(&grid);
    phks__free(points);
    return st;
}
