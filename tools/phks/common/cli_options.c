/*
 * cli_options.c - the options in the `phks` tool's words: names and values
 * as its users type them ("--hks-scaling local-area"), read from the
 * library's one table of option names (phks_option_*, PHKS_SPELLING_CLI),
 * so that the tool spells nothing of its own and no message of it shows
 * the C spelling (hks_scaling, local_area).
 */
#include "common/cli_common.h"

#include <string.h>

const char *cli_value_name(const char *option, int32_t value)
{
    uint32_t index;
    const char *name = NULL;
    if (phks_option_find(option, PHKS_SPELLING_CLI, &index) == PHKS_OK)
        name = phks_option_value_name(index, value, PHKS_SPELLING_CLI);
    /* Options the library validated always have a name; the fallback
     * keeps a corrupt value from reaching printf as NULL. */
    return name ? name : "unknown";
}

void cli_print_options(FILE *out, const char *prefix, const phks_options *o)
{
    /* NEAREST ignores the descriptors: not shown there. */
    char descriptors[96] = "";
    if (o->matching == PHKS_MATCHING_VERIFIED)
        snprintf(descriptors, sizeof descriptors,
                 ", local descriptor %s, global descriptor %s",
                 cli_value_name("local-descriptor", o->local_descriptor),
                 cli_value_name("global-descriptor", o->global_descriptor));
    fprintf(out, "%soperator %s, box %s, tau %g, cutoff %g, eigenpairs %u, "
            "features %u at %g tau, %u scales (%g..%g tau), boundary margin "
            "%g, HKS scaling %s, quadrature %s, matching %s%s, HKS-simp "
            "above %u vertices (target %u)\n",
            prefix, cli_value_name("operator", o->operator_kind),
            cli_value_name("box", o->box),
            o->tau, o->cutoff, o->eigen_count, o->feature_count,
            o->feature_scale, o->scale_count, o->scales[0],
            o->scales[o->scale_count ? o->scale_count - 1 : 0],
            o->boundary_margin,
            cli_value_name("hks-scaling", o->hks_scaling),
            cli_value_name("quadrature", o->quadrature),
            cli_value_name("matching", o->matching), descriptors,
            o->simplify_above, o->simplify_target);
}

int cli_options_differ(const phks_options *a, const phks_options *b,
                       char *detail, size_t size)
{
    char words[256];
    if (phks_options_compare(a, b, PHKS_SPELLING_CLI, words, sizeof words) ==
        PHKS_OK)
        return 0;
    /* "hks-scaling none against local-area": the tool's option is
     * "--hks-scaling". */
    snprintf(detail, size, "--%s", words);
    return 1;
}

/* Option names stand in the library's messages between spaces,
 * parentheses and punctuation; a file name that holds one ("a/local_area.off")
 * is not touched. */
static int starts_word(const char *msg, const char *at)
{
    return at == msg || strchr(" (", at[-1]) != NULL;
}

static int ends_word(char c)
{
    return c == '\0' || strchr(" ),:;[", c) != NULL;
}

/* Replaces every whole word `from` in msg by `to` (as long or shorter:
 * the C and tool spellings differ by '_' against '-' and operator_kind
 * against operator). */
static void replace_word(char *msg, const char *from, const char *to)
{
    size_t n = strlen(from), m = strlen(to);
    for (char *at = strstr(msg, from); at; at = strstr(at, from)) {
        if (!starts_word(msg, at) || !ends_word(at[n])) {
            at += n;
            continue;
        }
        memmove(at + m, at + n, strlen(at + n) + 1);
        memcpy(at, to, m);
        at += m;
    }
}

static void reword_pair(char *msg, const char *c, const char *cli)
{
    if (strcmp(c, cli) != 0 && strlen(cli) <= strlen(c))
        replace_word(msg, c, cli);
}

void cli_options_reword(char *msg)
{
    const char *name;
    for (uint32_t i = 0; (name = phks_option_name(i, PHKS_SPELLING_C)); i++) {
        reword_pair(msg, name, phks_option_name(i, PHKS_SPELLING_CLI));
        const char *value;
        for (int32_t v = 0;
             (value = phks_option_value_name(i, v, PHKS_SPELLING_C)); v++)
            reword_pair(msg, value,
                        phks_option_value_name(i, v, PHKS_SPELLING_CLI));
    }
}
