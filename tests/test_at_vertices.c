/* test_at_vertices.c - phks_signature_at_vertices: at the vertices
 * phks_signature_from_spectrum picked it makes that signature again, blob
 * for blob once the persistence is set aside; in another order, the same
 * points in that order; and it refuses what it documents it refuses.
 * Small generated creatures (500-1300 vertices) keep it fast. */
#include "soup.h"
#include "shapes.h"
#include "partial.h"

#include <stdlib.h>
#include <string.h>

/* A cut piece: a boundary, so the taper moves the maxima and the
 * layout's boundary distances are finite. */
static phks_mesh *incomplete(unsigned kind, unsigned pose, uint64_t seed)
{
    double angles[SHAPE_MAX_JOINTS];
    shape_mesh s;
    shape_creature_pose(kind, pose, angles);
    ck_assert_int_eq(shape_creature(kind, angles, 1, &s), 0);
    piece p;
    ck_assert_int_eq(piece_incomplete(s.xyz, s.vertex_count, s.triangles,
                                      s.triangle_count, seed, &p),
                     0);
    phks_mesh *m;
    ck_assert_int_eq(phks_mesh_create(p.xyz, p.vertex_count, p.triangles,
                                      p.triangle_count, &m),
                     PHKS_OK);
    piece_free(&p);
    shape_mesh_free(&s);
    return m;
}

static bytes encoded(const phks_signature *sig)
{
    bytes b = {0};
    size_t size = phks_signature_encoded_size(sig), got;
    b.p = malloc(size);
    b.n = size;
    ck_assert_ptr_nonnull(b.p);
    ck_assert_int_eq(phks_signature_encode(sig, b.p, size, &got), PHKS_OK);
    ck_assert_uint_eq(got, size);
    return b;
}

/* phks_signature_at_vertices at the features of `picked`. */
static phks_signature *at_features(const phks_mesh *m, const phks_spectrum *spec,
                                   const phks_options *o,
                                   const phks_signature *picked)
{
    size_t count = phks_signature_feature_count(picked);
    uint32_t *v = malloc(count * sizeof *v);
    for (size_t i = 0; i < count; i++)
        v[i] = phks_signature_feature_vertex(picked, i);
    phks_signature *sig;
    phks_status st = phks_signature_at_vertices(m, spec, o, v, count, &sig);
    ck_assert_msg(st == PHKS_OK, "%s", phks_last_error_message());
    free(v);
    return sig;
}

/* The same points give the same signature: equal blobs once a's
 * persistence is copied over b's zeros (features: the only field that
 * differs), and a score of 0 between them. */
static void same_signature(const phks_mesh *m, const phks_options *o)
{
    phks_spectrum *spec;
    phks_signature *a, *b;
    ck_assert_int_eq(phks_spectrum_compute(m, o, &spec), PHKS_OK);
    ck_assert_int_eq(phks_signature_from_spectrum(m, spec, o, &a), PHKS_OK);
    b = at_features(m, spec, o, a);
    size_t count = phks_signature_feature_count(a);
    ck_assert_uint_gt(count, 1);
    ck_assert_uint_eq(phks_signature_feature_count(b), count);
    ck_assert_uint_eq(phks_signature_sample_count(b),
                      phks_signature_sample_count(a));
    for (size_t i = 0; i < count; i++) {
        ck_assert_double_eq(phks_signature_feature_persistence(b, i), 0);
        b->persistence[i] = a->persistence[i];
    }
    bytes x = encoded(a), y = encoded(b);
    ck_assert_uint_eq(x.n, y.n);
    ck_assert_mem_eq(x.p, y.p, x.n);
    double score;
    ck_assert_int_eq(phks_score(a, b, &score), PHKS_OK);
    ck_assert_double_eq(score, 0);
    free(x.p);
    free(y.p);
    phks_signature_free(a);
    phks_signature_free(b);
    phks_spectrum_free(spec);
}

/* Closed and cut, the defaults (verified matching: samples and layout)
 * and the paper's nearest matching with plain HKS and no taper. */
START_TEST(picked_vertices_give_the_same_signature)
{
    phks_options paper;
    phks_options_init(&paper);
    paper.matching = PHKS_MATCHING_NEAREST;
    paper.hks_scaling = PHKS_HKS_SCALING_NONE;
    paper.boundary_margin = 0;
    phks_mesh *closed = creature_mesh(SHAPE_HAND, 2);
    phks_mesh *cut = incomplete(SHAPE_OCTOPUS, 1, 17);
    ck_assert_uint_gt(phks_mesh_boundary_edge_count(cut), 0);
    same_signature(closed, NULL);
    same_signature(cut, NULL);
    same_signature(cut, &paper);
    phks_mesh_free(closed);
    phks_mesh_free(cut);
}
END_TEST

/* Points in another order keep their vectors and their distances; the
 * samples, spread from the set of points, do not move. */
START_TEST(order_is_kept)
{
    phks_mesh *m = incomplete(SHAPE_HAND, 1, 5);
    phks_spectrum *spec;
    phks_signature *a, *b;
    ck_assert_int_eq(phks_spectrum_compute(m, NULL, &spec), PHKS_OK);
    ck_assert_int_eq(phks_signature_from_spectrum(m, spec, NULL, &a), PHKS_OK);
    size_t n = phks_signature_feature_count(a);
    uint32_t v[15];
    ck_assert_uint_le(n, 15);
    for (size_t i = 0; i < n; i++)
        v[i] = phks_signature_feature_vertex(a, n - 1 - i);
    ck_assert_int_eq(phks_signature_at_vertices(m, spec, NULL, v, n, &b),
                     PHKS_OK);
    size_t points = phks__signature_points(a), len = a->length;
    ck_assert_uint_eq(phks__signature_points(b), points);
    /* where b's point i is a's */
    size_t *of = malloc(points * sizeof *of);
    for (size_t i = 0; i < points; i++)
        of[i] = i < n ? n - 1 - i : i;
    for (size_t i = 0; i < points; i++) {
        ck_assert_uint_eq(b->vertex[i], a->vertex[of[i]]);
        ck_assert_mem_eq(b->vectors + i * len, a->vectors + of[i] * len,
                         len * sizeof *b->vectors);
        ck_assert_float_eq(b->boundary[i], a->boundary[of[i]]);
        for (size_t j = 0; j < i; j++) {
            size_t p = of[i] < of[j] ? of[i] : of[j];
            size_t q = of[i] < of[j] ? of[j] : of[i];
            ck_assert_float_eq(b->geodesic[phks__pair_index(j, i)],
                               a->geodesic[phks__pair_index(p, q)]);
        }
    }
    free(of);
    phks_signature_free(a);
    phks_signature_free(b);
    phks_spectrum_free(spec);
    phks_mesh_free(m);
}
END_TEST

/* Each refusal: the status, *signature NULL, the function named. */
static void refused(const phks_mesh *m, const phks_spectrum *spec,
                    const phks_options *o, const uint32_t *v, size_t count,
                    bool with_out)
{
    phks_signature *sig = (phks_signature *)1;
    ck_assert_int_eq(phks_signature_at_vertices(m, spec, o, v, count,
                                                with_out ? &sig : NULL),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(),
                                 "phks_signature_at_vertices"));
    if (with_out)
        ck_assert_ptr_null(sig);
}

START_TEST(argument_errors)
{
    phks_mesh *m = creature_mesh(SHAPE_PLIER, 0), *other = creature_mesh(SHAPE_HAND, 0);
    phks_spectrum *spec;
    ck_assert_int_eq(phks_spectrum_compute(m, NULL, &spec), PHKS_OK);
    uint32_t n = (uint32_t)phks_mesh_vertex_count(m);
    uint32_t v[16];
    for (uint32_t i = 0; i < 16; i++)
        v[i] = i * 7;
    refused(NULL, spec, NULL, v, 3, true);
    refused(m, NULL, NULL, v, 3, true);
    refused(m, spec, NULL, NULL, 3, true);
    refused(m, spec, NULL, v, 3, false);
    refused(m, spec, NULL, v, 0, true);
    refused(m, spec, NULL, v, 16, true);  /* above feature_count, 15 */
    phks_options few;
    phks_options_init(&few);
    few.feature_count = 2;
    phks_spectrum *few_spec;
    ck_assert_int_eq(phks_spectrum_compute(m, &few, &few_spec), PHKS_OK);
    refused(m, few_spec, &few, v, 3, true);
    refused(other, spec, NULL, v, 3, true);  /* another mesh's spectrum */
    phks_options literal;
    phks_options_init(&literal);
    literal.operator_kind = PHKS_OPERATOR_LITERAL;
    refused(m, spec, &literal, v, 3, true);  /* not the spectrum's options */
    v[2] = n;
    refused(m, spec, NULL, v, 3, true);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "out of range"));
    v[2] = v[0];
    refused(m, spec, NULL, v, 3, true);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "twice"));
    /* The limits themselves are accepted: one point, feature_count
     * points, the last vertex. */
    phks_signature *sig;
    v[2] = n - 1;
    ck_assert_int_eq(phks_signature_at_vertices(m, few_spec, &few, v + 1, 2,
                                                &sig), PHKS_OK);
    ck_assert_uint_eq(phks_signature_feature_count(sig), 2);
    ck_assert_uint_eq(phks_signature_feature_vertex(sig, 1), n - 1);
    phks_signature_free(sig);
    for (uint32_t i = 0; i < 16; i++)
        v[i] = i * 7;
    ck_assert_int_eq(phks_signature_at_vertices(m, spec, NULL, v, 15, &sig),
                     PHKS_OK);
    ck_assert_uint_eq(phks_signature_feature_count(sig), 15);
    phks_signature_free(sig);
    ck_assert_int_eq(phks_signature_at_vertices(m, spec, NULL, v, 1, &sig),
                     PHKS_OK);
    ck_assert_uint_eq(phks_signature_feature_count(sig), 1);
    phks_signature_free(sig);
    phks_spectrum_free(few_spec);
    phks_spectrum_free(spec);
    phks_mesh_free(other);
    phks_mesh_free(m);
}
END_TEST

int main(void)
{
    Suite *s = suite_create("at_vertices");
    TCase *c = tcase_create("at_vertices");
    tcase_set_timeout(c, 600);
    tcase_add_test(c, picked_vertices_give_the_same_signature);
    tcase_add_test(c, order_is_kept);
    tcase_add_test(c, argument_errors);
    suite_add_tcase(s, c);
    return run_suite(s);
}
