/* test_mesh.c - creation, cleaning, edges, boundary and components on
 * hand-made meshes whose answers are known by construction. */
#include "testutil.h"

#include <math.h>
#include <string.h>

/* Two triangles sharing edge 1-2, a square with a 4-edge boundary. */
static const double square[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0};
static const uint32_t square_tris[6] = {0, 1, 2, 2, 1, 3};

START_TEST(square_has_four_boundary_edges)
{
    phks_mesh *m;
    ck_assert_int_eq(phks_mesh_create(square, 4, square_tris, 2, &m), PHKS_OK);
    ck_assert_uint_eq(phks_mesh_vertex_count(m), 4);
    ck_assert_uint_eq(phks_mesh_triangle_count(m), 2);
    ck_assert_uint_eq(phks_mesh_boundary_edge_count(m), 4);
    const uint32_t expect[8] = {0, 1, 0, 2, 1, 3, 2, 3};
    ck_assert_mem_eq(phks_mesh_boundary_edges(m), expect, sizeof expect);
    ck_assert_uint_eq(phks_mesh_component_count(m), 1);
    ck_assert_double_eq_tol(phks_mesh_area(m), 1.0, 1e-15);
    phks_mesh_free(m);
}
END_TEST

START_TEST(closed_tetrahedron_has_no_boundary)
{
    const double xyz[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    const uint32_t tri[12] = {0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2};
    phks_mesh *m;
    ck_assert_int_eq(phks_mesh_create(xyz, 4, tri, 4, &m), PHKS_OK);
    ck_assert_uint_eq(phks_mesh_boundary_edge_count(m), 0);
    ck_assert_uint_eq(m->edge_count, 6);
    for (size_t e = 0; e < m->edge_count; e++)
        ck_assert_uint_eq(m->edge_tri_offset[e + 1] - m->edge_tri_offset[e], 2);
    /* Every triangle's edges join its own corners. */
    for (size_t t = 0; t < 4; t++)
        for (int k = 0; k < 3; k++) {
            uint32_t a = tri[3 * t + k], b = tri[3 * t + (k + 1) % 3];
            const uint32_t *ev = m->edge_vertices + 2 * m->triangle_edges[3 * t + k];
            ck_assert_uint_eq(ev[0], a < b ? a : b);
            ck_assert_uint_eq(ev[1], a < b ? b : a);
        }
    phks_mesh_free(m);
}
END_TEST

/* Unreferenced vertices and degenerate triangles go; the origin map tells
 * where each kept vertex came from. */
START_TEST(cleaning_drops_and_renumbers)
{
    const double xyz[] = {9, 9, 9,   /* 0 unreferenced */
                          0, 0, 0,  1, 0, 0,  0, 1, 0,  1, 1, 0,
                          5, 5, 5,   /* 5 only in a degenerate triangle */
                          2, 2, 0};  /* 6 collinear with 1 and 4 */
    const uint32_t tri[] = {1, 2, 3,  3, 2, 4,  5, 5, 2,  1, 4, 6};
    phks_mesh *m;
    ck_assert_int_eq(phks_mesh_create(xyz, 7, tri, 4, &m), PHKS_OK);
    ck_assert_uint_eq(phks_mesh_vertex_count(m), 4);
    ck_assert_uint_eq(phks_mesh_triangle_count(m), 2);
    const uint32_t origin[4] = {1, 2, 3, 4};
    ck_assert_mem_eq(phks_mesh_vertex_origin(m), origin, sizeof origin);
    ck_assert_mem_eq(phks_mesh_vertices(m), square, sizeof square);
    ck_assert_mem_eq(phks_mesh_triangles(m), square_tris, sizeof square_tris);
    phks_mesh_free(m);
}
END_TEST

START_TEST(components_are_counted_and_labelled)
{
    /* Square, a lone triangle far away, and a triangle touching the square
     * only at vertex 3 (a vertex joins). */
    const double xyz[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0,
                          5, 5, 5, 6, 5, 5, 5, 6, 5,
                          2, 1, 0, 1, 2, 0};
    const uint32_t tri[] = {0, 1, 2, 2, 1, 3, 4, 5, 6, 3, 7, 8};
    phks_mesh *m;
    ck_assert_int_eq(phks_mesh_create(xyz, 9, tri, 4, &m), PHKS_OK);
    ck_assert_uint_eq(phks_mesh_component_count(m), 2);
    const uint32_t label[9] = {0, 0, 0, 0, 1, 1, 1, 0, 0};
    ck_assert_mem_eq(phks_mesh_vertex_components(m), label, sizeof label);
    phks_mesh_free(m);
}
END_TEST

/* A non-manifold "book": three triangles on one edge. */
START_TEST(non_manifold_edge_lists_all_triangles)
{
    const double xyz[] = {0, 0, 0, 0, 0, 1, 1, 0, 0, -1, 0, 0, 0, 1, 0};
    const uint32_t tri[] = {0, 1, 2, 1, 0, 3, 0, 1, 4};
    phks_mesh *m;
    ck_assert_int_eq(phks_mesh_create(xyz, 5, tri, 3, &m), PHKS_OK);
    uint32_t spine = m->triangle_edges[0];
    ck_assert_uint_eq(m->edge_tri_offset[spine + 1] - m->edge_tri_offset[spine], 3);
    ck_assert_uint_eq(phks_mesh_boundary_edge_count(m), 6);
    phks_mesh_free(m);
}
END_TEST

START_TEST(float_input_equals_double_input)
{
    float xyz_f[12];
    for (int i = 0; i < 12; i++)
        xyz_f[i] = (float)square[i];
    phks_mesh *a, *b;
    ck_assert_int_eq(phks_mesh_create_f(xyz_f, 4, square_tris, 2, &a), PHKS_OK);
    ck_assert_int_eq(phks_mesh_create(square, 4, square_tris, 2, &b), PHKS_OK);
    ck_assert_mem_eq(phks_mesh_vertices(a), phks_mesh_vertices(b), sizeof square);
    phks_mesh_free(a);
    phks_mesh_free(b);
}
END_TEST

START_TEST(bad_input_gets_a_specific_status)
{
    phks_mesh *m;
    double bad[12];
    memcpy(bad, square, sizeof bad);
    bad[7] = INFINITY;
    ck_assert_int_eq(phks_mesh_create(bad, 4, square_tris, 2, &m),
                     PHKS_ERROR_NON_FINITE);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "vertex 2"));
    const uint32_t far[6] = {0, 1, 2, 2, 1, UINT32_MAX};
    ck_assert_int_eq(phks_mesh_create(square, 4, far, 2, &m),
                     PHKS_ERROR_INDEX_OUT_OF_RANGE);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "triangle 1"));
    ck_assert_int_eq(phks_mesh_create(square, 4, square_tris, 0, &m),
                     PHKS_ERROR_NO_TRIANGLES);
    const double line[9] = {0, 0, 0, 1, 1, 1, 2, 2, 2};
    const uint32_t one[3] = {0, 1, 2};
    ck_assert_int_eq(phks_mesh_create(line, 3, one, 1, &m), PHKS_ERROR_ZERO_AREA);
    const double point[9] = {1, 1, 1, 1, 1, 1, 1, 1, 1};
    ck_assert_int_eq(phks_mesh_create(point, 3, one, 1, &m), PHKS_ERROR_ZERO_AREA);
    ck_assert_int_eq(phks_mesh_create(NULL, 4, square_tris, 2, &m),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_mesh_create(square, 4, square_tris, 2, NULL),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_mesh_create(square, (size_t)UINT32_MAX + 5,
                                      square_tris, 2, &m),
                     PHKS_ERROR_TOO_LARGE);
}
END_TEST

/* A soup: every triangle has its own three vertices. Accepted; each
 * triangle is its own component with three boundary edges. */
START_TEST(triangle_soup_is_accepted)
{
    const double xyz[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0};
    const uint32_t tri[] = {0, 1, 2, 3, 5, 4};
    phks_mesh *m;
    ck_assert_int_eq(phks_mesh_create(xyz, 6, tri, 2, &m), PHKS_OK);
    ck_assert_uint_eq(phks_mesh_component_count(m), 2);
    ck_assert_uint_eq(phks_mesh_boundary_edge_count(m), 6);
    phks_mesh_free(m);
}
END_TEST

int main(void)
{
    Suite *s = suite_create("mesh");
    TCase *c = tcase_create("mesh");
    tcase_add_test(c, square_has_four_boundary_edges);
    tcase_add_test(c, closed_tetrahedron_has_no_boundary);
    tcase_add_test(c, cleaning_drops_and_renumbers);
    tcase_add_test(c, components_are_counted_and_labelled);
    tcase_add_test(c, non_manifold_edge_lists_all_triangles);
    tcase_add_test(c, float_input_equals_double_input);
    tcase_add_test(c, bad_input_gets_a_specific_status);
    tcase_add_test(c, triangle_soup_is_accepted);
    suite_add_tcase(s, c);
    return run_suite(s);
}
