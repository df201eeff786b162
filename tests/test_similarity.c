/* test_similarity.c - phks_similarity (include/phks.h; docs/method.md
 * section 14, "What a score means"): 1 and every feature verified for a
 * signature against itself, strictly between 0 and 1 for two creatures of
 * different kinds, Q read back from phks_score and phks_score_nearest and
 * the verified count from phks_match, the NEAREST formula worked by hand,
 * the refusals, and phks_db_similarity: the same numbers for an entry read
 * back from a database. */
#include "shapes.h"
#include "testutil.h"

#include <math.h>
#include <stdlib.h>

static phks_signature *creature(unsigned kind, phks_matching matching)
{
    double angles[SHAPE_MAX_JOINTS];
    shape_mesh s;
    shape_creature_pose(kind, 0, angles);
    ck_assert_int_eq(shape_creature(kind, angles, 1, &s), 0);
    phks_mesh *m;
    ck_assert_int_eq(phks_mesh_create(s.xyz, s.vertex_count, s.triangles,
                                      s.triangle_count, &m), PHKS_OK);
    phks_options o;
    ck_assert_int_eq(phks_options_init(&o), PHKS_OK);
    o.matching = matching;
    phks_signature *sig;
    ck_assert_int_eq(phks_signature_compute(m, &o, &sig), PHKS_OK);
    phks_mesh_free(m);
    shape_mesh_free(&s);
    return sig;
}

/* The rows of phks_match(a, b) with from_a = 1 and verified = 1. */
static size_t verified_rows(const phks_signature *a, const phks_signature *b)
{
    size_t count;
    ck_assert_int_eq(phks_match(a, b, NULL, 0, &count, NULL), PHKS_OK);
    phks_correspondence *c = malloc(count * sizeof *c);
    ck_assert_ptr_nonnull(c);
    ck_assert_int_eq(phks_match(a, b, c, count, &count, NULL), PHKS_OK);
    size_t n = 0;
    for (size_t i = 0; i < count; i++)
        n += c[i].from_a && c[i].verified;
    free(c);
    return n;
}

START_TEST(self_is_one_and_all_verified)
{
    phks_signature *a = creature(SHAPE_QUADRUPED, PHKS_MATCHING_VERIFIED);
    double sim = -1;
    size_t verified = 0;
    ck_assert_int_eq(phks_similarity(a, a, &sim, &verified), PHKS_OK);
    ck_assert(sim == 1.0);
    ck_assert_uint_eq(verified, phks_signature_feature_count(a));
    ck_assert_uint_eq(verified, verified_rows(a, a));
    phks_signature_free(a);
}
END_TEST

/* Q = 1 - score / nearest of the public scores, and the verified rows of
 * phks_match, in both directions. */
START_TEST(two_kinds_lie_between)
{
    phks_signature *a = creature(SHAPE_QUADRUPED, PHKS_MATCHING_VERIFIED);
    phks_signature *b = creature(SHAPE_HUMANOID, PHKS_MATCHING_VERIFIED);
    const phks_signature *pair[2][2] = {{a, b}, {b, a}};
    for (int d = 0; d < 2; d++) {
        const phks_signature *q = pair[d][0], *e = pair[d][1];
        double sim, score, nearest;
        size_t verified;
        ck_assert_int_eq(phks_similarity(q, e, &sim, &verified), PHKS_OK);
        ck_assert_int_eq(phks_score(q, e, &score), PHKS_OK);
        ck_assert_int_eq(phks_score_nearest(q, e, &nearest), PHKS_OK);
        ck_assert(sim > 0 && sim < 1);
        ck_assert_double_eq_tol(sim, 1 - score / nearest, 1e-12);
        ck_assert_uint_eq(verified, verified_rows(q, e));
        ck_assert_uint_lt(verified, phks_signature_feature_count(q));
        ck_assert_int_eq(phks_similarity(q, e, &sim, NULL), PHKS_OK);
    }
    phks_signature_free(a);
    phks_signature_free(b);
}
END_TEST

/* exp(-nearest / ((n_a + n_b) L 0.15)), worked from phks_score_nearest;
 * symmetric up to rounding; nothing verified. */
START_TEST(nearest_follows_its_formula)
{
    phks_signature *a = creature(SHAPE_QUADRUPED, PHKS_MATCHING_NEAREST);
    phks_signature *b = creature(SHAPE_OCTOPUS, PHKS_MATCHING_NEAREST);
    double nearest, ab, ba;
    size_t verified = 99;
    ck_assert_int_eq(phks_score_nearest(a, b, &nearest), PHKS_OK);
    ck_assert_int_eq(phks_similarity(a, b, &ab, &verified), PHKS_OK);
    ck_assert_int_eq(phks_similarity(b, a, &ba, NULL), PHKS_OK);
    double terms = (double)(phks_signature_feature_count(a) +
                            phks_signature_feature_count(b)) *
                   (double)phks_signature_vector_length(a);
    ck_assert_double_eq_tol(ab, exp(-nearest / (terms * 0.15)), 1e-15);
    ck_assert(ab > 0 && ab < 1);
    ck_assert_double_eq_tol(ab, ba, 1e-12); /* the sums run in another order */
    ck_assert_uint_eq(verified, 0);
    ck_assert_int_eq(phks_similarity(a, a, &ab, &verified), PHKS_OK);
    ck_assert(ab == 1.0);
    ck_assert_uint_eq(verified, 0);
    phks_signature_free(a);
    phks_signature_free(b);
}
END_TEST

START_TEST(refusals)
{
    phks_signature *a = creature(SHAPE_QUADRUPED, PHKS_MATCHING_VERIFIED);
    phks_signature *n = creature(SHAPE_QUADRUPED, PHKS_MATCHING_NEAREST);
    double sim;
    size_t verified;
    ck_assert_int_eq(phks_similarity(NULL, a, &sim, &verified),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_similarity(a, NULL, &sim, &verified),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_similarity(a, a, NULL, &verified),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_similarity(a, n, &sim, &verified),
                     PHKS_ERROR_INCOMPATIBLE);
    phks_signature_free(a);
    phks_signature_free(n);
}
END_TEST

START_TEST(database_entry_gives_the_same)
{
    phks_signature *a = creature(SHAPE_QUADRUPED, PHKS_MATCHING_VERIFIED);
    phks_signature *b = creature(SHAPE_HUMANOID, PHKS_MATCHING_VERIFIED);
    phks_db *db;
    ck_assert_int_eq(phks_db_open(":memory:", 0, &db), PHKS_OK);
    int64_t id;
    ck_assert_int_eq(phks_db_add(db, "b", NULL, b, &id), PHKS_OK);
    double want, got = -1;
    size_t want_verified, got_verified = 99;
    ck_assert_int_eq(phks_similarity(a, b, &want, &want_verified), PHKS_OK);
    ck_assert_int_eq(phks_db_similarity(db, a, id, &got, &got_verified),
                     PHKS_OK);
    /* The stored blob keeps the layout as floats, as b's own samples
     * are: the same numbers. */
    ck_assert(got == want);
    ck_assert_uint_eq(got_verified, want_verified);
    ck_assert_int_eq(phks_db_similarity(db, a, id + 1, &got, NULL),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_db_similarity(NULL, a, id, &got, NULL),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_db_similarity(db, NULL, id, &got, NULL),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_db_similarity(db, a, id, NULL, NULL),
                     PHKS_ERROR_INVALID_ARGUMENT);
    phks_db_close(db);
    phks_signature_free(a);
    phks_signature_free(b);
}
END_TEST

int main(void)
{
    Suite *s = suite_create("similarity");
    TCase *c = tcase_create("similarity");
    tcase_set_timeout(c, 300);
    tcase_add_test(c, self_is_one_and_all_verified);
    tcase_add_test(c, two_kinds_lie_between);
    tcase_add_test(c, nearest_follows_its_formula);
    tcase_add_test(c, refusals);
    tcase_add_test(c, database_entry_gives_the_same);
    suite_add_tcase(s, c);
    return run_suite(s);
}
