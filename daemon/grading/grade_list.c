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

/* A listing gives at most this many records, oldest first from `since`:
 * a longer history is read in pages by moving since on. */
enum { GRADES_LISTED = 10000 };

/* A record as a table row. 0 when it cannot be one. */
static int row_of(const rd_store_grade *g, rd_grade_row *row)
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
    return rc == RD_OK;
}

static cJSON *row_json(const rd_store_grade *g)
{
    rd_grade_row row;
    cJSON *o = row_of(g, &row) ? rd_grade_row_json(&row) : NULL;
    if (o)
        cJSON_AddStringToObject(o, "grade_id", g->id);
    return o;
}

static void row_csv(rd_strbuf *b, const rd_store_grade *g)
{
    rd_grade_row row;
    if (row_of(g, &row))
        rd_grade_csv_row(b, &row);
}

char *grading_rows_text(const rd_store_grade *grades, size_t n, int csv)
{
    if (csv) {
        rd_strbuf b = {0};
        rd_grade_csv_header(&b);
        for (size_t i = 0; i < n; i++)
            row_csv(&b, &grades[i]);
        return rd_strbuf_take(&b, NULL);
    }
    cJSON *a = cJSON_CreateArray();
    for (size_t i = 0; a && i < n; i++) {
        cJSON *o = row_json(&grades[i]);
        if (o)
            cJSON_AddItemToArray(a, o);
    }
    char *t = a ? cJSON_PrintUnformatted(a) : NULL;
    cJSON_Delete(a);
    return t;
}

/* Days from 1970-01-01 to y-m-d (proleptic Gregorian; Hinnant's
 * days_from_civil), so no time zone is involved. */
static long long days_from_civil(long long y, unsigned m, unsigned d)
{
    y -= m <= 2;
    long long era = (y >= 0 ? y : y - 399) / 400;
    unsigned yoe = (unsigned)(y - era * 400);
    unsigned doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
    unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    return era * 146097 + (long long)doe - 719468;
}

/* ".123" (1 to 3 digits) at *p as milliseconds, *p moved past it; -1 when
 * it is not that. The times the answers give (rd_grade_time_text) have
 * them, and a page of batches begins at one. */
static int millis(const char **p)
{
    const char *q = *p + 1;
    int ms = 0, digits = 0;
    for (; digits < 3 && *q >= '0' && *q <= '9'; q++, digits++)
        ms = ms * 10 + (*q - '0');
    if (digits == 0)
        return -1;
    for (int k = digits; k < 3; k++)
        ms *= 10;
    *p = q;
    return ms;
}

/* since: Unix milliseconds, or a UTC date as 2026-12-01,
 * 2026-12-01T09:30:00Z or 2026-12-01T09:30:00.123Z. -1 when it is
 * neither. */
static long long since_ms(const char *v)
{
    if (!v || !*v)
        return 0;
    char *end;
    long long ms = strtoll(v, &end, 10);
    if (!*end && ms >= 0)
        return ms;
    int y, mo, d, h = 0, mi = 0, sec = 0, n = 0;
    if (sscanf(v, "%4d-%2d-%2d%n", &y, &mo, &d, &n) != 3 || n != 10)
        return -1;
    const char *p = v + n;
    int frac = 0;
    if (*p == 'T') {
        int k = 0;
        if (sscanf(p, "T%2d:%2d:%2d%n", &h, &mi, &sec, &k) != 3 || k != 9)
            return -1;
        p += k;
        if (*p == '.' && (frac = millis(&p)) < 0)
            return -1;
        if (*p == 'Z')
            p++;
    }
    if (*p || mo < 1 || mo > 12 || d < 1 || d > 31 || h > 23 || mi > 59 || sec > 60 || y < 1970)
        return -1;
    return ((days_from_civil(y, (unsigned)mo, (unsigned)d) * 24 + h) * 60 + mi) * 60000LL + sec * 1000LL + frac;
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
    char *t = grading_rows_text(rows, n, f->csv);
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
    rd_grade_time_text(b->created_ms, at, sizeof at);
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
