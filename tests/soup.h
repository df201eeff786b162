/* soup.h - a growable triangle soup and the meshes the tests build in it. */
#ifndef PHKS_TEST_SOUP_H
#define PHKS_TEST_SOUP_H

#include "testutil.h"

/* Vertices (xyz, 3 per vertex) and triangles (tri, 3 indices each);
 * start from soup s = {0}. */
typedef struct {
    double *xyz;
    size_t nv, cap_v;
    uint32_t *tri;
    size_t nt, cap_t;
} soup;

/* Appends a vertex; returns its index. */
uint32_t soup_vertex(soup *s, double x, double y, double z);

/* Appends the triangle (a, b, c). */
void soup_triangle(soup *s, uint32_t a, uint32_t b, uint32_t c);

/* Releases the arrays and zeroes the soup. */
void soup_free(soup *s);

/* Makes the library mesh; fails the test unless every vertex and triangle
 * is kept, so that the soup's arrays describe the mesh exactly. */
phks_mesh *soup_mesh(const soup *s);

/* Makes the library mesh and frees the soup; fails the test unless every
 * triangle is kept (unreferenced vertices may be dropped). */
phks_mesh *soup_mesh_take(soup *s);

/* Appends an icosphere of `subdiv` subdivisions: unit sphere points, each
 * pushed radially by 1 + noise * U(-1, 1) (one test_random per vertex),
 * scaled per axis by axes and moved to center. */
void add_icosphere(soup *out, unsigned subdiv, const double center[3],
                   const double axes[3], double noise, uint64_t *rng);

/* Appends the surface of the box [0,a] x [0,b] x [0,c] (size) with
 * cells[d] cells along axis d on every face, two triangles per cell,
 * vertices shared, faces wound outwards. */
void add_box(soup *s, const double size[3], const size_t cells[3]);

/* Appends a closed torus of nu * nv quads about the z axis (radii big and
 * small), angles jittered by jitter * U(-1/2, 1/2) steps (0: exact). */
void add_torus(soup *s, size_t nu, size_t nv, double big, double small,
               double jitter, uint64_t *rng);

/* The library mesh of generated creature `kind` (tests/fixtures/shapes.h)
 * in pose `pose`, at resolution 1 (500 to 1,300 vertices). */
phks_mesh *creature_mesh(unsigned kind, unsigned pose);

/* The same, rotated (row-major 3 x 3; NULL: as made), scaled and then
 * shifted by shift[3] as shape_transform does. */
phks_mesh *creature_mesh_moved(unsigned kind, unsigned pose,
                               const double *rotation, double scale,
                               const double *shift);

/* Keeps the triangles whose centroid has z >= zmin, and their vertices. */
void crop_z(soup *s, double zmin);

#endif
