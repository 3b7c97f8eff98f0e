/* The records as the rows of a table (grade_table.h): a JSON array or CSV,
 * for a batch and for the instructors' listing. */
#include <cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "grade_table.h"
#include "grading_internal.h"
#include "roster.h"
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
    snprintf(row->regrade_of, sizeof row->regrade_of, "%s", g->regrade_of ? g->regrade_of : "");
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

static char *rows_csv(const rd_grade_row *rows, size_t n)
{
    rd_strbuf b = {0};
    rd_grade_csv_header(&b);
    for (size_t i = 0; i < n; i++)
        rd_grade_csv_row(&b, &rows[i]);
    return rd_strbuf_take(&b, NULL);
}

static char *rows_json(const rd_grade_row *rows, size_t n)
{
    cJSON *a = cJSON_CreateArray();
    for (size_t i = 0; a && i < n; i++) {
        cJSON *o = rd_grade_row_json(&rows[i]);
        if (o)
            cJSON_AddItemToArray(a, o);
    }
    char *t = a ? cJSON_PrintUnformatted(a) : NULL;
    cJSON_Delete(a);
    return t;
}

rd_store_grade *grading_sort_rows(rd_store_grade *rows, size_t n)
{
    if (n)
        qsort(rows, n, sizeof *rows, by_student);
    return rows;
}

/* The roster's students without a record of assignment (grades sorted by
 * student), as rows saying so after the k rows made: a table shows who has
 * not handed in. Returns the rows now made. */
static size_t no_submissions(const rd_roster *roster, const char *assignment, const rd_store_grade *grades, size_t n,
                             rd_grade_row *rows, size_t k)
{
    for (size_t i = 0, j = 0; assignment && *assignment && i < roster->n; i++) {
        const char *s = roster->e[i].student;
        while (j < n && strcmp(grades[j].student, s) < 0)
            j++;
        int has = 0;
        for (size_t m = j; m < n && strcmp(grades[m].student, s) == 0; m++)
            has |= strcmp(grades[m].assignment, assignment) == 0;
        if (has || rd_grade_row_error(&rows[k], s, assignment, "no submission", 0, NULL))
            continue;
        rows[k++].on_roster = 1;
    }
    return k;
}

/* By student, then assignment; qsort is not stable, so a record's place
 * among its student's records is its submission order (index) */
typedef struct {
    const rd_grade_row *row;
    size_t index;
} placed;

static int by_row(const void *x, const void *y)
{
    const placed *a = x, *b = y;
    int c = strcmp(a->row->student, b->row->student);
    if (!c)
        c = strcmp(a->row->assignment, b->row->assignment);
    return c ? c : (a->index > b->index) - (a->index < b->index);
}

/* rows in table order (the "no submission" rows among the others). */
static rd_grade_row *in_order(rd_grade_row *rows, size_t n)
{
    placed *p = malloc((n ? n : 1) * sizeof *p);
    rd_grade_row *out = malloc((n ? n : 1) * sizeof *out);
    for (size_t i = 0; p && out && i < n; i++)
        p[i] = (placed){&rows[i], i};
    if (p && out) {
        qsort(p, n, sizeof *p, by_row);
        for (size_t i = 0; i < n; i++)
            out[i] = *p[i].row;
    }
    free(p);
    free(rows);
    if (!p)
        free(out);
    return p ? out : NULL;
}

/* The records as rows, on the roster or not, with the roster's students
 * who have none of assignment's. *made counts them. */
static rd_grade_row *table_rows(rd_grading *g, rd_store_grade *grades, size_t n, const char *assignment, size_t *made)
{
    rd_roster roster = {0};
    rd_error err = {0};
    /* A roster that no longer reads leaves the table as it is without one. */
    if (g->opt.roster && rd_roster_load(g->opt.roster, &roster, &err))
        rd_log_msg(g->opt.log, "warning", "--roster: %s", err.message);
    int *counts = calloc(n ? n : 1, sizeof *counts);
    rd_grade_row *rows = calloc(n + roster.n + 1, sizeof *rows);
    size_t k = 0;
    if (counts && rows) {
        grading_sort_rows(grades, n);
        grading_mark_counts(g, grades, n, counts);
        for (size_t i = 0; i < n; i++)
            if (row_of(&grades[i], counts[i], &rows[k])) {
                rows[k].on_roster = roster.e ? rd_roster_find(&roster, rows[k].student) != NULL : -1;
                k++;
            }
        size_t all = no_submissions(&roster, assignment, grades, n, rows, k);
        if (all > k)
            rows = in_order(rows, all);
        k = all;
    }
    if (!counts) {
        free(rows);
        rows = NULL;
    }
    free(counts);
    rd_roster_free(&roster);
    *made = k;
    return rows;
}

char *grading_rows_text(rd_grading *g, rd_store_grade *grades, size_t n, int csv, const char *assignment)
{
    size_t made = 0;
    rd_grade_row *rows = table_rows(g, grades, n, assignment, &made);
    char *t = !rows ? NULL : csv ? rows_csv(rows, made) : rows_json(rows, made);
    free(rows);
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
    char *t = grading_rows_text(g, rows, n, f->csv, f->assignment);
    rd_store_grades_free(rows, n);
    if (t && !f->csv)
        t = wrapped(t);
    *text = t;
    return t ? RD_OK : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
}

/* ---- the batches ---- */

/* A listing gives 100 batches unless asked for up to 1000: each is a row
 * of the page's list, and a term has a few dozen. */
enum { BATCHES_LISTED = 100, BATCHES_LISTED_MAX = 1000 };

cJSON *grading_batch_json(const rd_store_batch *b)
{
    char at[40];
    rd_time_text(b->created_ms, at, sizeof at);
    cJSON *o = cJSON_CreateObject();
    int ok = o && cJSON_AddStringToObject(o, "id", b->id) && cJSON_AddStringToObject(o, "assignment", b->assignment) &&
             cJSON_AddStringToObject(o, "status", rd_store_batch_status_name(b->status)) &&
             cJSON_AddNumberToObject(o, "total", b->total) && cJSON_AddNumberToObject(o, "done", b->done) &&
             cJSON_AddStringToObject(o, "created_at", at);
    if (ok)
        return o;
    cJSON_Delete(o);
    return NULL;
}

/* limit: 1 to BATCHES_LISTED_MAX in decimal; NULL the default; -1 else. */
static long listed(const char *v)
{
    if (!v)
        return BATCHES_LISTED;
    char *end;
    long n = v[0] >= '0' && v[0] <= '9' ? strtol(v, &end, 10) : -1;
    return n < 1 || n > BATCHES_LISTED_MAX || *end ? -1 : n;
}

static char *batches_text(const rd_store_batch *list, size_t n)
{
    cJSON *root = cJSON_CreateObject();
    cJSON *a = root ? cJSON_AddArrayToObject(root, "batches") : NULL;
    int ok = a != NULL;
    for (size_t i = 0; ok && i < n; i++) {
        cJSON *o = grading_batch_json(&list[i]);
        ok = o && cJSON_AddItemToArray(a, o);
    }
    char *text = ok ? cJSON_PrintUnformatted(root) : NULL;
    cJSON_Delete(root);
    return text;
}

rd_error_code rd_grading_batches_list(rd_grading *g, const rd_grading_batch_filter *f, char **text, rd_error *err)
{
    long long until = since_ms(f->until);
    long max = listed(f->limit);
    if (until < 0)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0,
                            "query parameter until: expected Unix milliseconds or a time as 2026-12-01T09:30:00.123Z");
    if (max < 0)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "query parameter limit: expected a whole number from 1 to %d",
                            BATCHES_LISTED_MAX);
    rd_store_batch_filter sf = {.assignment = f->assignment, .until_ms = until, .max = (size_t)max};
    rd_store_batch *list = NULL;
    size_t n = 0;
    rd_error_code rc = rd_store_batches_list(g->store, &sf, &list, &n, err);
    if (rc)
        return rc;
    *text = batches_text(list, n);
    free(list);
    return *text ? RD_OK : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
}
