/*
 * phks.c - the `phks` command-line tool: signatures, matching,
 * segmentation, shape databases and the paper's retrieval benchmark, over
 * the public API. docs/cli.md is its manual.
 *
 *   phks [global options] COMMAND ARGS...  (global options anywhere)
 */
#include "cli.h"
#include "common/cli_common.h"

#include <stdlib.h>
#include <string.h>

static const char usage_text[] =
    "usage: phks [global options] COMMAND ...\n"
    "global options (anywhere on the line):\n"
    "  --operator literal|random-walk      heat operator (random-walk)\n"
    "  --boundary-margin X                 0..100 (2)\n"
    "  --hks-scaling none|mean|local-area  (local-area)\n"
    "  --quadrature triangles|vertices     where the operator samples the\n"
    "                                      surface (triangles)\n"
    "  --matching verified|nearest         how signatures are scored: verified\n"
    "                                      correspondences, or the paper's\n"
    "                                      nearest vectors (verified)\n"
    "  --local-descriptor spin|heat        what proposes the correspondences\n"
    "                                      verified matching checks: spin\n"
    "                                      images beside the HKS vectors, or\n"
    "                                      the vectors alone, as 0.2.0 (spin;\n"
    "                                      ignored with --matching nearest)\n"
    "  --global-descriptor none|d2         a term of the whole shape in the\n"
    "                                      verified score: none, or the\n"
    "                                      shape distribution D2 (none;\n"
    "                                      ignored with --matching nearest)\n"
    "  --threads N                         0 = one per CPU (0)\n"
    "  --object NAME                       read only this OBJ object or group,\n"
    "                                      or glTF/FBX/... node or mesh\n"
    "                                      (all, merged)\n"
    "  --progress | --no-progress          progress on stderr (when stderr is\n"
    "                                      a terminal)\n"
    "commands (`phks COMMAND --help` tells more):\n"
    "  phks signature MESH|SIG [-o SIG] [--json]\n"
    "  phks match A B [--json]              (meshes or .sig files)\n"
    "  phks segment MESH -o OUT.ply [--regions N (15)] [--time T (5)]\n"
    "               [--ascii] [--json]\n"
    "  phks render MESH [MESH_B] -o OUT.png [--size WxH (480x360)]\n"
    "              [--regions N (15)] [--time T (5)]\n"
    "              [--pairs verified|all|none (verified)]\n"
    "              [--view AZ,EL (30,20)] [--up x|y|z|-x|-y|-z] [--json]\n"
    "  phks db add DB FILES|DIRS... [--label L] [-j N (CPUs)]\n"
    "              [--allow-duplicates]\n"
    "  phks db add DB --manifest TSV [-j N (CPUs)] [--allow-duplicates]\n"
    "  phks db query DB MESH|SIG [-k K (10)] [--json] [--png OUT.png]\n"
    "  phks db list DB [--json]\n"
    "  phks db info DB [--json]\n"
    "  phks db remove DB ID...\n"
    "  phks bench MANIFEST [--prefix P (psb/)] [--classes A,B (all)]\n"
    "             [--max-per-class M (all)] [--seeds N (1)] [--cache DIR]\n"
    "             [--queries-out TSV] [-j N (CPUs)] [--json]\n"
    "             [--no-source] [--one-character A,B (none)]\n"
    "             [--feature-function hks|agd|gc (hks)]\n"
    "             [--descriptor hks|evd (hks)] [--group NAME=A,B (none)]\n"
    "  phks bench --db LIST --queries LIST [--cache DIR] [-j N (CPUs)] [--json]\n"
    "  phks bench --leave-one-out LIST [--cache DIR] [-j N (CPUs)] [--json]\n"
    "  phks --version | --help\n";

/* The global options with a value: --object, and options of the library's
 * table after "--" (phks_option_find). */
static const char *const globals[] = {"--operator", "--threads",
                                      "--boundary-margin", "--hks-scaling",
                                      "--quadrature", "--matching",
                                      "--local-descriptor",
                                      "--global-descriptor", "--object"};

/* Global options without a value. */
static int take_flag(const char *arg)
{
    if (strcmp(arg, "--progress") == 0)
        cli_progress_mode = 1;
    else if (strcmp(arg, "--no-progress") == 0)
        cli_progress_mode = 0;
    else
        return 0;
    return 1;
}

static int is_global(const char *arg)
{
    for (size_t i = 0; i < sizeof globals / sizeof globals[0]; i++)
        if (strcmp(arg, globals[i]) == 0)
            return 1;
    return 0;
}

/* The library's table also takes an enum's number ("--hks-scaling 2");
 * the tool has always taken the names only. */
static int is_enum_number(uint32_t index, const char *text)
{
    return phks_option_value_name(index, 0, PHKS_SPELLING_CLI) && *text &&
           strspn(text, "0123456789") == strlen(text);
}

/* "'2' is not one of none, mean, local-area", as phks_option_set says it
 * of other text. */
static int not_a_value(const char *name, uint32_t index, const char *text)
{
    char names[256] = "";
    const char *value;
    for (int32_t v = 0;
         (value = phks_option_value_name(index, v, PHKS_SPELLING_CLI)); v++)
        snprintf(names + strlen(names), sizeof names - strlen(names), "%s%s",
                 v ? ", " : "", value);
    fprintf(stderr, "phks: %s: '%s' is not one of %s\n", name, text, names);
    return -1;
}

/* Sets global option `name` to v from the library's table of options (or
 * --object); 0, or -1 after a message saying what is wrong. */
static int set_global(const char *name, const char *v, phks_options *o)
{
    if (!v) {
        fprintf(stderr, "phks: option %s needs a value\n", name);
        return -1;
    }
    if (strcmp(name, "--object") == 0) {
        if (!*v) {
            cli_error(name, "the name is empty");
            return -1;
        }
        cli_object = v;
        return 0;
    }
    uint32_t index;
    phks_status st = phks_option_find(name + 2, PHKS_SPELLING_CLI, &index);
    if (st == PHKS_OK && is_enum_number(index, v))
        return not_a_value(name, index, v);
    if (st == PHKS_OK)
        st = phks_option_set(o, index, v, PHKS_SPELLING_CLI);
    if (st != PHKS_OK) {
        cli_error(name, cli_reason(name + 2, st));
        return -1;
    }
    cli_explicit |= 1u << index;
    return 0;
}

/* Takes the global options out of argv, wherever they are (up to "--"),
 * into o. Returns the new argc, or -1 after a message. */
static int take_globals(int argc, char **argv, phks_options *o)
{
    int n = 1;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--") == 0) {
            while (i < argc)
                argv[n++] = argv[i++];
            break;
        }
        if (take_flag(argv[i]))
            continue;
        if (!is_global(argv[i])) {
            argv[n++] = argv[i];
            continue;
        }
        if (set_global(argv[i], i + 1 < argc ? argv[i + 1] : NULL, o) != 0)
            return -1;
        i++;
    }
    argv[n] = NULL;
    return n;
}

int main(int argc, char **argv)
{
    phks_options o;
    phks_options_init(&o);
    argc = take_globals(argc, argv, &o);
    if (argc < 0) {
        fputs(usage_text, stderr);
        return 2;
    }
    const char *cmd = argc > 1 ? argv[1] : "";
    if (strcmp(cmd, "--help") == 0 || strcmp(cmd, "-h") == 0) {
        fputs(usage_text, stdout);
        return 0;
    }
    if (strcmp(cmd, "--version") == 0) {
        printf("phks (libphks %s)\n", phks_version_string());
        return 0;
    }
    static const struct {
        const char *name;
        int (*run)(int, char **, const phks_options *);
    } commands[] = {
        {"signature", cli_signature}, {"match", cli_match},
        {"segment", cli_segment},     {"db", cli_db},
        {"bench", cli_bench},
        {"render", cli_render},
    };
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (strcmp(cmd, commands[i].name) == 0)
            return commands[i].run(argc - 1, argv + 1, &o);
    if (*cmd)
        fprintf(stderr, "phks: unknown command %s\n", cmd);
    fputs(usage_text, stderr);
    return 2;
}
