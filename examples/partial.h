/*
 * partial.h - partial scans and incomplete models made from a complete
 * triangle mesh, for the retrieval benchmark of the paper's protocol
 * (section 5) and for tests. Plain arrays in, plain arrays out; every result
 * is a deterministic function of the input and the seed, the same on every
 * machine and run.
 *
 * - A partial scan is what one range scan sees: a random view direction, a
 *   depth buffer rendered along it, the vertices the buffer shows, the
 *   triangles whose three vertices are all shown, then the largest
 *   edge-connected piece.
 * - An incomplete model is the mesh with one or two portions cut off by
 *   random planes: the triangles whose centroids are on the kept side, the
 *   largest edge-connected piece, keeping between 50% and 90% of the area.
 */
#ifndef PHKS_EXAMPLES_PARTIAL_H
#define PHKS_EXAMPLES_PARTIAL_H

#include <stddef.h>
#include <stdint.h>

typedef struct piece {
    double *xyz;              /* 3 per vertex                               */
    size_t vertex_count;
    uint32_t *triangles;      /* 3 per triangle, into xyz                   */
    size_t triangle_count;
    uint32_t *source_vertex;  /* per vertex: its index in the input mesh    */
} piece;

/* Partial scan of the mesh (xyz: 3 * vertex_count, triangles: 3 *
 * triangle_count) seen from a direction drawn from seed. Returns 0 and fills
 * *out (release with piece_free), or -1 when the scan keeps no triangle or
 * memory runs out (then *out is empty). */
int piece_partial_scan(const double *xyz, size_t vertex_count,
                       const uint32_t *triangles, size_t triangle_count,
                       uint64_t seed, piece *out);

/* Incomplete model: one or two plane cuts drawn from seed, keeping 50-90%
 * of the area (planes are redrawn until it does). Returns 0 or -1 as
 * piece_partial_scan. */
int piece_incomplete(const double *xyz, size_t vertex_count,
                     const uint32_t *triangles, size_t triangle_count,
                     uint64_t seed, piece *out);

void piece_free(piece *p);

#endif
