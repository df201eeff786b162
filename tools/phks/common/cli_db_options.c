/*
 * cli_db_options.c - the options of a database for `phks db add | query |
 * info`: those its signatures were made with (its first entry's), which a
 * new signature must share, and the tool's words when one does not.
 */
#include "common/cli_common.h"

/* The options of the database's first entry into *options, and whether it
 * has one. */
static phks_status first_entry_options(phks_db *db, phks_options *options,
                                       int *found)
{
    int64_t first;
    size_t listed = 0;
    phks_signature *sig = NULL;
    phks_status st = phks_db_list(db, 0, &first, 1, &listed);
    if (st == PHKS_OK && listed == 1)
        st = phks_db_get(db, first, &sig, NULL, 0, NULL, 0);
    *found = sig != NULL;
    if (sig)
        phks_signature_options(sig, options);
    phks_signature_free(sig);
    return st;
}

/* theirs with the options given on the command line put over it. */
static phks_options given_over(const phks_options *theirs,
                               const phks_options *command_line)
{
    phks_options given = *theirs;
    char text[512];
    for (uint32_t i = 0; i < 32 && phks_option_name(i, PHKS_SPELLING_CLI);
         i++)
        if ((cli_explicit >> i & 1u) &&
            phks_option_format(command_line, i, PHKS_SPELLING_CLI, text,
                               sizeof text) == PHKS_OK)
            phks_option_set(&given, i, text, PHKS_SPELLING_CLI);
    return given;
}

int cli_db_options(phks_db *db, const char *path, phks_options *options)
{
    phks_options theirs;
    int found;
    phks_status st = first_entry_options(db, &theirs, &found);
    if (st != PHKS_OK)
        return cli_fail(path, st);
    if (!found)
        return 0;
    phks_options given = given_over(&theirs, options);
    char detail[256];
    if (cli_options_differ(&given, &theirs, detail, sizeof detail)) {
        fprintf(stderr, "phks: %s: the options given are not the "
                "database's: %s (drop the option, or use another "
                "database)\n", path, detail);
        return 1;
    }
    uint32_t threads = options->threads;
    *options = theirs;
    options->threads = threads;
    return 0;
}

void cli_say_db_fail(phks_db *db, const char *path, const phks_signature *sig,
                     phks_status status)
{
    /* Taken first: reading the database's options sets another. */
    const char *reason = cli_reason(path, status);
    phks_options mine, theirs;
    int found = 0;
    char detail[256];
    if (status == PHKS_ERROR_INCOMPATIBLE &&
        first_entry_options(db, &theirs, &found) == PHKS_OK && found) {
        phks_signature_options(sig, &mine);
        if (cli_options_differ(&mine, &theirs, detail, sizeof detail))
            reason = detail;
    }
    cli_say(stderr, "phks: %s: %s%s\n", path,
            reason == detail ? "made with other options than the "
                               "database's: " : "", reason);
}
