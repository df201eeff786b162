/*
 * partial.h - partial scans and incomplete models made from a complete
 * triangle mesh, for the retrieval benchmark of the paper's protocol
 * (section 5) and for tests. Plain arrays in, plain arrays out; every result
 * is a deterministic function of the input and the seed, the same on every
 * machine and run.
 *
 * - A partial scan is what one range scan sees: a random view direction,
 *   the vertices a depth buffer along it shows, the triangles whose three
 *   vertices are all shown and that do not graze the view, then the
 *   largest edge-connected piece.
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

/* Every function below returns -1, with *out zeroed, when the input is
 * invalid: out NULL, no triangle, xyz or triangles NULL, a vertex index >=
 * vertex_count, or any coordinate (referenced or not) that is not finite
 * or exceeds 1e100 in magnitude. On success *out owns malloc'ed arrays;
 * its vertices are the input vertices its triangles use, in increasing
 * input order (source_vertex is strictly increasing), and its triangles
 * are input triangles, corners in the input order, in increasing input
 * order. The result is always one edge-connected piece (two triangles are
 * edge-connected when they share two vertex indices): of the triangles
 * selected, the piece of largest area (ties: the one holding the lowest
 * input triangle). Thread-safe (no global state). */

/* Partial scan of the mesh (xyz: 3 * vertex_count, triangles: 3 *
 * triangle_count) seen from the direction piece_view_direction(seed):
 * the same as piece_partial_scan_dir with that direction. Returns 0 and
 * fills *out (release with piece_free), or -1 when the input is invalid,
 * the scan keeps no triangle or memory runs out (then *out is empty). */
int piece_partial_scan(const double *xyz, size_t vertex_count,
                       const uint32_t *triangles, size_t triangle_count,
                       uint64_t seed, piece *out);

/* The view direction of piece_partial_scan(.., seed, ..): a unit vector
 * uniform on the sphere, computed with + - * / and sqrt only, so it is
 * bit-identical on every IEEE-754 machine. */
void piece_view_direction(uint64_t seed, double dir[3]);

/* Partial scan along dir (any non-zero finite length; it is normalised):
 * the viewer looks along +dir from far away, so the depth of a point p is
 * p . dir and the nearer surface has the smaller depth; on a sphere about
 * the origin the half p . dir < 0 is seen. A vertex is shown when no
 * triangle without it as a corner covers its projection (edges included)
 * nearer than it by more than 1e-6 of the mesh's size (the larger of the
 * projected bounding box's sides and the depth range): the depth buffer at
 * unlimited resolution, evaluated exactly at the vertex (a pixel grid
 * over the projected bounding box lists the triangles touching each
 * pixel; it sets the speed, never the result). Triangles occlude whatever
 * they face. A triangle is kept when its three vertices are shown and it
 * is not grazing: |unit normal . dir| > 0.1 (the sign is not used, so
 * orientation does not matter; triangles seen within about 6 degrees of
 * edge-on are not seen by a scanner either). Returns -1 also for a NULL,
 * zero or non-finite dir, and when all vertices project to one point. */
int piece_partial_scan_dir(const double *xyz, size_t vertex_count,
                           const uint32_t *triangles, size_t triangle_count,
                           const double dir[3], piece *out);

/* Incomplete model: one or two plane cuts drawn from seed, keeping 50-90%
 * of the area (planes are redrawn until it does). Returns 0 or -1 as
 * piece_partial_scan; -1 also when 1000 draws never keep 50-90%. */
int piece_incomplete(const double *xyz, size_t vertex_count,
                     const uint32_t *triangles, size_t triangle_count,
                     uint64_t seed, piece *out);

/* piece_incomplete, also telling the cuts (same result for the same seed).
 * A draw takes 1 or 2 planes; each has a unit normal n uniform on the
 * sphere and passes through the vertex projection n . p at a random
 * quantile (the cut-off side holds 10-45% of the referenced vertices for
 * one plane, 5-30% each for two). A triangle abc is selected when its
 * centroid m = (a + b + c) / 3 has n . m + e >= 0 for every plane; the draw is
 * accepted when the largest piece holds 50-90% of the total triangle
 * area. If planes is not NULL it receives plane_count * 4 numbers
 * {n.x, n.y, n.z, e} (room for 8); plane_count, if not NULL, receives 1
 * or 2 (0 on failure). */
int piece_incomplete_planes(const double *xyz, size_t vertex_count,
                            const uint32_t *triangles, size_t triangle_count,
                            uint64_t seed, piece *out, double planes[8],
                            unsigned *plane_count);

/* Releases the arrays of *p and zeroes it. NULL, or a zeroed piece, is
 * fine. */
void piece_free(piece *p);

#endif
