/* test_similarity.c - phks_similarity (include/phks.h; docs/method.md
 * section 14, "What a score means"): 1 and every feature verified for a
 * signature against itself, strictly between 0 and 1 for two creatures of
 * different kinds, Q read back from phks_score and phks_score_nearest and
 * the verified count from phks_match, the NEAREST formula worked by hand,
 * the refusals, and phks_db_similarity: the same numbers for an entry read
 * back from a database. And phks_candidates, what the verification
 * proposes: a feature's own point first at affinity 1 against itself (or
 * after equal descriptions of lower index), and
 * against another shape at least the affinity of the vectors' steps at
 * the unit scale, worked here from the public vectors. */
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
 * phks_match, in both directions: strictly between 0 and 1, and at most
 * every feature verified. (With spin images proposing, a quadruped's
 * limbs, neck and head find a consistent set on a humanoid, so the count
 * may reach every feature: the similarity is what tells the kinds apart,
 * test_signature.c's poses_score_far_closer_than_kinds.) */
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
        ck_assert_uint_le(verified, phks_signature_feature_count(q));
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

/* Against itself a feature's own point is proposed at affinity 1, first
 * but for ties: with spin images the quadruped's features left and right
 * (and front and back) of it have equal images, quantised to the same
 * bytes, in groups of two and four, and equal descriptions go to the
 * lower index. Most alike first, every affinity
 * in (0, 1]. */
START_TEST(candidates_of_itself_start_with_the_feature)
{
    phks_signature *a = creature(SHAPE_QUADRUPED, PHKS_MATCHING_VERIFIED);
    phks_candidate c[5];
    for (size_t i = 0; i < phks_signature_feature_count(a); i++) {
        size_t count = 0;
        ck_assert_int_eq(phks_candidates(a, i, a, 5, c, &count), PHKS_OK);
        ck_assert_uint_eq(count, 5);
        size_t own = 0;
        while (own < count && c[own].point != i) {
            ck_assert(c[own].affinity == 1.0 && c[own].point < i);
            own++;
        }
        ck_assert_uint_lt(own, count);
        ck_assert(c[own].affinity == 1.0);
        for (size_t r = 1; r < count; r++) {
            ck_assert(c[r].affinity <= c[r - 1].affinity && c[r].affinity > 0);
            ck_assert(c[r].affinity < c[r - 1].affinity ||
                      c[r].point > c[r - 1].point);
        }
    }
    phks_signature_free(a);
}
END_TEST

/* The affinity the verifier gives feature i of a and point j of b at the
 * unit scale, from the public vectors: the L1 distance of their steps
 * from one time scale to the next, scaled to the vector's length L,
 * through exp(-D / (0.15 L)) (docs/method.md section 14). The creatures
 * are closed: no boundary weighs a step down. */
static double unit_scale_affinity(const phks_signature *a, size_t i,
                                  const phks_signature *b, size_t j)
{
    size_t L = phks_signature_vector_length(a);
    const double *x = phks_signature_feature_vector(a, i);
    const double *y = phks_signature_feature_vector(b, j);
    double sum = 0;
    for (size_t k = 1; k < L; k++)
        sum += fabs((x[k] - x[k - 1]) - (y[k] - y[k - 1]));
    double distance = sum / (double)(L - 1) * (double)L;
    return exp(-distance / (0.15 * (double)L));
}

START_TEST(candidates_are_at_least_the_unit_scale_best)
{
    phks_signature *a = creature(SHAPE_QUADRUPED, PHKS_MATCHING_VERIFIED);
    phks_signature *b = creature(SHAPE_HUMANOID, PHKS_MATCHING_VERIFIED);
    size_t points = phks_signature_feature_count(b) +
                    phks_signature_sample_count(b);
    for (size_t i = 0; i < phks_signature_feature_count(a); i++) {
        phks_candidate c[3];
        size_t count = 0;
        ck_assert_int_eq(phks_candidates(a, i, b, 3, c, &count), PHKS_OK);
        ck_assert_uint_eq(count, 3);
        double most = 0;
        for (size_t j = 0; j < points; j++)
            most = fmax(most, unit_scale_affinity(a, i, b, j));
        ck_assert_msg(c[0].affinity >= most * (1 - 1e-12),
                      "feature %zu: best %.6f, unit scale alone %.6f", i,
                      c[0].affinity, most);
        for (size_t r = 0; r < count; r++)
            ck_assert(c[r].affinity >= unit_scale_affinity(a, i, b,
                                                           c[r].point) *
                                           (1 - 1e-12));
    }
    phks_signature_free(a);
    phks_signature_free(b);
}
END_TEST

START_TEST(candidates_refusals)
{
    phks_signature *a = creature(SHAPE_QUADRUPED, PHKS_MATCHING_VERIFIED);
    phks_signature *n = creature(SHAPE_QUADRUPED, PHKS_MATCHING_NEAREST);
    phks_candidate c[2];
    size_t count = 7;
    size_t features = phks_signature_feature_count(a);
    ck_assert_int_eq(phks_candidates(n, 0, n, 2, c, &count),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_uint_eq(count, 0);
    ck_assert_int_eq(phks_candidates(a, 0, n, 2, c, &count),
                     PHKS_ERROR_INCOMPATIBLE);
    ck_assert_int_eq(phks_candidates(a, features, a, 2, c, &count),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_candidates(a, 0, a, 0, c, &count),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_candidates(NULL, 0, a, 2, c, &count),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_candidates(a, 0, a, 2, NULL, &count),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_candidates(a, 0, a, 2, c, NULL),
                     PHKS_ERROR_INVALID_ARGUMENT);
    phks_signature_free(a);
    phks_signature_free(n);
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
    tcase_add_test(c, candidates_of_itself_start_with_the_feature);
    tcase_add_test(c, candidates_are_at_least_the_unit_scale_best);
    tcase_add_test(c, candidates_refusals);
    suite_add_tcase(s, c);
    return run_suite(s);
}
