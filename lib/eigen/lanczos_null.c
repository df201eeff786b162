/*
 * lanczos_null.c - B's null space for the block Lanczos solver, where the
 * kernel splits the mesh into more components than a block can resolve
 * (lanczos.c): the null vectors in the pair numbering, the projection of
 * a block onto their orthogonal complement, and the null pairs.
 *
 * The null vectors have disjoint supports (one per component), so the
 * projection is one sum and one subtraction per entry: O(n) per column,
 * against the O(n m) of the Gram-Schmidt against the basis.
 */
#include "eigen/lanczos.h"

#include <string.h>

#define BLOCK PHKS__LANCZOS_BLOCK

void phks__lanczos_null_release(phks__lanczos_null *z)
{
    phks__free(z->component);
    phks__free(z->z);
    phks__free(z->coef);
    memset(z, 0, sizeof *z);
}

/* The unit null vectors (null_space.c) moved to the pair numbering. */
static phks_status place(const phks__operator_matrix *op,
                         const phks__operator_pairs *pm,
                         const uint32_t *component, phks__lanczos_null *z)
{
    size_t n = op->n;
    double *root = phks__malloc_array(n, sizeof *root);
    double *scale = phks__malloc_array(z->count, sizeof *scale);
    z->component = phks__malloc_array(n, sizeof *z->component);
    z->z = phks__malloc_array(n, sizeof *z->z);
    z->coef = phks__malloc_array(z->count, BLOCK * sizeof *z->coef);
    phks_status st = root && scale && z->component && z->z && z->coef
                         ? phks__null_space(op, component, z->count, root, scale)
                         : phks__fail_oom("Lanczos null space");
    if (st == PHKS_OK)
        for (size_t r = 0; r < n; r++) {
            uint32_t i = pm->order[r], c = component[i];
            z->component[r] = c;
            z->z[r] = root[i] * scale[c];
        }
    phks__free(root);
    phks__free(scale);
    return st;
}

phks_status phks__lanczos_null_build(const phks__operator_matrix *op,
                                     const phks__operator_pairs *pm,
                                     phks__lanczos_null *z)
{
    uint32_t *component = NULL;
    memset(z, 0, sizeof *z);
    phks_status st = phks__operator_components(op, &component, &z->count);
    if (st == PHKS_OK)
        st = place(op, pm, component, z);
    phks__free(component);
    if (st != PHKS_OK)
        phks__lanczos_null_release(z);
    return st;
}

void phks__lanczos_null_rows(const phks__lanczos_null *z, double *wr, size_t n)
{
    double *coef = z->coef;
    memset(coef, 0, z->count * BLOCK * sizeof *coef);
    for (size_t r = 0; r < n; r++) {
        double *c = coef + (size_t)z->component[r] * BLOCK, zr = z->z[r];
        for (size_t j = 0; j < BLOCK; j++)
            c[j] += zr * wr[r * BLOCK + j];
    }
    for (size_t r = 0; r < n; r++) {
        const double *c = coef + (size_t)z->component[r] * BLOCK;
        double zr = z->z[r];
        for (size_t j = 0; j < BLOCK; j++)
            wr[r * BLOCK + j] -= zr * c[j];
    }
}

void phks__lanczos_null_cols(const phks__lanczos_null *z, double *w, size_t n,
                             size_t cols)
{
    double *coef = z->coef;
    for (size_t j = 0; j < cols; j++) {
        double *x = w + j * n;
        memset(coef, 0, z->count * sizeof *coef);
        for (size_t r = 0; r < n; r++)
            coef[z->component[r]] += z->z[r] * x[r];
        for (size_t r = 0; r < n; r++)
            x[r] -= z->z[r] * coef[z->component[r]];
    }
}

void phks__lanczos_null_vectors(const phks__lanczos_null *z, size_t count,
                                double *vectors, size_t n)
{
    memset(vectors, 0, n * count * sizeof *vectors);
    for (size_t r = 0; r < n; r++)
        if (z->component[r] < count)
            vectors[(size_t)z->component[r] * n + r] = z->z[r];
}
