/* test_api.c - versions, statuses, per-thread messages, options, and the
 * allocator hook. */
#include "testutil.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

START_TEST(version_matches_header)
{
    ck_assert_uint_eq(phks_version_number(), PHKS_VERSION_NUMBER);
    char expect[32];
    snprintf(expect, sizeof expect, "%d.%d.%d", PHKS_VERSION_MAJOR,
             PHKS_VERSION_MINOR, PHKS_VERSION_PATCH);
    ck_assert_str_eq(phks_version_string(), expect);
}
END_TEST

START_TEST(every_status_has_its_own_string)
{
    const char *seen[PHKS_ERROR_SOLVER + 1];
    for (int s = 0; s <= PHKS_ERROR_SOLVER; s++) {
        seen[s] = phks_status_string((phks_status)s);
        ck_assert_str_ne(seen[s], "unknown status");
        for (int t = 0; t < s; t++)
            ck_assert_str_ne(seen[s], seen[t]);
    }
    ck_assert_str_eq(phks_status_string((phks_status)9999), "unknown status");
}
END_TEST

static void *fail_in_thread(void *arg)
{
    phks_mesh *m;
    const uint32_t tri[3] = {0, 1, 7};
    const double xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    phks_mesh_create(xyz, 3, tri, 1, &m);
    return strstr(phks_last_error_message(), "index 7") ? arg : NULL;
}

START_TEST(error_messages_are_per_thread)
{
    const double xyz[9] = {0, 0, NAN, 1, 0, 0, 0, 1, 0};
    const uint32_t tri[3] = {0, 1, 2};
    phks_mesh *m = (phks_mesh *)1;
    ck_assert_int_eq(phks_mesh_create(xyz, 3, tri, 1, &m), PHKS_ERROR_NON_FINITE);
    ck_assert_ptr_null(m);
    pthread_t t;
    void *result = NULL;
    ck_assert_int_eq(pthread_create(&t, NULL, fail_in_thread, (void *)1), 0);
    pthread_join(t, &result);
    ck_assert_ptr_nonnull(result);
    /* The other thread's failure did not touch this thread's message. */
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "not finite"));
}
END_TEST

START_TEST(options_defaults_are_the_papers)
{
    phks_options o;
    ck_assert_int_eq(phks_options_init(&o), PHKS_OK);
    ck_assert_uint_eq(o.version, PHKS_OPTIONS_VERSION);
    ck_assert_double_eq(o.tau, 0.0002);
    ck_assert_uint_eq(o.eigen_count, 300);
    ck_assert_uint_eq(o.feature_count, 15);
    ck_assert_double_eq(o.feature_scale, 5);
    const double scales[15] = {5,   20,  40,  60,  100, 150, 200, 300,
                               400, 500, 600, 700, 800, 900, 1000};
    ck_assert_uint_eq(o.scale_count, 15);
    for (int i = 0; i < 15; i++)
        ck_assert_double_eq(o.scales[i], scales[i]);
    /* The documented departures for partial shapes (docs/retrieval.md). */
    ck_assert_int_eq(o.operator_kind, PHKS_OPERATOR_RANDOM_WALK);
    ck_assert_double_eq(o.boundary_margin, 2);
    ck_assert_int_eq(o.hks_scaling, PHKS_HKS_SCALING_LOCAL_AREA);
    ck_assert_int_eq(o.matching, PHKS_MATCHING_VERIFIED);
    ck_assert_int_eq(o.local_descriptor, PHKS_LOCAL_DESCRIPTOR_SPIN);
    ck_assert_int_eq(o.global_descriptor, PHKS_GLOBAL_DESCRIPTOR_NONE);
    ck_assert_int_eq(phks_options_init(NULL), PHKS_ERROR_INVALID_ARGUMENT);
}
END_TEST

/* Each bad field is named in the message. */
START_TEST(bad_options_are_refused)
{
    const double xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const uint32_t tri[3] = {0, 1, 2};
    phks_mesh *m;
    ck_assert_int_eq(phks_mesh_create(xyz, 3, tri, 1, &m), PHKS_OK);
    phks_options o;
    phks_spectrum *s;
#define REFUSED(stmt, word)                                                    \
    do {                                                                       \
        phks_options_init(&o);                                                 \
        stmt;                                                                  \
        s = (phks_spectrum *)1;                                                \
        ck_assert_int_eq(phks_spectrum_compute(m, &o, &s),                     \
                         PHKS_ERROR_INVALID_ARGUMENT);                         \
        ck_assert_ptr_null(s);                                                 \
        ck_assert_ptr_nonnull(strstr(phks_last_error_message(), word));        \
    } while (0)
    REFUSED(o.version = 0, "version");
    REFUSED(o.tau = -1, "tau");
    REFUSED(o.tau = NAN, "tau");
    REFUSED(o.eigen_count = 0, "eigen_count");
    REFUSED(o.cutoff = 0.5, "cutoff");
    REFUSED(o.scale_count = 0, "scale_count");
    REFUSED(o.scale_count = PHKS_MAX_SCALES + 1, "scale_count");
    REFUSED(o.scales[3] = INFINITY, "scales[3]");
    REFUSED(o.feature_scale = 0, "feature_scale");
    REFUSED(o.operator_kind = 7, "operator_kind");
    REFUSED(o.box = -1, "box");
    REFUSED(o.solver = 9, "solver");
    REFUSED(o.tolerance = 0, "tolerance");
    REFUSED(o.hks_scaling = 3, "hks_scaling");
    REFUSED(o.boundary_margin = -1, "boundary_margin");
    REFUSED(o.local_descriptor = 7, "unknown local_descriptor 7");
    /* Checked with NEAREST too, which ignores a valid one. */
    REFUSED((o.matching = PHKS_MATCHING_NEAREST, o.local_descriptor = -1),
            "local_descriptor");
    REFUSED(o.global_descriptor = 2, "unknown global_descriptor 2");
    REFUSED((o.matching = PHKS_MATCHING_NEAREST, o.global_descriptor = -1),
            "global_descriptor");
#undef REFUSED
    phks_mesh_free(m);
}
END_TEST

/* A caller built against 0.2.0's header left local_descriptor (its
 * reserved_pad) zero: HEAT, a valid value, so its options still pass. */
START_TEST(old_callers_zero_pad_is_heat)
{
    phks_options o, resolved;
    phks_options_init(&o);
    o.local_descriptor = 0;
    ck_assert_int_eq(phks_option_set(&o, 0, "0.0002", PHKS_SPELLING_C),
                     PHKS_OK);
    ck_assert_int_eq(o.local_descriptor, PHKS_LOCAL_DESCRIPTOR_HEAT);
    ck_assert_int_eq(phks__options_resolve(&o, &resolved), PHKS_OK);
    ck_assert_int_eq(resolved.local_descriptor, PHKS_LOCAL_DESCRIPTOR_HEAT);
}
END_TEST

/* A caller built against 0.2.0's header left its reserved words, from
 * where global_descriptor now sits to the end, zero: NONE, so its options
 * still pass. */
START_TEST(old_callers_zero_reserved_is_no_global_descriptor)
{
    phks_options o, resolved;
    phks_options_init(&o);
    size_t from = offsetof(phks_options, global_descriptor);
    memset((char *)&o + from, 0, sizeof o - from);
    ck_assert_int_eq(phks__options_resolve(&o, &resolved), PHKS_OK);
    ck_assert_int_eq(resolved.global_descriptor, PHKS_GLOBAL_DESCRIPTOR_NONE);
}
END_TEST

/* Two VERIFIED option sets of other global descriptors are incomparable,
 * the message naming the option and both values; NEAREST ignores it. */
START_TEST(global_descriptor_compares_only_when_verified)
{
    phks_options a, b;
    phks_options_init(&a);
    b = a;
    b.global_descriptor = PHKS_GLOBAL_DESCRIPTOR_D2;
    char detail[64];
    ck_assert_int_eq(phks_options_compare(&a, &b, PHKS_SPELLING_C, detail,
                                          sizeof detail),
                     PHKS_ERROR_INCOMPATIBLE);
    ck_assert_str_eq(detail, "global_descriptor none against d2");
    ck_assert_str_eq(phks_last_error_message(),
                     "options differ: global_descriptor none against d2");
    ck_assert(!phks__options_comparable(&a, &b));
    a.matching = b.matching = PHKS_MATCHING_NEAREST;
    ck_assert_int_eq(phks_options_compare(&a, &b, PHKS_SPELLING_C, NULL, 0),
                     PHKS_OK);
    ck_assert(phks__options_comparable(&a, &b));
}
END_TEST

/* Failing the i-th allocation of a mesh build, for every i, gives
 * PHKS_ERROR_OUT_OF_MEMORY and leaks nothing. */
START_TEST(allocator_hook_sees_every_allocation)
{
    phks_allocator a = {count_malloc, count_realloc, count_free, NULL};
    ck_assert_int_eq(phks_set_allocator(&a), PHKS_OK);
    const double xyz[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    const uint32_t tri[12] = {0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2};
    phks_mesh *m;
    alloc_fail_at = -1;
    alloc_calls = alloc_live = 0;
    ck_assert_int_eq(phks_mesh_create(xyz, 4, tri, 4, &m), PHKS_OK);
    long total = alloc_calls;
    ck_assert_uint_gt(alloc_live, 0);
    phks_mesh_free(m);
    ck_assert_uint_eq(alloc_live, 0);
    for (alloc_fail_at = 0; alloc_fail_at < total; alloc_fail_at++) {
        alloc_calls = 0;
        m = (phks_mesh *)1;
        phks_status st = phks_mesh_create(xyz, 4, tri, 4, &m);
        if (st == PHKS_OK) { /* a failed shrinking realloc is harmless */
            phks_mesh_free(m);
        } else {
            ck_assert_int_eq(st, PHKS_ERROR_OUT_OF_MEMORY);
            ck_assert_ptr_null(m);
        }
        ck_assert_uint_eq(alloc_live, 0);
    }
    alloc_fail_at = -1;
    ck_assert_int_eq(phks_set_allocator(NULL), PHKS_OK);
    phks_allocator half = {count_malloc, NULL, count_free, NULL};
    ck_assert_int_eq(phks_set_allocator(&half), PHKS_ERROR_INVALID_ARGUMENT);
}
END_TEST

START_TEST(null_handles_are_harmless)
{
    phks_mesh_free(NULL);
    phks_spectrum_free(NULL);
    phks_signature_free(NULL);
    ck_assert_uint_eq(phks_mesh_vertex_count(NULL), 0);
    ck_assert_ptr_null(phks_mesh_vertices(NULL));
    ck_assert_uint_eq(phks_spectrum_count(NULL), 0);
    ck_assert_ptr_null(phks_spectrum_eigenvector(NULL, 0));
    ck_assert_uint_eq(phks_signature_feature_count(NULL), 0);
    ck_assert(isnan(phks_signature_feature_persistence(NULL, 0)));
    ck_assert_int_eq(phks_spectrum_compute(NULL, NULL, NULL),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_signature_compute(NULL, NULL, NULL),
                     PHKS_ERROR_INVALID_ARGUMENT);
    double score;
    ck_assert_int_eq(phks_score(NULL, NULL, &score), PHKS_ERROR_INVALID_ARGUMENT);
}
END_TEST

int main(void)
{
    Suite *s = suite_create("api");
    TCase *c = tcase_create("api");
    tcase_add_test(c, version_matches_header);
    tcase_add_test(c, every_status_has_its_own_string);
    tcase_add_test(c, error_messages_are_per_thread);
    tcase_add_test(c, options_defaults_are_the_papers);
    tcase_add_test(c, bad_options_are_refused);
    tcase_add_test(c, old_callers_zero_pad_is_heat);
    tcase_add_test(c, old_callers_zero_reserved_is_no_global_descriptor);
    tcase_add_test(c, global_descriptor_compares_only_when_verified);
    tcase_add_test(c, allocator_hook_sees_every_allocation);
    tcase_add_test(c, null_handles_are_harmless);
    suite_add_tcase(s, c);
    return run_suite(s);
}
