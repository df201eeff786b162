/*
 * test_spin_image.c - the spin images of PHKS_LOCAL_DESCRIPTOR_SPIN
 * (lib/geometry/spin_image.c, docs/method.md section 15) against
 * expectations computed without a mesh:
 *
 *  - a flat square, as 4 triangles and as a fine grid: all area at height
 *    0 (the middle height bin), the shares of the distance bins those of a
 *    disc's rings, (1, 3, 5, 7) / 16, at every radius;
 *  - a sphere of radius R: the area within chord distance d of a point is
 *    pi d^2 (Archimedes), at height -d^2 / (2 R) and distance
 *    d sqrt(1 - d^2 / (4 R^2)) from the normal line, so the shares are an
 *    integral over d^2 uniform on [0, r^2], taken here by a fine sum;
 *  - a creature moved rigidly, and with every other triangle's winding
 *    reversed (a soup): the same images within the bytes' rounding.
 */
#include "testutil.h"

#include "geometry/geometry.h"
#include "shapes.h"

#include <check.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* A bin's share may differ from the integral by the binning of pieces
 * whose centroid lies on the other side of a bin's edge than part of
 * their area (and by the sphere's facets): about a percent of the area.
 * Compared as shares, not bytes: the square root inflates a sliver of
 * area at an edge (0.0005 is 6 of 255). */
#define TOLERANCE 0.015

static double radius_of(int r)
{
    return PHKS__SPIN_RADIUS * exp2(r / 2.0);
}

/* The images of the vertices of `mesh` (input coordinates = unit box). */
static void images_of(const phks_mesh *mesh, const uint32_t *vertices,
                      size_t count, uint8_t *out)
{
    phks__unit_mesh um = {mesh, 1.0, NULL};
    ck_assert_int_eq(phks__spin_images(&um, vertices, count, out), PHKS_OK);
}

static void assert_near(const uint8_t *got, const double *share,
                        const char *what)
{
    for (int b = 0; b < PHKS__SPIN_BYTES; b++) {
        double x = got[b] / 255.0;
        ck_assert_msg(fabs(x * x - share[b]) <= TOLERANCE,
                      "%s: radius %d bin %d: share %.4f, expected %.4f", what,
                      b / PHKS__SPIN_IMAGE, b % PHKS__SPIN_IMAGE, x * x,
                      share[b]);
    }
}

/* A square [-1, 1]^2 at z = 0 meshed as a (2 cells + 1)^2 grid of
 * vertices, its centre vertex into *centre. */
static phks_mesh *square(size_t cells, uint32_t *centre)
{
    size_t side = cells + 1, n = side * side;
    double *xyz = malloc(3 * n * sizeof *xyz);
    uint32_t *tri = malloc(6 * cells * cells * sizeof *tri);
    ck_assert(xyz && tri);
    for (size_t y = 0; y < side; y++)
        for (size_t x = 0; x < side; x++) {
            double *p = xyz + 3 * (y * side + x);
            p[0] = -1 + 2.0 * (double)x / (double)cells;
            p[1] = -1 + 2.0 * (double)y / (double)cells;
            p[2] = 0;
        }
    size_t t = 0;
    for (size_t y = 0; y < cells; y++)
        for (size_t x = 0; x < cells; x++) {
            uint32_t a = (uint32_t)(y * side + x), b = a + 1,
                     c = (uint32_t)(a + side), d = c + 1;
            uint32_t quad[6] = {a, b, d, a, d, c};
            memcpy(tri + 6 * t++, quad, sizeof quad);
        }
    phks_mesh *mesh;
    ck_assert_int_eq(phks_mesh_create(xyz, n, tri, 2 * cells * cells, &mesh),
                     PHKS_OK);
    *centre = (uint32_t)(cells / 2 * side + cells / 2);
    free(xyz);
    free(tri);
    return mesh;
}

START_TEST(flat_square_is_a_disc)
{
    double share[PHKS__SPIN_BYTES] = {0};
    int middle = PHKS__SPIN_BETA / 2;
    for (int r = 0; r < PHKS__SPIN_RADII; r++)
        for (int a = 0; a < PHKS__SPIN_ALPHA; a++)
            share[r * PHKS__SPIN_IMAGE + a * PHKS__SPIN_BETA + middle] =
                (2.0 * a + 1) / (PHKS__SPIN_ALPHA * PHKS__SPIN_ALPHA);
    size_t cells[2] = {2, 200};
    uint8_t got[2][PHKS__SPIN_BYTES];
    for (int k = 0; k < 2; k++) {
        uint32_t centre;
        phks_mesh *mesh = square(cells[k], &centre);
        images_of(mesh, &centre, 1, got[k]);
        assert_near(got[k], share, k ? "fine square" : "square of 8");
        phks_mesh_free(mesh);
    }
}
END_TEST

/* The shares of a point of a sphere of radius R, by a midpoint sum over
 * u = d^2 uniform on [0, r^2] at each radius. */
static void sphere_shares(double R, double *share)
{
    const int steps = 200000;
    memset(share, 0, PHKS__SPIN_BYTES * sizeof *share);
    for (int r = 0; r < PHKS__SPIN_RADII; r++) {
        double radius = radius_of(r);
        for (int s = 0; s < steps; s++) {
            double u = (s + 0.5) / steps * radius * radius, d = sqrt(u);
            double beta = -u / (2 * R), alpha = d * sqrt(1 - u / (4 * R * R));
            int a = (int)fmin(floor(alpha / radius * PHKS__SPIN_ALPHA),
                              PHKS__SPIN_ALPHA - 1);
            int b = (int)floor((beta + radius) / (2 * radius) * PHKS__SPIN_BETA);
            share[r * PHKS__SPIN_IMAGE + a * PHKS__SPIN_BETA + b] += 1.0 / steps;
        }
    }
}

START_TEST(sphere_matches_archimedes)
{
    const double R = 0.2;
    shape_mesh s;
    ck_assert_int_eq(shape_sphere(6, R, &s), 0);
    phks_mesh *mesh;
    ck_assert_int_eq(phks_mesh_create(s.xyz, s.vertex_count, s.triangles,
                                      s.triangle_count, &mesh),
                     PHKS_OK);
    double share[PHKS__SPIN_BYTES];
    sphere_shares(R, share);
    /* The curvature moves area out of the middle height bin. */
    ck_assert(share[(PHKS__SPIN_RADII - 1) * PHKS__SPIN_IMAGE +
                    (PHKS__SPIN_ALPHA - 1) * PHKS__SPIN_BETA +
                    PHKS__SPIN_BETA / 2] < 0.5);
    uint32_t points[3] = {0, 1000, 30000};
    uint8_t got[3][PHKS__SPIN_BYTES];
    images_of(mesh, points, 3, got[0]);
    for (int k = 0; k < 3; k++)
        assert_near(got[k], share, "sphere");
    phks_mesh_free(mesh);
    shape_mesh_free(&s);
}
END_TEST

START_TEST(rigid_motion_and_winding_change_nothing)
{
    shape_mesh s;
    ck_assert_int_eq(shape_creature(0, NULL, 3, &s), 0);
    /* Into a box of about unit size, as phks__unit_mesh would. */
    ck_assert_int_eq(shape_transform(&s, NULL, 0.5, NULL), 0);
    phks_mesh *mesh, *moved;
    ck_assert_int_eq(phks_mesh_create(s.xyz, s.vertex_count, s.triangles,
                                      s.triangle_count, &mesh),
                     PHKS_OK);
    double rotation[9], shift[3] = {0.3, -2, 5};
    shape_random_rotation(7, rotation);
    ck_assert_int_eq(shape_transform(&s, rotation, 1, shift), 0);
    for (size_t t = 0; t < s.triangle_count; t += 2) {
        uint32_t *tri = s.triangles + 3 * t, first = tri[0];
        tri[0] = tri[1];
        tri[1] = first;
    }
    ck_assert_int_eq(phks_mesh_create(s.xyz, s.vertex_count, s.triangles,
                                      s.triangle_count, &moved),
                     PHKS_OK);
    ck_assert_uint_eq(phks_mesh_vertex_count(mesh),
                      phks_mesh_vertex_count(moved));
    enum { POINTS = 40 };
    uint32_t points[POINTS];
    for (int k = 0; k < POINTS; k++)
        points[k] = (uint32_t)((size_t)k * 7919 % phks_mesh_vertex_count(mesh));
    uint8_t *a = malloc(POINTS * PHKS__SPIN_BYTES),
            *b = malloc(POINTS * PHKS__SPIN_BYTES);
    ck_assert(a && b);
    images_of(mesh, points, POINTS, a);
    images_of(moved, points, POINTS, b);
    int most = 0, nonzero = 0;
    for (int k = 0; k < POINTS * PHKS__SPIN_BYTES; k++) {
        most = abs((int)a[k] - (int)b[k]) > most ? abs((int)a[k] - (int)b[k])
                                                 : most;
        nonzero += a[k] != 0;
    }
    /* Rounding moves a piece across a bin's edge now and then. */
    ck_assert_msg(most <= 2, "moved images differ by %d", most);
    ck_assert(nonzero > POINTS * PHKS__SPIN_RADII);
    free(a);
    free(b);
    phks_mesh_free(mesh);
    phks_mesh_free(moved);
    shape_mesh_free(&s);
}
END_TEST

int main(void)
{
    Suite *s = suite_create("spin_image");
    TCase *tc = tcase_create("images");
    tcase_add_test(tc, flat_square_is_a_disc);
    tcase_add_test(tc, sphere_matches_archimedes);
    tcase_add_test(tc, rigid_motion_and_winding_change_nothing);
    suite_add_tcase(s, tc);
    return run_suite(s);
}
