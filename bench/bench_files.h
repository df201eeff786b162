/* bench_files.h - what the benchmark programs share: reading a file. */
#ifndef PHKS_BENCH_FILES_H
#define PHKS_BENCH_FILES_H

#include <stddef.h>

/* The whole file at path, malloc'd, its length in *size; NULL when it
 * cannot be read or is empty. */
void *bench_read_file(const char *path, size_t *size);

#endif
