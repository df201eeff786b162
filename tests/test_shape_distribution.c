/*
 * test_shape_distribution.c - the shape distribution D2 of
 * PHKS_GLOBAL_DESCRIPTOR_D2 (lib/geometry/shape_distribution.c,
 * docs/method.md section 16) against distributions known without a mesh:
 *
 *  - a sphere of radius R: the chord between two uniform points has
 *    density d / (2 R^2) on [0, 2R], so its mean is 4R/3 and the share of
 *    distances below x means is 4 x^2 / 9;
 *  - the unit square: the distance of two uniform points has the density
 *    of square line picking, 2d (d^2 - 4d + pi) up to 1 and
 *    2d (4 sqrt(d^2 - 1) - (d^2 + 2 - pi) - 4 arcsec d) beyond, integrated
 *    here by a fine sum; as 2 triangles and as 20,000 alike;
 *  - a creature moved, turned and scaled: the same bytes within rounding;
 *  - the verified score's factor: the floor for one shape against itself,
 *    and a box told from a sphere by far more than the floor.
 */
#include "testutil.h"

#include "features/features.h"
#include "geometry/geometry.h"
#include "shapes.h"

#include <check.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Where the points fall decides a bin's count up to a few pairs in a
 * thousand; the bytes' rounding adds at most 0.5/255 to a square root. */
#define TOLERANCE 0.006

static void distribution_of(const shape_mesh *s, uint8_t *out)
{
    phks_mesh *mesh;
    ck_assert_int_eq(phks_mesh_create(s->xyz, s->vertex_count, s->triangles,
                                      s->triangle_count, &mesh),
                     PHKS_OK);
    phks__unit_mesh um = {mesh, 1.0, NULL};
    ck_assert_int_eq(phks__shape_distribution(&um, out), PHKS_OK);
    phks_mesh_free(mesh);
}

/* Hellinger distance of the bytes and the shares, bin by bin checked. */
static double against(const uint8_t *got, const double *share,
                      const char *what)
{
    double sum = 0;
    for (int b = 0; b < PHKS__SHAPE_BINS; b++) {
        double x = got[b] / 255.0, d = x - sqrt(share[b]);
        ck_assert_msg(fabs(x * x - share[b]) <= TOLERANCE,
                      "%s: bin %d: share %.4f, expected %.4f", what, b, x * x,
                      share[b]);
        sum += d * d;
    }
    return sqrt(sum / 2);
}

/* Shares of the bins from a cumulative distribution in units of the
 * mean. */
static void shares_from(double (*cdf)(double), double *share)
{
    const double width = PHKS__SHAPE_RANGE / PHKS__SHAPE_BINS;
    for (int b = 0; b < PHKS__SHAPE_BINS; b++)
        share[b] = cdf((b + 1) * width) - cdf(b * width);
    share[PHKS__SHAPE_BINS - 1] += 1 - cdf(PHKS__SHAPE_RANGE);
}

static double sphere_cdf(double x)
{
    return x >= 1.5 ? 1 : 4 * x * x / 9;
}

START_TEST(sphere_chords)
{
    shape_mesh s;
    ck_assert_int_eq(shape_sphere(5, 0.3, &s), 0);
    uint8_t got[PHKS__SHAPE_BINS];
    distribution_of(&s, got);
    double share[PHKS__SHAPE_BINS];
    shares_from(sphere_cdf, share);
    double h = against(got, share, "sphere");
    printf("sphere: Hellinger distance from the law %.4f\n", h);
    ck_assert(h < 0.01);
    shape_mesh_free(&s);
}
END_TEST

static double square_density(double d)
{
    if (d <= 1)
        return 2 * d * (d * d - 4 * d + PI);
    return 2 * d *
           (4 * sqrt(d * d - 1) - (d * d + 2 - PI) - 4 * acos(1 / d));
}

/* The mean distance of square line picking, (2 + sqrt 2 + 5 asinh 1) / 15. */
static double square_mean(void)
{
    return (2 + sqrt(2.0) + 5 * asinh(1.0)) / 15;
}

static double square_cdf(double x)
{
    const int steps = 100000;
    double end = fmin(x * square_mean(), sqrt(2.0)), sum = 0;
    for (int k = 0; k < steps; k++)
        sum += square_density((k + 0.5) / steps * end) * end / steps;
    return fmin(sum, 1);
}

/* The unit square at z = 0 as cells x cells squares of two triangles. */
static void unit_square(size_t cells, shape_mesh *s)
{
    size_t side = cells + 1;
    s->vertex_count = side * side;
    s->triangle_count = 2 * cells * cells;
    s->xyz = malloc(3 * s->vertex_count * sizeof *s->xyz);
    s->triangles = malloc(3 * s->triangle_count * sizeof *s->triangles);
    ck_assert(s->xyz && s->triangles);
    for (size_t y = 0; y < side; y++)
        for (size_t x = 0; x < side; x++) {
            double *p = s->xyz + 3 * (y * side + x);
            p[0] = (double)x / (double)cells;
            p[1] = (double)y / (double)cells;
            p[2] = 0;
        }
    for (size_t y = 0, t = 0; y < cells; y++)
        for (size_t x = 0; x < cells; x++, t += 2) {
            uint32_t a = (uint32_t)(y * side + x), b = a + 1,
                     c = (uint32_t)(a + side), d = c + 1;
            uint32_t pair[6] = {a, b, d, a, d, c};
            memcpy(s->triangles + 3 * t, pair, sizeof pair);
        }
}

START_TEST(square_as_two_triangles_and_as_many)
{
    double share[PHKS__SHAPE_BINS];
    shares_from(square_cdf, share);
    size_t cells[2] = {1, 100};
    for (int k = 0; k < 2; k++) {
        shape_mesh s;
        unit_square(cells[k], &s);
        uint8_t got[PHKS__SHAPE_BINS];
        distribution_of(&s, got);
        double h = against(got, share, k ? "fine square" : "square of 2");
        printf("square of %zu triangles: Hellinger distance from the law "
               "%.4f\n", s.triangle_count, h);
        ck_assert(h < 0.01);
        shape_mesh_free(&s);
    }
}
END_TEST

START_TEST(rigid_motion_and_scale_change_nothing)
{
    shape_mesh s;
    ck_assert_int_eq(shape_creature(SHAPE_QUADRUPED, NULL, 2, &s), 0);
    uint8_t a[PHKS__SHAPE_BINS], b[PHKS__SHAPE_BINS];
    distribution_of(&s, a);
    double rotation[9], shift[3] = {0.3, -2, 5};
    shape_random_rotation(11, rotation);
    ck_assert_int_eq(shape_transform(&s, rotation, 3.7, shift), 0);
    distribution_of(&s, b);
    for (int k = 0; k < PHKS__SHAPE_BINS; k++)
        ck_assert_msg(abs((int)a[k] - (int)b[k]) <= 1,
                      "bin %d: %d moved, %d before", k, b[k], a[k]);
    shape_mesh_free(&s);
}
END_TEST

/* A verified signature with the shape distribution, of a mesh. */
static phks_signature *signature_with_shape(const shape_mesh *s)
{
    phks_mesh *mesh;
    ck_assert_int_eq(phks_mesh_create(s->xyz, s->vertex_count, s->triangles,
                                      s->triangle_count, &mesh),
                     PHKS_OK);
    phks_options o;
    phks_options_init(&o);
    o.eigen_count = 60;
    o.global_descriptor = PHKS_GLOBAL_DESCRIPTOR_D2;
    phks_signature *sig;
    ck_assert_int_eq(phks_signature_compute(mesh, &o, &sig), PHKS_OK);
    phks_mesh_free(mesh);
    return sig;
}

START_TEST(factor_is_the_floor_for_itself_and_far_above_it_between_shapes)
{
    shape_mesh sphere, square;
    ck_assert_int_eq(shape_sphere(4, 0.5, &sphere), 0);
    unit_square(40, &square);
    phks_signature *a = signature_with_shape(&sphere);
    phks_signature *b = signature_with_shape(&square);
    double self = phks__global_factor(a, a), apart = phks__global_factor(a, b);
    printf("factor: sphere itself %.4f, sphere and square %.4f\n", self,
           apart);
    ck_assert(self > 0 && self < 0.0101);
    ck_assert(apart > 10 * self);
    ck_assert(apart == phks__global_factor(b, a));
    phks_signature_free(a);
    phks_signature_free(b);
    shape_mesh_free(&sphere);
    shape_mesh_free(&square);
}
END_TEST

int main(void)
{
    Suite *s = suite_create("shape_distribution");
    TCase *tc = tcase_create("distributions");
    tcase_add_test(tc, sphere_chords);
    tcase_add_test(tc, square_as_two_triangles_and_as_many);
    tcase_add_test(tc, rigid_motion_and_scale_change_nothing);
    tcase_add_test(tc, factor_is_the_floor_for_itself_and_far_above_it_between_shapes);
    suite_add_tcase(s, tc);
    return run_suite(s);
}
