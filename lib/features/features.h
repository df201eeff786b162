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
    size_t samples;        /* spread points after the features
                              (PHKS_MATCHING_VERIFIED; 0 with NEAREST):
                              the arrays below hold count + samples
                              points, the features first                */
    uint32_t *vertex;      /* points                                    */
    double *position;      /* 3 * points, input coordinates             */
    double *persistence;   /* points; INFINITY when unpaired, 0 for a
                              sample                                    */
    double *vectors;       /* points x length, row-major                */
    float *geodesic;       /* VERIFIED: the distance along the surface
                              (unit box) between points i < j at
                              geodesic[phks__pair_index(i, j)]; NULL
                              with NEAREST                               */
    float *boundary;       /* VERIFIED: each point's straight-line
                              distance to the mesh boundary (unit box;
                              INFINITY on a closed mesh); NULL with
                              NEAREST                                    */
    double unit_scale;     /* positions times this lie in the unit box;
                              0 where unknown (blobs of format 4 and
                              older, a database's options), then no
                              straight-line distances                    */
    uint8_t *spin;         /* VERIFIED with PHKS_LOCAL_DESCRIPTOR_SPIN:
                              points x PHKS__SPIN_BYTES, each point's
                              spin images (geometry.h); NULL otherwise  */
    bool has_shape;        /* VERIFIED with PHKS_GLOBAL_DESCRIPTOR_D2     */
    uint8_t shape[PHKS__SHAPE_BINS]; /* then its shape distribution
                              (geometry.h)                               */
};

/* Features and samples. */
static inline size_t phks__signature_points(const phks_signature *sig)
{
    return sig->count + sig->samples;
}

/* Index of the pair i < j in a packed upper triangle without diagonal. */
static inline size_t phks__pair_index(size_t i, size_t j)
{
    return j * (j - 1) / 2 + i;
}
static inline size_t phks__pair_count(size_t count)
{
    return count * (count - 1) / 2;
}

/* An empty signature with room for count features and `samples` spread
 * points of length values each. */
phks_status phks__signature_alloc(size_t count, size_t samples, size_t length,
                                  phks_signature **out);
/* Room for sig->geodesic and sig->boundary, and sig->spin (zero) when
 * sig->options asks for spin images: set sig->options first. */
phks_status phks__signature_alloc_layout(phks_signature *sig);

/* ---- where the points lie (signature_layout.c) */
/* The samples VERIFIED signatures spread after their features. */
#define PHKS__SAMPLES 20
/* Picks up to `wanted` vertices spread over um's surface, each the
 * farthest (straight line, unit box) from the `given` vertices and those
 * picked before it (ties: the lowest index), into out, and how many into
 * *picked (fewer when no vertex is left apart from those). */
phks_status phks__spread_vertices(const phks__unit_mesh *um,
                                  const uint32_t *given, size_t given_count,
                                  size_t wanted, uint32_t *out, size_t *picked);
/* Fills sig->geodesic and sig->boundary (allocating them): the distances
 * along um's surface between sig's points, Dijkstra over the edges with
 * the pieces of a mesh joined within the operator's reach (cutoff
 * sqrt(4 tau)); pairs in pieces that stay apart get INFINITY. The
 * values are those a blob holds (floats). */
phks_status phks__signature_layout(const phks__unit_mesh *um,
                                   const phks_options *opt,
                                   phks_signature *sig);

/* ---- verified matching (verify.c) */
/* Vector distance per time scale at which a verified proposal's own
 * affinity falls to 1/e: the logarithms of the local-area scaling differ
 * by 0.15 where HKS A_t differs by about 16%. phks_similarity (score.c)
 * reads a NEAREST score with the same width. */
#define PHKS__VECTOR_SIGMA 0.15
/* What the verified score of a and b is multiplied by for their whole
 * shapes: their shape distributions' Hellinger distance plus the floor
 * sampling leaves (docs/method.md section 16) when both carry one
 * (PHKS_GLOBAL_DESCRIPTOR_D2), 1 otherwise. */
double phks__global_factor(const phks_signature *a, const phks_signature *b);
/* phks_candidates on checked arguments: k at most b's points. */
phks_status phks__candidates(const phks_signature *a, size_t feature,
                             const phks_signature *b, size_t k,
                             phks_candidate *out, size_t *count);
/* The verified correspondences of query a in entry b and the score
 * phks_score documents for PHKS_MATCHING_VERIFIED, given `nearest`, the
 * paper's score of a and b. pair_of[i] (a->count entries, may be NULL)
 * gets the point of b verified for feature i of a, or UINT32_MAX. Both
 * carry their layouts. */
phks_status phks__verify(const phks_signature *a, const phks_signature *b,
                         double nearest, uint32_t *pair_of, double *score);
/* The same for one query against many entries: a verifier holds the
 * query's share of the work and room for entries of up to `points`
 * points, so that phks__verifier_run allocates nothing and may run on
 * any thread (one verifier per thread; the scores do not depend on what
 * it verified before). Fails only for want of memory. */
typedef struct phks__verifier phks__verifier;
phks_status phks__verifier_new(const phks_signature *a, size_t points,
                               phks__verifier **out);
void phks__verifier_run(phks__verifier *v, const phks_signature *b,
                        double nearest, uint32_t *pair_of, double *score);
void phks__verifier_free(phks__verifier *v);
#endif /* PHKS_FEATURES_H */
