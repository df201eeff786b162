/* test_option_names.c - the table of option names and values
 * (phks_option_name, _find, _value_name, _set, _format and
 * phks_options_compare) against the names the tool's manual
 * (docs/cli.md) and the Python module's (docs/python.md) promise, written
 * out here by hand. */
#include "testutil.h"

#include <string.h>

/* Index of the option called name in spelling, failing the test when none
 * is. */
static uint32_t index_of(const char *name, phks_spelling spelling)
{
    uint32_t i = 99;
    ck_assert_msg(phks_option_find(name, spelling, &i) == PHKS_OK,
                  "no option %s", name);
    return i;
}

static void set(phks_options *o, const char *name, const char *text,
                phks_spelling spelling)
{
    ck_assert_msg(phks_option_set(o, index_of(name, spelling), text,
                                  spelling) == PHKS_OK,
                  "%s %s: %s", name, text, phks_last_error_message());
}

START_TEST(tool_words_set_the_fields_the_manual_says)
{
    phks_options o;
    phks_options_init(&o);
    const phks_spelling cli = PHKS_SPELLING_CLI;
    set(&o, "operator", "literal", cli);
    ck_assert_int_eq(o.operator_kind, PHKS_OPERATOR_LITERAL);
    set(&o, "operator", "random-walk", cli);
    ck_assert_int_eq(o.operator_kind, PHKS_OPERATOR_RANDOM_WALK);
    set(&o, "hks-scaling", "none", cli);
    ck_assert_int_eq(o.hks_scaling, PHKS_HKS_SCALING_NONE);
    set(&o, "hks-scaling", "mean", cli);
    ck_assert_int_eq(o.hks_scaling, PHKS_HKS_SCALING_MEAN);
    set(&o, "hks-scaling", "local-area", cli);
    ck_assert_int_eq(o.hks_scaling, PHKS_HKS_SCALING_LOCAL_AREA);
    set(&o, "quadrature", "triangles", cli);
    ck_assert_int_eq(o.quadrature, PHKS_QUADRATURE_TRIANGLES);
    set(&o, "matching", "nearest", cli);
    ck_assert_int_eq(o.matching, PHKS_MATCHING_NEAREST);
    set(&o, "local-descriptor", "heat", cli);
    ck_assert_int_eq(o.local_descriptor, PHKS_LOCAL_DESCRIPTOR_HEAT);
    set(&o, "local-descriptor", "spin", cli);
    ck_assert_int_eq(o.local_descriptor, PHKS_LOCAL_DESCRIPTOR_SPIN);
    set(&o, "global-descriptor", "d2", cli);
    ck_assert_int_eq(o.global_descriptor, PHKS_GLOBAL_DESCRIPTOR_D2);
    set(&o, "global-descriptor", "none", cli);
    ck_assert_int_eq(o.global_descriptor, PHKS_GLOBAL_DESCRIPTOR_NONE);
    set(&o, "box", "axis-aligned", cli);
    ck_assert_int_eq(o.box, PHKS_BOX_AXIS_ALIGNED);
    set(&o, "solver", "arpack", cli);
    ck_assert_int_eq(o.solver, PHKS_SOLVER_ARPACK);
    set(&o, "boundary-margin", "0.5", cli);
    ck_assert(o.boundary_margin == 0.5);
    set(&o, "threads", "3", cli);
    ck_assert_uint_eq(o.threads, 3);
    set(&o, "eigen-count", "120", cli);
    ck_assert_uint_eq(o.eigen_count, 120);
    set(&o, "scales", "5,20,1e3", cli);
    ck_assert_uint_eq(o.scale_count, 3);
    ck_assert(o.scales[0] == 5 && o.scales[1] == 20 && o.scales[2] == 1000);
}
END_TEST

START_TEST(python_words_are_the_fields_names)
{
    phks_options o;
    phks_options_init(&o);
    const phks_spelling c = PHKS_SPELLING_C;
    set(&o, "operator_kind", "literal", c);
    ck_assert_int_eq(o.operator_kind, PHKS_OPERATOR_LITERAL);
    set(&o, "hks_scaling", "local_area", c);
    ck_assert_int_eq(o.hks_scaling, PHKS_HKS_SCALING_LOCAL_AREA);
    set(&o, "box", "axis_aligned", c);
    ck_assert_int_eq(o.box, PHKS_BOX_AXIS_ALIGNED);
    set(&o, "simplify_target", "5000", c);
    ck_assert_uint_eq(o.simplify_target, 5000);
    /* An enum also by its number, as Python's keywords take it. */
    set(&o, "matching", "0", c);
    ck_assert_int_eq(o.matching, PHKS_MATCHING_NEAREST);
    set(&o, "local_descriptor", "heat", c);
    ck_assert_int_eq(o.local_descriptor, PHKS_LOCAL_DESCRIPTOR_HEAT);
    set(&o, "local_descriptor", "1", c);
    ck_assert_int_eq(o.local_descriptor, PHKS_LOCAL_DESCRIPTOR_SPIN);
    set(&o, "global_descriptor", "d2", c);
    ck_assert_int_eq(o.global_descriptor, PHKS_GLOBAL_DESCRIPTOR_D2);
    set(&o, "global_descriptor", "0", c);
    ck_assert_int_eq(o.global_descriptor, PHKS_GLOBAL_DESCRIPTOR_NONE);
    /* The other binding's words are not these. */
    uint32_t i;
    ck_assert_int_eq(phks_option_find("hks-scaling", c, &i),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_option_set(&o, index_of("hks_scaling", c),
                                     "local-area", c),
                     PHKS_ERROR_INVALID_ARGUMENT);
}
END_TEST

/* Every option, in both spellings, formats to a text that sets it back to
 * the same bytes, from the defaults and from changed values. */
START_TEST(every_option_reads_back_what_it_writes)
{
    const phks_spelling spellings[] = {PHKS_SPELLING_C, PHKS_SPELLING_CLI};
    phks_options changed;
    phks_options_init(&changed);
    changed.tau = 0.1 + 0.2; /* needs 17 digits */
    changed.operator_kind = PHKS_OPERATOR_LITERAL;
    changed.hks_scaling = PHKS_HKS_SCALING_MEAN;
    changed.scale_count = 2;
    changed.threads = 7;
    changed.local_descriptor = PHKS_LOCAL_DESCRIPTOR_HEAT;
    changed.global_descriptor = PHKS_GLOBAL_DESCRIPTOR_D2;
    const phks_options *sources[2] = {NULL, &changed};
    phks_options defaults;
    phks_options_init(&defaults);
    sources[0] = &defaults;
    uint32_t count = 0;
    while (phks_option_name(count, PHKS_SPELLING_C))
        count++;
    /* The 20 fields a caller sets: every one but version, progress,
     * progress_user and the reserved space. */
    ck_assert_uint_eq(count, 20);
    ck_assert_ptr_null(phks_option_name(count, PHKS_SPELLING_CLI));
    for (size_t s = 0; s < 2; s++)
        for (size_t k = 0; k < 2; k++)
            for (uint32_t i = 0; i < count; i++) {
                char text[512];
                ck_assert_int_eq(phks_option_format(sources[k], i,
                                                    spellings[s], text,
                                                    sizeof text),
                                 PHKS_OK);
                phks_options back;
                phks_options_init(&back);
                if (i != index_of("scales", PHKS_SPELLING_C))
                    back.scale_count = sources[k]->scale_count;
                ck_assert_msg(phks_option_set(&back, i, text, spellings[s]) ==
                                  PHKS_OK,
                              "%s = %s: %s",
                              phks_option_name(i, spellings[s]), text,
                              phks_last_error_message());
                char again[512];
                phks_option_format(&back, i, spellings[s], again,
                                   sizeof again);
                ck_assert_str_eq(again, text);
                uint32_t found;
                ck_assert_int_eq(phks_option_find(phks_option_name(
                                                      i, spellings[s]),
                                                  spellings[s], &found),
                                 PHKS_OK);
                ck_assert_uint_eq(found, i);
            }
    char text[32];
    phks_option_format(&changed, index_of("tau", PHKS_SPELLING_C),
                       PHKS_SPELLING_C, text, sizeof text);
    ck_assert_str_eq(text, "0.30000000000000004");
}
END_TEST

START_TEST(types_are_what_the_fields_hold)
{
    const struct {
        const char *name;
        phks_option_type type;
    } expect[] = {
        {"tau", PHKS_OPTION_REAL},          {"boundary_margin", PHKS_OPTION_REAL},
        {"eigen_count", PHKS_OPTION_COUNT}, {"threads", PHKS_OPTION_COUNT},
        {"operator_kind", PHKS_OPTION_ENUM}, {"solver", PHKS_OPTION_ENUM},
        {"local_descriptor", PHKS_OPTION_ENUM},
        {"global_descriptor", PHKS_OPTION_ENUM},
        {"scales", PHKS_OPTION_REALS},
    };
    for (size_t i = 0; i < sizeof expect / sizeof expect[0]; i++) {
        phks_option_type type;
        ck_assert_int_eq(phks_option_type_of(index_of(expect[i].name,
                                                      PHKS_SPELLING_C),
                                             &type),
                         PHKS_OK);
        ck_assert_int_eq(type, expect[i].type);
    }
    /* Every enum names its value 0, and nothing else does. */
    for (uint32_t i = 0; phks_option_name(i, PHKS_SPELLING_C); i++) {
        phks_option_type type;
        phks_option_type_of(i, &type);
        ck_assert_int_eq(type == PHKS_OPTION_ENUM,
                         phks_option_value_name(i, 0, PHKS_SPELLING_C) != NULL);
    }
    phks_option_type type;
    ck_assert_int_eq(phks_option_type_of(99, &type),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_option_type_of(0, NULL),
                     PHKS_ERROR_INVALID_ARGUMENT);
}
END_TEST

START_TEST(value_names_by_value)
{
    const uint32_t scaling = index_of("hks_scaling", PHKS_SPELLING_C);
    ck_assert_str_eq(phks_option_value_name(scaling, 2, PHKS_SPELLING_CLI),
                     "local-area");
    ck_assert_str_eq(phks_option_value_name(scaling, 2, PHKS_SPELLING_C),
                     "local_area");
    ck_assert_ptr_null(phks_option_value_name(scaling, 3, PHKS_SPELLING_C));
    ck_assert_ptr_null(phks_option_value_name(scaling, -1, PHKS_SPELLING_C));
    ck_assert_ptr_null(phks_option_value_name(
        index_of("tau", PHKS_SPELLING_C), 0, PHKS_SPELLING_C));
    ck_assert_ptr_null(
        phks_option_value_name(scaling, 0, (phks_spelling)2));
}
END_TEST

START_TEST(bad_text_is_refused_and_changes_nothing)
{
    phks_options o, before;
    phks_options_init(&o);
    before = o;
    const phks_spelling cli = PHKS_SPELLING_CLI;
    const struct {
        const char *option, *text, *says;
    } cases[] = {
        {"hks-scaling", "local_area", "not one of none, mean, local-area"},
        {"boundary-margin", "abc", "not a finite number"},
        {"boundary-margin", "nan", "not a finite number"},
        {"boundary-margin", "1e999", "not a finite number"},
        {"boundary-margin", "2x", "not a finite number"},
        {"boundary-margin", "200", "boundary_margin 200 outside [0, 100]"},
        {"threads", "-1", "not a count"},
        {"threads", "4294967296", "not a count"},
        {"threads", "2000", "threads 2000 above 1024"},
        {"threads", "", "not a count"},
        {"operator", "7", "unknown operator_kind 7"},
        {"local-descriptor", "7", "unknown local_descriptor 7"},
        {"local-descriptor", "hks", "not one of heat, spin"},
        {"global-descriptor", "2", "unknown global_descriptor 2"},
        {"global-descriptor", "D2", "not one of none, d2"},
        {"scales", "5,,20", "not a list of numbers"},
        {"scales", "5,-1", "scales[1] = -1"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        ck_assert_int_eq(phks_option_set(&o, index_of(cases[i].option, cli),
                                         cases[i].text, cli),
                         PHKS_ERROR_INVALID_ARGUMENT);
        ck_assert_msg(strstr(phks_last_error_message(), cases[i].says),
                      "%s %s: '%s'", cases[i].option, cases[i].text,
                      phks_last_error_message());
        ck_assert_mem_eq(&o, &before, sizeof o);
    }
    char many[200];
    memset(many, 0, sizeof many);
    for (int i = 0; i < 33; i++)
        strcat(many, i ? ",1" : "1");
    ck_assert_int_eq(phks_option_set(&o, index_of("scales", cli), many, cli),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_option_set(NULL, 0, "1", cli),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_option_set(&o, 0, NULL, cli),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_option_set(&o, 99, "1", cli),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_option_set(&o, 0, "1", (phks_spelling)5),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_mem_eq(&o, &before, sizeof o);
}
END_TEST

START_TEST(format_says_when_the_buffer_is_short)
{
    phks_options o;
    phks_options_init(&o);
    const uint32_t scales = index_of("scales", PHKS_SPELLING_C);
    char text[8];
    ck_assert_int_eq(phks_option_format(&o, scales, PHKS_SPELLING_C, text,
                                        sizeof text),
                     PHKS_ERROR_BUFFER_TOO_SMALL);
    ck_assert_uint_lt(strlen(text), sizeof text);
    ck_assert_int_eq(strncmp(text, "5,20,40", 7), 0);
    o.hks_scaling = 9;
    ck_assert_int_eq(phks_option_format(&o, index_of("hks_scaling",
                                                     PHKS_SPELLING_C),
                                        PHKS_SPELLING_C, text, sizeof text),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_option_format(NULL, 0, PHKS_SPELLING_C, text, 8),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_option_format(&o, 0, PHKS_SPELLING_C, text, 0),
                     PHKS_ERROR_INVALID_ARGUMENT);
}
END_TEST

START_TEST(compare_names_both_values_in_the_users_words)
{
    phks_options a, b;
    phks_options_init(&a);
    phks_options_init(&b);
    char detail[128];
    ck_assert_int_eq(phks_options_compare(&a, &b, PHKS_SPELLING_CLI, detail,
                                          sizeof detail),
                     PHKS_OK);
    /* Options that change how, not what, never make two sets differ. */
    b.threads = 3;
    b.solver = PHKS_SOLVER_ARPACK;
    b.tolerance = 1e-8;
    b.simplify_above = 0;
    ck_assert_int_eq(phks_options_compare(&a, &b, PHKS_SPELLING_C, NULL, 0),
                     PHKS_OK);
    b.hks_scaling = PHKS_HKS_SCALING_NONE;
    ck_assert_int_eq(phks_options_compare(&a, &b, PHKS_SPELLING_CLI, detail,
                                          sizeof detail),
                     PHKS_ERROR_INCOMPATIBLE);
    ck_assert_str_eq(detail, "hks-scaling local-area against none");
    ck_assert_str_eq(phks_last_error_message(),
                     "options differ: hks-scaling local-area against none");
    phks_options_compare(&a, &b, PHKS_SPELLING_C, detail, sizeof detail);
    ck_assert_str_eq(detail, "hks_scaling local_area against none");
    /* The first difference in the table's order, and a cut detail. */
    b.operator_kind = PHKS_OPERATOR_LITERAL;
    phks_options_compare(&a, &b, PHKS_SPELLING_CLI, detail, 12);
    ck_assert_str_eq(detail, "operator ra");
    b = a;
    b.scales[14] = 999;
    phks_options_compare(&a, &b, PHKS_SPELLING_CLI, detail, sizeof detail);
    ck_assert_str_eq(detail, "scales[14] 1000 against 999");
    b = a;
    b.boundary_margin = 0.25;
    phks_options_compare(&a, &b, PHKS_SPELLING_CLI, detail, sizeof detail);
    ck_assert_str_eq(detail, "boundary-margin 2 against 0.25");
    /* The local descriptor only between two VERIFIED sets: NEAREST
     * ignores it. */
    b = a;
    b.local_descriptor = PHKS_LOCAL_DESCRIPTOR_HEAT;
    phks_options_compare(&a, &b, PHKS_SPELLING_CLI, detail, sizeof detail);
    ck_assert_str_eq(detail, "local-descriptor spin against heat");
    a.matching = b.matching = PHKS_MATCHING_NEAREST;
    ck_assert_int_eq(phks_options_compare(&a, &b, PHKS_SPELLING_C, NULL, 0),
                     PHKS_OK);
    b.matching = PHKS_MATCHING_VERIFIED;
    phks_options_compare(&a, &b, PHKS_SPELLING_C, detail, sizeof detail);
    ck_assert_str_eq(detail, "matching nearest against verified");
    phks_options_compare(&b, &a, PHKS_SPELLING_C, detail, sizeof detail);
    ck_assert_str_eq(detail, "matching verified against nearest");
    /* So is the global descriptor. */
    phks_options_init(&a);
    b = a;
    b.global_descriptor = PHKS_GLOBAL_DESCRIPTOR_D2;
    phks_options_compare(&a, &b, PHKS_SPELLING_CLI, detail, sizeof detail);
    ck_assert_str_eq(detail, "global-descriptor none against d2");
    a.matching = b.matching = PHKS_MATCHING_NEAREST;
    ck_assert_int_eq(phks_options_compare(&a, &b, PHKS_SPELLING_C, NULL, 0),
                     PHKS_OK);
    ck_assert_int_eq(phks_options_compare(NULL, &b, PHKS_SPELLING_C, NULL, 0),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_options_compare(&a, &b, PHKS_SPELLING_C, NULL, 8),
                     PHKS_ERROR_INVALID_ARGUMENT);
}
END_TEST

int main(void)
{
    Suite *s = suite_create("option_names");
    TCase *c = tcase_create("option_names");
    tcase_add_test(c, tool_words_set_the_fields_the_manual_says);
    tcase_add_test(c, python_words_are_the_fields_names);
    tcase_add_test(c, every_option_reads_back_what_it_writes);
    tcase_add_test(c, types_are_what_the_fields_hold);
    tcase_add_test(c, value_names_by_value);
    tcase_add_test(c, bad_text_is_refused_and_changes_nothing);
    tcase_add_test(c, format_says_when_the_buffer_is_short);
    tcase_add_test(c, compare_names_both_values_in_the_users_words);
    suite_add_tcase(s, c);
    return run_suite(s);
}
