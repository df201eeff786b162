/*
 * signature_geodesic.c - the distances along the surface between a
 * signature's feature points, which PHKS_MATCHING_VERIFIED checks
 * correspondences against: unlike a point's heat values, a pair's
 * distance carries the layout of the shape, and bending does not change
 * it.
 */
#include "features/features.h"

#include <math.h>

phks_status phks__signature_geodesics(const phks__unit_mesh *um,
                                      const phks_options *opt,
                                      phks_signature *sig)
{
    phks_status st = phks__signature_alloc_geodesic(sig);
    if (st != PHKS_OK || sig->count < 2)
        return st;
    phks__geodesic_graph graph;
    st = phks__geodesic_graph_build(um, opt->cutoff * sqrt(4 * opt->tau),
                                    &graph);
    if (st != PHKS_OK)
        return st;
    double *d = phks__malloc_array(graph.n, sizeof *d);
    if (!d)
        st = phks__fail_oom("feature geodesics");
    /* Feature j's distances to the earlier features: the search from j
     * stops once they are settled. */
    for (size_t j = 1; st == PHKS_OK && j < sig->count; j++) {
        st = phks__geodesic_run(&graph, sig->vertex[j], sig->vertex, j, d);
        for (size_t i = 0; st == PHKS_OK && i < j; i++)
            sig->geodesic[phks__pair_index(i, j)] = (float)d[sig->vertex[i]];
    }
    phks__free(d);
    phks__geodesic_graph_release(&graph);
    return st;
}
