/*
 * features.h - persistent maxima, signatures, their blobs and the score:
 * what the database layer stores and ranks.
 */
#ifndef PHKS_FEATURES_H
#define PHKS_FEATURES_H

#include "spectrum/spectrum.h"

/* ---- persistence (persistence.c) */
/* phks_persistent_maxima with progress: reports through `at` at the
 * start of each phase and every 65,536 triangles, edges or merges inside
 * one (often enough that a cancellation is noticed promptly on any mesh:
 * docs/benchmarks.md; a count that depends on the mesh and f alone), and
 * returns PHKS_ERROR_CANCELLED, everything freed and *count 0, when the
 * callback asks. The results are those of phks_persistent_maxima, bit for
 * bit. */
phks_status phks__persistence_run(const phks_mesh *mesh, const double *f,
                                  size_t max_count, double threshold,
                                  phks__span at, phks_maximum *out,
                                  size_t *count, uint32_t *region_of_triangle);

/* ---- signature (signature.c, signature_codec.c, score.c) */
struct phks_signature {
    phks_options options;  /* what shaped the numbers; see
                              phks__options_comparable                   */
    size_t count, length;  /* features, vector length (scale_count)    */
    uint32_t *vertex;      /* count                                     */
    double *position;      /* 3 * count, input coordinates              */
    double *persistence;   /* count; INFINITY when unpaired             */
    double *vectors;       /* count x length, row-major                 */
    float *geodesic;       /* PHKS_MATCHING_VERIFIED: the distance along
                              the surface (unit box) between features i
                              < j at geodesic[phks__pair_index(i, j)];
                              NULL with NEAREST                          */
};

/* Index of the pair i < j in a packed upper triangle without diagonal. */
static inline size_t phks__pair_index(size_t i, size_t j)
{
    return j * (j - 1) / 2 + i;
}
static inline size_t phks__pair_count(size_t count)
{
    return count * (count - 1) / 2;
}

/* An empty signature with room for count features of length values. */
phks_status phks__signature_alloc(size_t count, size_t length,
                                 phks_signature **out);
/* Room for sig->geodesic (count >= 2; none needed below). */
phks_status phks__signature_alloc_geodesic(phks_signature *sig);

/* ---- geodesics between feature points (signature_geodesic.c) */
/* Fills sig->geodesic (allocating it) with the distances along um's
 * surface between sig's feature vertices: Dijkstra over the edges, the
 * pieces of a mesh joined within the operator's reach (cutoff sqrt(4
 * tau)). Pairs in pieces that stay apart get INFINITY. */
phks_status phks__signature_geodesics(const phks__unit_mesh *um,
                                      const phks_options *opt,
                                      phks_signature *sig);

/* ---- verified matching (verify.c) */
/* The verified correspondences of query a in entry b and the score
 * phks_score documents for PHKS_MATCHING_VERIFIED. pair_of[i] (a->count
 * entries, may be NULL) gets the feature of b verified for feature i of
 * a, or UINT32_MAX. Both carry geodesics. */
phks_status phks__verify(const phks_signature *a, const phks_signature *b,
                         uint32_t *pair_of, double *score);
#endif /* PHKS_FEATURES_H */
