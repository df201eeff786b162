/*
 * local_area.c - how much surface lies near a point: the area of the mesh
 * within straight-line distance r of a vertex, for PHKS_HKS_SCALING_LOCAL_AREA.
 *
 * Why it is wanted: a partial scan keeps one side of every thin part, so
 * heat that spread over both sides of a leg stays on one, and HKS_t at a
 * point the scan shares with its whole doubles once the heat has had time
 * to reach the missing side (docs/retrieval.md has the ratios measured).
 * The area within the kernel's width
 * sqrt(4 t) halves with it, so HKS_t times that area is the same on a half
 * tube as on the whole one, and 1 on a plane.
 *
 * Straight-line distance, not geodesic, on purpose: the operator's kernel
 * joins the two sides of a part thinner than its width, and the area must
 * count what the heat reached.
 */
#include "geometry/geometry.h"

void phks__local_areas(const phks__surface *surface, size_t point,
                       const double *radius2, size_t count, double *area)
{
    const double scale = surface->scale;
    const double *x = surface->xyz + 3 * point;
    for (size_t s = 0; s < count; s++)
        area[s] = 0;
    for (size_t v = 0; v < surface->n; v++) {
        const double *y = surface->xyz + 3 * v;
        double dx = (y[0] - x[0]) * scale, dy = (y[1] - x[1]) * scale,
               dz = (y[2] - x[2]) * scale, d2 = dx * dx + dy * dy + dz * dz;
        for (size_t s = 0; s < count; s++)
            if (d2 <= radius2[s])
                area[s] += surface->area[v];
    }
}
