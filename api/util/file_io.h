/* Whole files in and out, and path pieces: the only file access of api/
 * (the readers themselves take bytes, never paths). */
#ifndef RD_FILE_IO_H
#define RD_FILE_IO_H

#include <stddef.h>

#include "rayd/error.h"

/* Reads a whole regular file into a malloc'ed, NUL-terminated buffer of at
 * most max_bytes (refused before reading; the message names flag); the
 * caller frees *out. A FIFO or device is refused without blocking. On error
 * *out is NULL. */
rd_error_code rd_read_file(const char *path, size_t max_bytes, const char *flag, char **out, size_t *len,
                           rd_error *err);

/* The same, a file of 16 MiB or more read in pieces on up to `threads`
 * threads at once (a mesh of a million triangles is a 100 MB file). */
rd_error_code rd_read_file_threads(const char *path, size_t max_bytes, const char *flag, int threads, char **out,
                                   size_t *len, rd_error *err);

/* Writes bytes to path, replacing it only once the whole file is written
 * (through a temporary file in the same folder, renamed at the end). A
 * path that is neither a regular file nor a folder (/dev/null, a FIFO, a
 * terminal) is written directly: renaming over it would replace it. */
rd_error_code rd_write_file(const char *path, const void *data, size_t len, rd_error *err);

/* Whether rd_write_file could write path now: not a folder, and its
 * temporary file can be created (and is removed again), so a missing
 * folder or a missing permission is found before the work that makes the
 * bytes. RD_ERR_IO with a message naming path. */
rd_error_code rd_check_writable(const char *path, rd_error *err);

/* 1 when path exists and is neither a regular file nor a folder. */
int rd_is_special_file(const char *path);

/* The folder part of a path ("scenes" for "scenes/a.cfg", "." for "a.cfg"),
 * malloc'ed; the caller frees it. NULL when out of memory. */
char *rd_dirname(const char *path);

/* Whether s ends with suffix. */
int rd_ends_with(const char *s, const char *suffix);

#endif
