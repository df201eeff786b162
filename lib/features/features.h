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
};

/* An empty signature with room for count features of length values. */
phks_status phks__signature_alloc(size_t count, size_t length,
                                 phks_signature **out);
#endif /* PHKS_FEATURES_H */
