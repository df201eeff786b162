/*
 * cli.h - the commands of the `phks` command-line tool, one file each at
 * the top of tools/phks/ (phks.c dispatches to them). Their helpers are in
 * folders: common/ (errors, arguments, files, JSON, options in the tool's
 * words, workers), render/ (pictures), bench/ (the benchmark's parts).
 *
 * Conventions: commands return the exit status (0 success, 1 failure, 2
 * usage error). Failures print "phks: FILE: reason" on stderr; usage errors
 * print a usage line. Output meant for people or scripts goes to stdout.
 */
#ifndef PHKS_CLI_H
#define PHKS_CLI_H

#include "phks.h"

/* argv[0] is the command's name; options holds the global options. */
int cli_signature(int argc, char **argv, const phks_options *options);  /* cli_sig.c */
int cli_match(int argc, char **argv, const phks_options *options);      /* cli_sig.c */
int cli_segment(int argc, char **argv, const phks_options *options);
int cli_render(int argc, char **argv, const phks_options *options);
int cli_db(int argc, char **argv, const phks_options *options);
int cli_db_add(int argc, char **argv, const phks_options *options);
int cli_bench(int argc, char **argv, const phks_options *options);

#endif
