/*
 * cli_common.h - the utilities shared by the commands of the `phks` tool
 * and their helpers (common/): errors and usage, argument parsing, files
 * and signatures, JSON, manifests, the worker pool and progress, hashing.
 * The tool uses the public API only (phks.h) plus the example generators.
 * These files call nothing of the commands, render/ or bench/.
 */
#ifndef PHKS_CLI_COMMON_H
#define PHKS_CLI_COMMON_H

#include "phks.h"

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

/* ---- global settings (cli_util.c), set by phks.c from the global options */
/* --progress (1), --no-progress (0), or neither (-1: when stderr is a
 * terminal). */
extern int cli_progress_mode;
/* --object NAME: the OBJ object or group to read, or NULL for all. */
extern const char *cli_object;
/* The options of the library's table given on the command line: bit
 * 1u << i for option i (phks_option_name). */
extern unsigned cli_explicit;

/* ---- errors and usage (cli_util.c) -------------------------------------- */
/* The calling thread's last error message (without a leading "what: "),
 * or the status string when the library left no message. */
const char *cli_reason(const char *what, phks_status status);
/* Prints "phks: what: <last error message>" (or the status string when the
 * library left no message) and returns 1. */
int cli_fail(const char *what, phks_status status);
/* Prints "phks: what: reason" and returns 1. */
int cli_error(const char *what, const char *reason);
/* Prints "phks: path:line: " and the formatted reason, and returns 1. */
int cli_error_at(const char *path, int line, const char *format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
/* Prints "usage: phks <line>" and returns 2. */
int cli_usage(const char *line);
/* When argv[1..argc) holds -h or --help (before "--"), prints
 * "usage: phks <text>" on stdout and returns 1; else 0. */
int cli_help(int argc, char **argv, const char *text);

/* ---- argument parsing (cli_util.c) ------------------------------------- */
typedef struct cli_opt {
    const char *name;   /* "-o", "--json"                                */
    const char **value; /* set to the next argument; NULL for a flag     */
    int *flag;          /* set to 1 when the flag is present             */
} cli_opt;

/* Sorts argv[first..argc) into options (from opts) and positional
 * arguments, which are moved to the front of argv + first; *npos gets their
 * number. "--" ends the options. Returns 0, or -1 after printing what is
 * wrong (unknown option, missing value). */
int cli_parse(int argc, char **argv, int first, const cli_opt *opts,
              size_t nopts, int *npos);
/* Strict unsigned decimal in [min, max]; 0 or -1 (prints nothing). */
int cli_parse_count(const char *text, unsigned long min, unsigned long max,
                    unsigned long *out);
/* The same for the value of `option`; on failure prints "phks: OPTION:
 * 'TEXT' is not a whole number from MIN to MAX" (the caller then prints
 * the usage) and returns -1. */
int cli_option_count(const char *option, const char *text, unsigned long min,
                     unsigned long max, unsigned long *out);
/* An HKS time in units of tau, above 0 and at most 1e9, for `option`
 * (render's and segment's --time); on failure prints why and returns
 * -1. */
int cli_option_time(const char *option, const char *text, double *out);

/* ---- files (cli_util.c) ------------------------------------------------ */
/* The whole file into a new buffer (free it); 0, or -1 with errno set. */
int cli_read_file(const char *path, unsigned char **data, size_t *size);
/* Writes path atomically: a temporary file beside it, then rename.
 * 0, or -1 with errno set. */
int cli_write_file_atomic(const char *path, const void *data, size_t size);
/* Online CPUs, at least 1. */
unsigned cli_cpu_count(void);
/* 1 when path ends in suffix, in any case (".PNG" is ".png"). */
int cli_has_suffix(const char *path, const char *suffix);
/* A monotonic clock in seconds, for wall times. */
double cli_seconds(void);

/* ---- meshes (cli_mesh.c) ------------------------------------------------ */
/* phks_mesh_load, honouring --object for OBJ files and noting on stderr
 * when an OBJ's several objects are merged; other formats through assimp.
 * Thread-safe: on failure the message is printed ("phks: path: reason")
 * and 1 returned. */
int cli_load_mesh(const char *path, phks_mesh **mesh);

/* ---- signatures of files (cli_signature_file.c) ------------------------- */
/* The encoded blob of sig into a new buffer (free it). */
phks_status cli_encode(const phks_signature *sig, unsigned char **blob,
                       size_t *size);
/* 1 when the file starts with the blob magic "PHKS". */
int cli_is_blob(const char *path);
/* A signature from a mesh file, or from a .sig blob (recognised by the
 * magic "PHKS"). Prints "phks: path: reason" and returns NULL on failure. */
phks_signature *cli_signature_of(const char *path, const phks_options *options);
/* Same, and the mesh into *mesh (NULL for a blob; free it), so that vertex
 * ids can be given in the file's numbering (cli_file_vertex). With
 * `verbose`, prints the mesh's counts on stdout first. Reports the stages
 * when progress is on. */
phks_signature *cli_signature_mesh(const char *path,
                                   const phks_options *options,
                                   phks_mesh **mesh, int verbose);
/* The file's id of the cleaned mesh's vertex v (v itself without a mesh). */
uint32_t cli_file_vertex(const phks_mesh *mesh, uint32_t v);

/* ---- options in the tool's words (cli_options.c) ------------------------ */
/* The name of value of the option named `option` in the tool's words:
 * cli_value_name("hks-scaling", 2) is "local-area". */
const char *cli_value_name(const char *option, int32_t value);
/* Prints the options that shape the numbers, one line, with a prefix. */
void cli_print_options(FILE *out, const char *prefix, const phks_options *o);
/* 0 when signatures made with a and b are comparable; else 1, with the
 * first option that differs and both values in the tool's words,
 * "--hks-scaling none against local-area", in detail. */
int cli_options_differ(const phks_options *a, const phks_options *b,
                       char *detail, size_t size);
/* Puts the tool's words in place of the C names of options and values in
 * a library message ("boundary_margin" is "boundary-margin"). */
void cli_options_reword(char *msg);

/* ---- JSON on stdout (cli_json.c) ------------------------------------------ */
/* A string: quotes, backslashes and control characters escaped, bytes that
 * are not UTF-8 replaced by U+FFFD. */
void cli_json_string(const char *s);
/* A number that reads back exactly; null for infinities and NaN. */
void cli_json_number(double x);
/* [x, y, z] */
void cli_json_vec(const double *v, size_t n);
/* The options that shape signatures, as an object. */
void cli_json_options(const phks_options *o);

/* ---- a database's options (cli_db_options.c) ---------------------------- */
/* The options the signatures of a non-empty database were made with, into
 * *options (its threads kept): the only ones a new signature can be added
 * or queried with. An empty database leaves *options alone. A shaping
 * global option given on the command line that differs from the
 * database's is an error naming it. 0, or 1 after "phks: path: reason". */
int cli_db_options(phks_db *db, const char *path, phks_options *options);
/* cli_say_fail of adding or querying the signature of file path: when the
 * status is PHKS_ERROR_INCOMPATIBLE, the option that differs from the
 * database's, in the tool's words. Thread-safe. */
void cli_say_db_fail(phks_db *db, const char *path, const phks_signature *sig,
                     phks_status status);

/* ---- manifests (cli_manifest.c) ----------------------------------------- */
typedef struct cli_row {
    char *file;   /* the file column as written                       */
    char *path;   /* file joined to the manifest's directory          */
    char *cls;    /* the class column                                 */
    char *name;   /* the name column; the file when absent or empty   */
    char *kind;   /* the kind column as written; NULL: absent or empty */
    char *source; /* the source column; NULL: absent or empty         */
    int line;     /* the row's line in the manifest, from 1           */
} cli_row;

/* Reads a TSV with a header line naming at least the columns "file" and
 * "class", and optionally "name", "kind" and "source" (any order; other
 * columns ignored). Prints "phks: path: reason" (a row's or the header's
 * fault as "phks: path:line: reason") and returns -1 on failure. */
int cli_manifest_read(const char *path, cli_row **rows, size_t *count);
void cli_manifest_free(cli_row *rows, size_t count);

/* ---- work pool, output lock and progress bar (cli_pool.c) --------------- */
typedef void (*cli_task_fn)(void *ctx, size_t index);
/* Runs task(ctx, i) for i = 0..count-1 on `workers` threads, handing out
 * indices in order. Returns when all are done. */
void cli_pool_run(size_t count, unsigned workers, cli_task_fn task, void *ctx);
/* Workers that each run one signature at a time are best served by
 * single-threaded BLAS: OpenBLAS's own threads would only compete with
 * them (measured: twice the CPU time for the same work). Sets OpenBLAS,
 * when the process has it, to one thread unless OPENBLAS_NUM_THREADS or
 * OMP_NUM_THREADS says otherwise. */
void cli_blas_one_thread(void);
/* Is progress to be shown (--progress, or a terminal unless --no-progress)? */
int cli_progress_enabled(void);
/* Stage reports of one computation ("phks: WHAT: eigen-decomposition 40%"):
 * cli_stages_attach sets o->progress when progress is on; cli_stages_note
 * reports a stage of the tool's own; cli_stages_end ends the line. On a
 * terminal one updating line; otherwise one line per stage. */
typedef struct cli_stages {
    const char *what;
    int stage, percent, on;
} cli_stages;
void cli_stages_attach(cli_stages *s, const char *what, phks_options *o);
void cli_stages_note(cli_stages *s, const char *stage);
void cli_stages_end(cli_stages *s);
/* Starts a progress bar on stderr when progress is on: on a terminal
 * "[=====>    ] 12/380 unit", updated in place; else a line per item. */
void cli_progress_start(size_t total, const char *unit);
/* One more item done; thread-safe. */
void cli_progress_step(void);
/* Ends the bar (a newline when one was drawn). */
void cli_progress_end(void);
/* printf to `out` from any thread without tearing the progress bar. */
void cli_say(FILE *out, const char *format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
/* cli_fail from any thread: "phks: what: reason" on stderr. */
void cli_say_fail(const char *what, phks_status status);

/* ---- hashing (cli_hash.c) ------------------------------------------------ */
/* splitmix64's finaliser: a bijective 64-bit mix. */
uint64_t cli_mix64(uint64_t x);
/* h = mix64(h ^ byte) for every byte. */
uint64_t cli_hash_bytes(uint64_t h, const void *data, size_t size);
/* h = mix64(h ^ word) for one 64-bit word. */
uint64_t cli_hash_u64(uint64_t h, uint64_t word);
uint64_t cli_hash_double(uint64_t h, double value);
/* The string's bytes, then its length. */
uint64_t cli_hash_string(uint64_t h, const char *text);

#endif
