/* The records as the rows of a table (grade_table.h): a JSON array or CSV,
 * for a batch and for the instructors' listing. */
#include <cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "grade_table.h"
#include "grading_internal.h"
#include "strbuf.h"
#include "time_text.h"

/* A listing gives at most this many records, oldest first from `since`:
 * a longer history is read in pages by moving since on. */
enum { GRADES_LISTED = 10000 };

/* The record's own columns of its row (grade_table.h). */
static void record_columns(const rd_store_grade *g, int counts, rd_grade_row *row)
{
    snprintf(row->grade_id, sizeof row->grade_id, "%s", g->id);
    snprintf(row->url, sizeof row->url, "/v1/grades/%s", g->id);
    snprintf(row->kind, sizeof row->kind, "%s", g->kind ? g->kind : "image");
    row->counts = counts;
    row->submitted_at_ms = g->submitted_ms > 0 ? g->submitted_ms : g->graded_ms;
    row->late = g->late_ms > 0;
    row->score = g->score;
    row->points = g->points;
}

/* A record as a table row. 0 when it cannot be one. */
static int row_of(const rd_store_grade *g, int counts, rd_grade_row *row)
{
    rd_error err = {0};
    /* A grade sent without a student still has a row. */
    const char *student = g->student && *g->student ? g->student : "(unnamed)";
    rd_grade_result res = {0};
    res.pass = g->pass;
    res.failed_fraction = g->failed_fraction;
    /* An error row's metrics read back as NAN (store.h). */
    res.max_abs = isfinite(g->max_abs) ? (int)g->max_abs : 0;
    res.psnr_db = g->psnr_db;
    res.ssim = g->ssim;
    rd_error_code rc = g->error ? rd_grade_row_error(row, student, g->assignment, g->error, g->graded_ms, &err)
                                : rd_grade_row_from_result(row, student, g->assignment, &res, g->graded_ms, &err);
    if (rc == RD_OK)
        record_columns(g, counts, row);
    return rc == RD_OK;
}

/* By student, then assignment, then submission: one student's rows
 * together, as a gradebook reads them, and each student's submissions of
 * an assignment in a run (grading_mark_counts). */
static int by_student(const void *x, const void *y)
{
    const rd_store_grade *a = x, *b = y;
    int c = strcmp(a->student ? a->student : "", b->student ? b->student : "");
    if (!c)
        c = strcmp(a->assignment, b->assignment);
    if (!c)
        c = (a->submitted_ms > b->submitted_ms) - (a->submitted_ms < b->submitted_ms);
    return c ? c : strcmp(a->id, b->id);
}

static char *rows_csv(const rd_store_grade *grades, size_t n, const int *counts)
{
    rd_strbuf b = {0};
    rd_grade_csv_header(&b);
    rd_grade_row row;
    for (size_t i = 0; i < n; i++)
        if (row_of(&grades[i], counts[i], &row))
            rd_grade_csv_row(&b, &row);
    return rd_strbuf_take(&b, NULL);
}

static char *rows_json(const rd_store_grade *grades, size_t n, const int *counts)
{
    cJSON *a = cJSON_CreateArray();
    rd_grade_row row;
    for (size_t i = 0; a && i < n; i++) {
        cJSON *o = row_of(&grades[i], counts[i], &row) ? rd_grade_row_json(&row) : NULL;
        if (o)
            cJSON_AddItemToArray(a, o);
    }
    char *t = a ? cJSON_PrintUnformatted(a) : NULL;
    cJSON_Delete(a);
    return t;
}

char *grading_rows_text(rd_grading *g, rd_store_grade *grades, size_t n, int csv)
{
    int *counts = calloc(n ? n : 1, sizeof *counts);
    if (!counts)
        return NULL;
    qsort(grades, n, sizeof *grades, by_student);
    grading_mark_counts(g, grades, n, counts);
    char *t = csv ? rows_csv(grades, n, counts) : rows_json(grades, n, counts);
    free(counts);
    return t;
}

/* since: Unix milliseconds, or a UTC time (time_text.h). -1 when it is
 * neither. */
static long long since_ms(const char *v)
{
    if (!v || !*v)
        return 0;
    char *end;
    long long ms = strtoll(v, &end, 10);
    if (!*end && ms >= 0)
        return ms;
    return rd_time_parse(v);
}

/* {"grades": rows}, the rows as written: cJSON would print their numbers
 * again, with fewer digits than grade_table.h gives. */
static char *wrapped(char *rows)
{
    size_t len = strlen(rows) + 16;
    char *text = malloc(len);
    if (text)
        snprintf(text, len, "{\"grades\":%s}", rows);
    free(rows);
    return text;
}

rd_error_code rd_grading_list(rd_grading *g, const rd_grading_filter *f, char **text, rd_error *err)
{
    long long from = since_ms(f->since);
    if (from < 0)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0,
                            "query parameter since: expected Unix milliseconds or a date as 2026-12-01T09:30:00Z");
    rd_store_grade_filter sf = {
        .assignment = f->assignment, .student = f->student, .since_ms = from, .max = GRADES_LISTED};
    rd_store_grade *rows = NULL;
    size_t n = 0;
    rd_error_code rc = rd_store_grades_list(g->store, &sf, &rows, &n, err);
    if (rc)
        return rc;
    char *t = grading_rows_text(g, rows, n, f->csv);
    rd_store_grades_free(rows, n);
    if (t && !f->csv)
        t = wrapped(t);
    *text = t;
    return t ? RD_OK : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
}
