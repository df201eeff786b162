/*
 * signature_layout.c - where a VERIFIED signature's points lie: samples
 * spread over the surface beside the persistent maxima, the distances
 * along the surface between all of them, and each one's distance to the
 * boundary. Unlike a point's heat values, a pair's distance carries the
 * layout of the shape and bending does not change it; the samples give a
 * part of a shape, whose maxima are not its whole's, places to land on
 * (docs/method.md section 14).
 */
#include "features/features.h"

#include <math.h>

/* nearest[v]: the squared distance from v to the nearest chosen vertex,
 * now that `chosen` is one. */
static void move_away(const phks__unit_mesh *um, uint32_t chosen,
                      double *nearest)
{
    for (size_t v = 0; v < um->mesh->vertex_count; v++)
        nearest[v] = fmin(nearest[v], phks__unit_distance2(um, v, chosen));
}

phks_status phks__spread_vertices(const phks__unit_mesh *um,
                                  const uint32_t *given, size_t given_count,
                                  size_t wanted, uint32_t *out, size_t *picked)
{
    size_t n = um->mesh->vertex_count;
    double *nearest = phks__malloc_array(n, sizeof *nearest);
    *picked = 0;
    if (!nearest)
        return phks__fail_oom("spread samples");
    for (size_t v = 0; v < n; v++)
        nearest[v] = INFINITY;
    for (size_t g = 0; g < given_count; g++)
        move_away(um, given[g], nearest);
    while (*picked < wanted) {
        size_t far = 0;
        for (size_t v = 1; v < n; v++)
            if (nearest[v] > nearest[far])
                far = v;
        if (!(nearest[far] > 0))
            break;
        out[(*picked)++] = (uint32_t)far;
        move_away(um, (uint32_t)far, nearest);
    }
    phks__free(nearest);
    return PHKS_OK;
}

/* Straight-line distance to the nearest vertex of a boundary edge, by
 * brute force over them: a few dozen points against the boundary. */
static float boundary_distance(const phks__unit_mesh *um, uint32_t v)
{
    const phks_mesh *m = um->mesh;
    double best = INFINITY;
    for (size_t e = 0; e < 2 * m->boundary_edge_count; e++)
        best = fmin(best, phks__unit_distance2(um, v, m->boundary_edges[e]));
    return (float)sqrt(best);
}

phks_status phks__signature_layout(const phks__unit_mesh *um,
                                   const phks_options *opt,
                                   phks_signature *sig)
{
    phks_status st = phks__signature_alloc_layout(sig);
    if (st != PHKS_OK)
        return st;
    size_t points = phks__signature_points(sig);
    for (size_t i = 0; i < points; i++)
        sig->boundary[i] = boundary_distance(um, sig->vertex[i]);
    if (points < 2)
        return PHKS_OK;
    /* A mesh on the HKS-simp path gets a graph of about as many nodes as
     * HKS-simp has samples: 35 searches over millions of vertices would
     * cost more than the signature (docs/benchmarks.md). */
    double cell = 0;
    const phks_mesh *m = um->mesh;
    if (opt->simplify_above && m->vertex_count > opt->simplify_above &&
        m->vertex_count > opt->simplify_target)
        cell = sqrt(m->area * um->scale * um->scale / opt->simplify_target);
    phks__geodesic_graph graph;
    st = phks__geodesic_graph_build(um, opt->cutoff * sqrt(4 * opt->tau), cell,
                                    &graph);
    if (st != PHKS_OK)
        return st;
    double *d = phks__malloc_array(graph.n, sizeof *d);
    if (!d)
        st = phks__fail_oom("feature geodesics");
    /* Point j's distances to the earlier points: the search from j stops
     * once they are settled. */
    for (size_t j = 1; st == PHKS_OK && j < points; j++) {
        st = phks__geodesic_run(&graph, sig->vertex[j], sig->vertex, j, d);
        for (size_t i = 0; st == PHKS_OK && i < j; i++)
            sig->geodesic[phks__pair_index(i, j)] =
                (float)d[phks__geodesic_node(&graph, sig->vertex[i])];
    }
    phks__free(d);
    phks__geodesic_graph_release(&graph);
    return st;
}
