/* A class's grades as a table (grading.md, "Grading a class"): one row per
 * student, written as CSV or as JSON, for `rayd grade` with several images
 * and for the HTTP batch endpoint alike.
 *
 * A row is either graded (error is "") or an error row: the student's
 * image could not be graded (not a PNG, damaged, the wrong size, not
 * readable); pass is then false, the metrics are not given and error says
 * why. Every student has a row.
 *
 * CSV (RFC 4180): the header
 *
 *     student,assignment,pass,failed_fraction,max_abs,psnr_db,ssim,graded_at,
 *     grade_id,url,kind,counts,submitted_at,late,score,points,on_roster,
 *     regrade_of,error
 *
 * (one line) then one line per row, every line ending in CRLF and holding
 * all nineteen cells; error stays the last. pass is true or false;
 * graded_at is RFC 3339 in UTC with milliseconds
 * (2024-05-01T09:30:00.123Z), empty (JSON null) for a row graded at 0 ms:
 * a student of the roster without a submission; error is empty for a graded row,
 * and the four metrics are empty for an error row. A cell holding a comma
 * or a semicolon (the separator of many locales' spreadsheets), a double
 * quote, CR or LF is quoted, its quotes doubled. A text cell (student,
 * assignment, error) that begins with = + - @, a tab or CR gets a ' in
 * front, and so does every such character that follows a ',' or ';' inside
 * it ("semi;=1+1" is written "semi;'=1+1"), so that a spreadsheet, splitting
 * at either separator, shows it instead of running it as a formula; the
 * JSON keeps the text as it is.
 *
 * Numbers read back to the same double: the CSV and the JSON both write
 * the shortest %.Ng, N up to 17, that does (rd_number_text; whole numbers
 * as integers). The JSON's go in as raw text, since cJSON's own printing
 * stops at 15 digits when they compare "close enough". */
#ifndef RD_GRADE_TABLE_H
#define RD_GRADE_TABLE_H

#include <cJSON.h>

#include "grade.h"
#include "grading.h"
#include "rayd/error.h"
#include "strbuf.h"

/* A student id's longest text in bytes: a file name's. */
#define RD_GRADE_STUDENT_MAX 255

typedef struct {
    char student[RD_GRADE_STUDENT_MAX + 1]; /* UTF-8, not empty */
    char assignment[64];                    /* "" for a given scene */
    int pass;
    double failed_fraction;
    int max_abs;
    double psnr_db, ssim;
    long long graded_at_ms; /* Unix time in milliseconds */
    char error[512];        /* "" for a graded row */
    /* A record's (the daemon's tables: docs/grading.md, "A term"). A row
     * that is no record (rayd grade's) leaves them unknown, as the row's
     * making sets them: empty cells, JSON null. */
    char grade_id[40];         /* "" */
    char url[300];             /* the verdict's address; "" */
    char kind[8];              /* "image" or "code"; "" */
    int counts;                /* 1, 0; -1 */
    long long submitted_at_ms; /* 0 */
    int late;                  /* 1, 0; -1 */
    double score, points;      /* NAN */
    int on_roster;             /* 1, 0; -1 (no roster) */
    char regrade_of[40];       /* the record this one regrades; "" */
} rd_grade_row;

/* A graded row of student for assignment ("" or NULL: a given scene) from
 * a comparison's result. RD_ERR_INVALID when student is empty, longer than
 * RD_GRADE_STUDENT_MAX bytes or not UTF-8 (a NUL is not), or assignment is
 * longer than the row holds; the row is then unusable. */
rd_error_code rd_grade_row_from_result(rd_grade_row *row, const char *student, const char *assignment,
                                       const rd_grade_result *r, long long graded_at_ms, rd_error *err);

/* The same from a finished grade (its assignment and result). */
rd_error_code rd_grade_row_from_output(rd_grade_row *row, const char *student, const rd_grade_output *o,
                                       long long graded_at_ms, rd_error *err);

/* An error row: message (cut to what the row holds, bytes that are not
 * UTF-8 written '?'; "" or NULL is "not graded"). Errors as above. */
rd_error_code rd_grade_row_error(rd_grade_row *row, const char *student, const char *assignment, const char *message,
                                 long long graded_at_ms, rd_error *err);

/* Whether row is an error row. */
int rd_grade_row_is_error(const rd_grade_row *row);

/* Appends the CSV header line, and one row's line. */
void rd_grade_csv_header(rd_strbuf *b);
void rd_grade_csv_row(rd_strbuf *b, const rd_grade_row *row);

/* One text cell as the table writes it: quoted when it holds a separator,
 * a quote, CR or LF, and guarded against formulas; for other tables of
 * the same rules (the gradebook). */
void rd_grade_csv_cell(rd_strbuf *b, const char *text);

/* The row as an object with the CSV's keys: student, assignment (null for
 * a given scene), pass, failed_fraction, max_abs, psnr_db, ssim (null in
 * an error row), graded_at (the RFC 3339 text), the record's keys (null
 * when unknown), error (null in a graded row). The caller deletes it; NULL
 * when out of memory. */
cJSON *rd_grade_row_json(const rd_grade_row *row);

#endif
