/*
 * shapes.h - closed triangle meshes made on the fly, for the demo program,
 * the tests and the benchmarks.
 *
 * Plain arrays in, plain arrays out: this file does not use libphks, and
 * shapes.c needs only the C library and libm. Pass a shape_mesh to
 * phks_mesh_create(m.xyz, m.vertex_count, m.triangles, m.triangle_count, ..).
 *
 * Every mesh made here is a closed, connected, consistently oriented
 * 2-manifold of genus 0 (every edge in exactly two triangles, triangles
 * counter-clockwise seen from outside), without degenerate triangles.
 *
 * Creatures are articulated: a pose is a vector of joint angles. All poses
 * of one kind at one resolution have the same triangles, and vertex i is
 * the same material point in all of them, so a test knows the true
 * correspondence. A pose change bends limbs smoothly over a few rings, so
 * it is nearly isometric (see shape_creature).
 *
 * Functions that return int return 0 on success, -1 for a bad argument and
 * -2 when memory runs out. Nothing is printed. All functions are
 * thread-safe (no global state).
 */
#ifndef SHAPES_H
#define SHAPES_H

#include <stddef.h>
#include <stdint.h>

typedef struct shape_mesh {
    double *xyz;           /* 3 * vertex_count coordinates x0 y0 z0 x1 ... */
    size_t vertex_count;
    uint32_t *triangles;   /* 3 * triangle_count vertex indices            */
    size_t triangle_count;
} shape_mesh;

/* Releases the arrays of *mesh (malloc'ed) and zeroes it. NULL is fine. */
void shape_mesh_free(shape_mesh *mesh);

/* Icosphere: the icosahedron with each triangle split into four,
 * `subdivisions` times, every vertex exactly at distance `radius` from the
 * origin. 10 * 4^s + 2 vertices (12, 42, 162, 642, 2562, 10242, 40962 for
 * s = 0..6) and 20 * 4^s triangles. subdivisions <= 9, radius > 0 and
 * finite. On failure *out is zeroed. */
int shape_sphere(unsigned subdivisions, double radius, shape_mesh *out);

/* The kinds of creature. Each is a body with limbs (tubes) grown out of
 * it, smoothed by Catmull-Clark subdivision. Coordinates: z is up; every
 * creature fits in a box of about 1 to 2 units. */
typedef enum shape_kind {
    SHAPE_QUADRUPED = 0, /* 4 legs, a tail, neck and head; faces +x      */
    SHAPE_HUMANOID = 1,  /* 2 legs, 2 arms, neck and head; faces +y      */
    SHAPE_OCTOPUS = 2,   /* a mantle on top and 8 tentacles              */
    SHAPE_HAND = 3,      /* palm facing -y, 4 fingers up (+z), a thumb   */
    SHAPE_PLIER = 4,     /* 2 short jaws and 2 long handles on a hinge   */
    SHAPE_KIND_COUNT = 5
} shape_kind;

/* Resolution r is the number of subdivision steps; each step multiplies
 * the triangle count by 4. The default gives 2k to 5k vertices,
 * r = 1 gives 500 to 1300. Exact counts: shape_creature_vertex_count. */
#define SHAPE_DEFAULT_RESOLUTION 2
#define SHAPE_MAX_RESOLUTION 6
/* No kind has more joints than this. */
#define SHAPE_MAX_JOINTS 32

/* "quadruped", "humanoid", ...; NULL for an unknown kind. */
const char *shape_creature_name(unsigned kind);

/* Number of joint angles of a pose of this kind; 0 for an unknown kind. */
unsigned shape_creature_joint_count(unsigned kind);

/* Vertex count of shape_creature(kind, .., resolution, ..); the triangle
 * count is 2 * (vertex count - 2). 0 for a bad kind or resolution. */
size_t shape_creature_vertex_count(unsigned kind, unsigned resolution);

/* Writes shape_creature_joint_count(kind) angles (radians) of a
 * reproducible pose into angles: pose 0 is the rest pose (all zero); every
 * other index gives a different pseudo-random pose, each angle uniform in
 * the joint's range (within +-0.6 rad; the ranges are chosen so that
 * limbs meet neither each other nor the body). Returns the number of
 * angles written (0 for an unknown kind, or a NULL angles). */
unsigned shape_creature_pose(unsigned kind, unsigned pose_index,
                             double *angles);

/* Makes a creature of the given kind in the pose `angles`
 * (shape_creature_joint_count(kind) radians; NULL is the rest pose; angle
 * 0 is the rest position of each joint). Each angle bends one limb about
 * one axis, spread over up to five rings of the limb, so a pose change
 * stretches or shrinks edges only on the inside and outside of the bends
 * and leaves the body as it is. Measured on the poses of
 * shape_creature_pose at resolutions 1 to 3: against the rest pose, edge
 * lengths change by under 1% on average and by at most 9%; between two
 * such poses, by under 1.2% on average and by at most 15%. Angles beyond
 * the pose ranges work but may make limbs pass through each other.
 * resolution <= SHAPE_MAX_RESOLUTION.
 * Returns -1 for an unknown kind, a resolution too large or a non-finite
 * angle, -2 when out of memory; on failure *out is zeroed. */
int shape_creature(unsigned kind, const double *angles, unsigned resolution,
                   shape_mesh *out);

/* Applies x' = scale * R x + t to every vertex. rotation is row-major
 * (NULL: identity), translation NULL: zero. A negative scale or a
 * rotation with determinant -1 mirrors the mesh; then the triangles are
 * reversed so they stay counter-clockwise seen from outside. Returns -1
 * for a NULL mesh or a zero or non-finite scale. */
int shape_transform(shape_mesh *mesh, const double rotation[9], double scale,
                    const double translation[3]);

/* A uniformly distributed random rotation (row-major, determinant +1)
 * determined by seed. */
void shape_random_rotation(uint64_t seed, double rotation[9]);

#endif
