/*
 * null_space.c - B's null space, known exactly: S is a graph Laplacian with
 * positive weights on the kernel's non-zero entries, so its null space is
 * spanned by the indicators of the connected components of that graph
 * (which may split a connected mesh where the kernel does not reach), and
 * B's by Mh^1/2 times them. The eigen-solvers deflate it and the spectrum
 * keeps its cluster whole.
 */
#include "operator/operator.h"

#include <math.h>

phks_status phks__operator_components(const phks__operator_matrix *op,
                                     uint32_t **component, size_t *count)
{
    size_t n = op->n;
    uint32_t *parent = phks__malloc_array(n, sizeof *parent);
    *component = parent;
    *count = 0;
    if (!parent)
        return phks__fail_oom("operator components");
    for (size_t i = 0; i < n; i++)
        parent[i] = (uint32_t)i;
    /* union by lower root, so every root is its component's lowest point */
    for (size_t r = 0; r < n; r++)
        for (size_t e = op->row_start[r]; e < op->row_start[r + 1]; e++) {
            if (op->col[e] <= r || op->val[e] == 0)
                continue;
            uint32_t a = phks__find_root(parent, (uint32_t)r);
            uint32_t b = phks__find_root(parent, op->col[e]);
            if (a != b)
                parent[a > b ? a : b] = a < b ? a : b;
        }
    for (size_t i = 0; i < n; i++)
        parent[i] = phks__find_root(parent, (uint32_t)i);
    /* every root is its component's lowest point: in one ascending pass
     * it is numbered before the points that refer to it */
    size_t c = 0;
    for (size_t i = 0; i < n; i++)
        parent[i] = parent[i] == i ? (uint32_t)c++ : parent[parent[i]];
    *count = c;
    return PHKS_OK;
}

phks_status phks__null_space(const phks__operator_matrix *op,
                            const uint32_t *component, size_t count,
                            double *root, double *scale)
{
    for (size_t c = 0; c < count; c++)
        scale[c] = 0;
    for (size_t i = 0; i < op->n; i++) {
        root[i] = sqrt(op->mass[i]);
        scale[component[i]] += op->mass[i];
    }
    for (size_t c = 0; c < count; c++) {
        if (!(scale[c] > 0))
            return phks__fail(PHKS_ERROR_SOLVER,
                             "operator component %zu has no mass", c);
        scale[c] = 1 / sqrt(scale[c]);
    }
    return PHKS_OK;
}
