/* The gradebook (docs/grading.md, "The gradebook"): the score that counts
 * of every student and assignment, as the CSV that Moodle's and Canvas's
 * grade imports read. Their rules, as their importers apply them:
 *
 * Moodle (grade/import/csv): a record a line; the instructor maps one
 * column to a user field (ID number, email address, username) and every
 * line must name a user who exists, or the whole import stops; a column of
 * a new grade item takes its header as the item's name; an empty cell or
 * "-" is no grade, else a number.
 *
 * Canvas (GradebookImporter): the header's first cell holds "Student" and
 * its second "ID"; then "SIS User ID" and "SIS Login ID", and the last
 * student column "Section"; every later column is an assignment, matched
 * by "Title (id)" or by its title, else created; a line whose first cell
 * holds "Points Possible" gives the assignments' points; a student is
 * found by ID, then SIS User ID or SIS Login ID, then by name; an empty
 * cell or "-" is no score. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "assignment.h"
#include "grade_table.h"
#include "grading_internal.h"
#include "number_text.h"
#include "roster.h"
#include "strbuf.h"

enum { BOOK_RECORDS = 10000 };

/* The gradebook's students: the roster's, else each student with a record
 * (sorted, once). */
typedef struct {
    const char **student;
    const rd_roster_entry **entry; /* NULL: not on the roster */
    size_t n;
} book_rows;

/* A score as a gradebook shows it: two decimals at most, as Canvas
 * compares them, a point for the decimal separator. */
static void score_cell(rd_strbuf *b, double score)
{
    if (!isfinite(score))
        return;
    char t[40];
    rd_number_text(round(score * 100) / 100, t, sizeof t);
    rd_strbuf_printf(b, "%s", t);
}

static rd_error_code students_of(const rd_roster *roster, const rd_store_grade *rows, size_t n, book_rows *out)
{
    size_t cap = roster->n ? roster->n : n;
    out->student = calloc(cap ? cap : 1, sizeof *out->student);
    out->entry = calloc(cap ? cap : 1, sizeof *out->entry);
    out->n = 0;
    if (!out->student || !out->entry)
        return RD_ERR_NOMEM;
    for (size_t i = 0; i < roster->n; i++, out->n++) {
        out->student[i] = roster->e[i].student;
        out->entry[i] = &roster->e[i];
    }
    /* rows are sorted by student: each new one once */
    for (size_t i = 0; !roster->n && i < n; i++)
        if (rows[i].student[0] && (!out->n || strcmp(out->student[out->n - 1], rows[i].student) != 0))
            out->student[out->n++] = rows[i].student;
    return RD_OK;
}

static void header(rd_strbuf *b, rd_gradebook_format f, const rd_assignment *a, size_t na)
{
    rd_strbuf_printf(b, "%s",
                     f == RD_GRADEBOOK_CANVAS ? "Student,ID,SIS User ID,SIS Login ID,Section"
                                              : "ID number,Email address,Full name");
    for (size_t k = 0; k < na; k++) {
        rd_strbuf_printf(b, ",");
        rd_grade_csv_cell(b, a[k].name);
    }
    rd_strbuf_printf(b, "\r\n");
    if (f != RD_GRADEBOOK_CANVAS)
        return;
    rd_strbuf_printf(b, "Points Possible,,,,");
    for (size_t k = 0; k < na; k++) {
        rd_strbuf_printf(b, ",");
        score_cell(b, a[k].term.points);
    }
    rd_strbuf_printf(b, "\r\n");
}

/* The student's identity cells, each followed by its comma. */
static void identity(rd_strbuf *b, rd_gradebook_format f, const char *student, const rd_roster_entry *e)
{
    const char *name = e && e->name[0] ? e->name : student, *email = e ? e->email : "";
    if (f == RD_GRADEBOOK_CANVAS) {
        /* Canvas's own ID is unknown here: it finds the student by SIS ids */
        rd_grade_csv_cell(b, name);
        rd_strbuf_printf(b, ",,");
        rd_grade_csv_cell(b, student);
        rd_strbuf_printf(b, ",");
        rd_grade_csv_cell(b, email[0] ? email : student);
        rd_strbuf_printf(b, ",,");
        return;
    }
    rd_grade_csv_cell(b, student);
    rd_strbuf_printf(b, ",");
    rd_grade_csv_cell(b, email);
    rd_strbuf_printf(b, ",");
    rd_grade_csv_cell(b, name);
    rd_strbuf_printf(b, ",");
}

/* The score that counts of student in assignment, or NAN. */
static double counted(const rd_store_grade *rows, const int *counts, size_t n, const char *student,
                      const char *assignment)
{
    for (size_t i = 0; i < n; i++)
        if (counts[i] == 1 && strcmp(rows[i].student, student) == 0 && strcmp(rows[i].assignment, assignment) == 0)
            return rows[i].score;
    return NAN;
}

static char *book_text(rd_gradebook_format f, const rd_assignment *a, size_t na, const book_rows *who,
                       const rd_store_grade *rows, const int *counts, size_t n)
{
    rd_strbuf b = {0};
    header(&b, f, a, na);
    for (size_t i = 0; i < who->n; i++) {
        identity(&b, f, who->student[i], who->entry[i]);
        for (size_t k = 0; k < na; k++) {
            if (k)
                rd_strbuf_printf(&b, ",");
            score_cell(&b, counted(rows, counts, n, who->student[i], a[k].name));
        }
        rd_strbuf_printf(&b, "\r\n");
    }
    return rd_strbuf_take(&b, NULL);
}

/* The assignments that load, in name order; the others are left out. */
static size_t loaded(rd_assignment *a, size_t n)
{
    size_t k = 0;
    for (size_t i = 0; i < n; i++)
        if (!a[i].error[0])
            a[k++] = a[i];
    return k;
}

rd_error_code rd_grading_gradebook(rd_grading *g, rd_gradebook_format f, char **csv, rd_error *err)
{
    *csv = NULL;
    rd_roster roster = {0};
    if (g->opt.roster && rd_roster_load(g->opt.roster, &roster, err))
        return err->code;
    rd_assignment *a = NULL;
    size_t na = 0;
    rd_store_grade_filter sf = {.max = BOOK_RECORDS + 1};
    rd_store_grade *rows = NULL;
    size_t n = 0;
    int *counts = NULL;
    book_rows who = {0};
    rd_error_code rc = rd_assignment_list(g->opt.assignments_dir, &a, &na, err);
    if (!rc)
        rc = rd_store_grades_list(g->store, &sf, &rows, &n, err);
    if (!rc && n > BOOK_RECORDS)
        rc = rd_error_set(err, RD_ERR_LIMIT, 0, 0, "more than %d records: the gradebook holds at most that many",
                          BOOK_RECORDS);
    if (!rc &&
        (!(counts = calloc(n ? n : 1, sizeof *counts)) || students_of(&roster, grading_sort_rows(rows, n), n, &who)))
        rc = rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    if (!rc) {
        grading_mark_counts(g, rows, n, counts);
        *csv = book_text(f, a, loaded(a, na), &who, rows, counts, n);
        if (!*csv)
            rc = rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    }
    free(who.student);
    free(who.entry);
    free(counts);
    rd_store_grades_free(rows, n);
    free(a);
    rd_roster_free(&roster);
    return rc;
}
