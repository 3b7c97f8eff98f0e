/* A class's roster (docs/grading.md, "A roster"): a CSV file, RFC 4180,
 * UTF-8 with or without a byte order mark, CRLF or LF, whose first line
 * names its columns: `student` (required: the id the records use, an
 * image's file name without extension) and `name`, `email` (optional), in
 * any order, other columns ignored. Blank lines are skipped. Everything in
 * it is hostile input: bounded (RD_ROSTER_MAX_STUDENTS students, cells of
 * RD_ROSTER_CELL_MAX bytes), and refused with the line and column of the
 * first fault.
 *
 * Ownership: rd_roster_parse and rd_roster_load fill *out, which
 * rd_roster_free frees; on an error *out holds nothing. */
#ifndef RD_ROSTER_H
#define RD_ROSTER_H

#include <stddef.h>

#include "rayd/error.h"

#define RD_ROSTER_MAX_STUDENTS 100000
#define RD_ROSTER_CELL_MAX 255
/* The largest roster file read: 100000 students of three full cells. */
#define RD_ROSTER_MAX_BYTES (100000 * 800)

typedef struct {
    char *student; /* not empty */
    char *name;    /* "" when not given */
    char *email;   /* "" when not given */
} rd_roster_entry;

typedef struct {
    rd_roster_entry *e; /* sorted by student (byte order) */
    size_t n;
} rd_roster;

/* Reads text (len bytes) named source in messages. RD_ERR_SYNTAX with
 * "source:line:column: ..." for a malformed file (no student column, a
 * quote not closed, a cell too long, text that is not UTF-8, an empty or
 * repeated student); RD_ERR_LIMIT past RD_ROSTER_MAX_STUDENTS;
 * RD_ERR_NOMEM. */
rd_error_code rd_roster_parse(const char *text, size_t len, const char *source, rd_roster *out, rd_error *err);

/* Reads the file at path (at most RD_ROSTER_MAX_BYTES): RD_ERR_IO when it
 * cannot be read, else as rd_roster_parse with the path as source. */
rd_error_code rd_roster_load(const char *path, rd_roster *out, rd_error *err);

/* The entry of student, or NULL. */
const rd_roster_entry *rd_roster_find(const rd_roster *r, const char *student);

void rd_roster_free(rd_roster *r);

#endif
