#include "grade_table.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "number_text.h"
#include "time_text.h"
#include "utf8.h"

static rd_error_code start_row(rd_grade_row *row, const char *student, const char *assignment, long long graded_at_ms,
                               rd_error *err)
{
    memset(row, 0, sizeof *row);
    size_t n = student ? strlen(student) : 0;
    if (n == 0 || n > RD_GRADE_STUDENT_MAX)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "a student id is 1 to %d bytes, not %zu", RD_GRADE_STUDENT_MAX,
                            n);
    if (rd_utf8_invalid_at(student, n) != n)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "a student id is UTF-8 text");
    if (!assignment)
        assignment = "";
    if (strlen(assignment) >= sizeof row->assignment)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "an assignment's name is at most %zu bytes",
                            sizeof row->assignment - 1);
    memcpy(row->student, student, n + 1);
    snprintf(row->assignment, sizeof row->assignment, "%s", assignment);
    row->graded_at_ms = graded_at_ms;
    row->counts = row->late = row->on_roster = -1;
    row->score = row->points = NAN;
    return RD_OK;
}

rd_error_code rd_grade_row_from_result(rd_grade_row *row, const char *student, const char *assignment,
                                       const rd_grade_result *r, long long graded_at_ms, rd_error *err)
{
    rd_error_code rc = start_row(row, student, assignment, graded_at_ms, err);
    if (rc)
        return rc;
    row->pass = r->pass != 0;
    row->failed_fraction = r->failed_fraction;
    row->max_abs = r->max_abs;
    row->psnr_db = r->psnr_db;
    row->ssim = r->ssim;
    return RD_OK;
}

rd_error_code rd_grade_row_from_output(rd_grade_row *row, const char *student, const rd_grade_output *o,
                                       long long graded_at_ms, rd_error *err)
{
    return rd_grade_row_from_result(row, student, o->assignment, &o->result, graded_at_ms, err);
}

rd_error_code rd_grade_row_error(rd_grade_row *row, const char *student, const char *assignment, const char *message,
                                 long long graded_at_ms, rd_error *err)
{
    rd_error_code rc = start_row(row, student, assignment, graded_at_ms, err);
    if (rc)
        return rc;
    if (!message || !*message)
        message = "not graded";
    /* Whole characters only: a cut or a bad byte never leaves half of one. */
    size_t len = strlen(message), out = 0, room = sizeof row->error - 1;
    while (len > 0 && out < room) {
        size_t ok = rd_utf8_invalid_at(message, len);
        size_t take = rd_utf8_prefix(message, ok < room - out ? ok : room - out, (size_t)-1);
        memcpy(row->error + out, message, take);
        out += take;
        if (take < ok || ok == len || out == room)
            break;
        row->error[out++] = '?';
        message += ok + 1;
        len -= ok + 1;
    }
    row->error[out] = 0;
    row->pass = 0;
    row->failed_fraction = row->psnr_db = row->ssim = NAN;
    row->max_abs = -1;
    return RD_OK;
}

int rd_grade_row_is_error(const rd_grade_row *row) { return row->error[0] != 0; }

/* 1 when a spreadsheet would run text starting at s as a formula. */
static int formula_at(const char *s) { return s[0] && strchr("=+-@\t\r", s[0]) != NULL; }

/* One cell: quoted when it holds a separator (',' or the ';' of many
 * locales' spreadsheets), a quote, CR or LF. In a text cell, a ' goes in
 * front of the cell, and after each ',' or ';', where what follows would
 * start a formula: a reader that splits at either separator, honouring the
 * quotes or not, never sees a cell that runs. */
static void cell(rd_strbuf *b, const char *s, int text)
{
    int quote = strpbrk(s, ",;\"\r\n") != NULL;
    rd_strbuf_printf(b, "%s%s", quote ? "\"" : "", text && formula_at(s) ? "'" : "");
    for (const char *p = s; *p;) {
        size_t n = strcspn(p, "\",;");
        rd_strbuf_printf(b, "%.*s", (int)n, p);
        p += n;
        if (!*p)
            break;
        rd_strbuf_printf(b, "%s", *p == '"' ? "\"\"" : *p == ',' ? "," : ";");
        if (text && *p != '"' && formula_at(p + 1))
            rd_strbuf_printf(b, "'");
        p++;
    }
    if (quote)
        rd_strbuf_printf(b, "\"");
}

void rd_grade_csv_cell(rd_strbuf *b, const char *text) { cell(b, text, 1); }

static void number_cell(rd_strbuf *b, double v)
{
    if (!isfinite(v))
        return;
    char buf[40];
    rd_number_text(v, buf, sizeof buf);
    rd_strbuf_printf(b, "%s", buf);
}

void rd_grade_csv_header(rd_strbuf *b)
{
    rd_strbuf_printf(b, "student,assignment,pass,failed_fraction,max_abs,psnr_db,ssim,graded_at,grade_id,url,kind,"
                        "counts,submitted_at,late,score,points,on_roster,regrade_of,error\r\n");
}

static const char *tristate(int v) { return v < 0 ? "" : v ? "true" : "false"; }

/* grade_id to points, each followed by its comma. */
static void record_cells(rd_strbuf *b, const rd_grade_row *row)
{
    char at[40] = "";
    if (row->submitted_at_ms > 0)
        rd_time_text(row->submitted_at_ms, at, sizeof at);
    cell(b, row->grade_id, 1);
    rd_strbuf_printf(b, ",");
    cell(b, row->url, 1);
    rd_strbuf_printf(b, ",%s,%s,%s,%s,", row->kind, tristate(row->counts), at, tristate(row->late));
    number_cell(b, row->score);
    rd_strbuf_printf(b, ",");
    number_cell(b, row->points);
    rd_strbuf_printf(b, ",%s,", tristate(row->on_roster));
    cell(b, row->regrade_of, 1);
    rd_strbuf_printf(b, ",");
}

void rd_grade_csv_row(rd_strbuf *b, const rd_grade_row *row)
{
    int error = rd_grade_row_is_error(row);
    char at[40] = "";
    if (row->graded_at_ms)
        rd_time_text(row->graded_at_ms, at, sizeof at);
    cell(b, row->student, 1);
    rd_strbuf_printf(b, ",");
    cell(b, row->assignment, 1);
    rd_strbuf_printf(b, ",%s,", row->pass && !error ? "true" : "false");
    if (!error) {
        number_cell(b, row->failed_fraction);
        rd_strbuf_printf(b, ",%d,", row->max_abs);
        number_cell(b, row->psnr_db);
        rd_strbuf_printf(b, ",");
        number_cell(b, row->ssim);
    } else {
        rd_strbuf_printf(b, ",,,");
    }
    rd_strbuf_printf(b, ",%s,", at);
    record_cells(b, row);
    cell(b, row->error, 1);
    rd_strbuf_printf(b, "\r\n");
}

/* A number as raw text that reads back to the same double (cJSON's own
 * printing keeps 15 digits when they compare "close enough"); null when
 * it is not finite. */
static int add_number(cJSON *o, const char *key, double v)
{
    if (!isfinite(v))
        return cJSON_AddNullToObject(o, key) != NULL;
    char t[40];
    rd_number_text(v, t, sizeof t);
    return cJSON_AddRawToObject(o, key, t) != NULL;
}

static int text_or_null(cJSON *o, const char *key, const char *text)
{
    return (*text ? cJSON_AddStringToObject(o, key, text) : cJSON_AddNullToObject(o, key)) != NULL;
}

static int bool_or_null(cJSON *o, const char *key, int v)
{
    return (v < 0 ? cJSON_AddNullToObject(o, key) : cJSON_AddBoolToObject(o, key, v)) != NULL;
}

/* The record's keys of the row. */
static int record_json(cJSON *o, const rd_grade_row *row)
{
    char at[40] = "";
    if (row->submitted_at_ms > 0)
        rd_time_text(row->submitted_at_ms, at, sizeof at);
    return text_or_null(o, "grade_id", row->grade_id) && text_or_null(o, "url", row->url) &&
           text_or_null(o, "kind", row->kind) && bool_or_null(o, "counts", row->counts) &&
           text_or_null(o, "submitted_at", at) && bool_or_null(o, "late", row->late) &&
           add_number(o, "score", row->score) && add_number(o, "points", row->points) &&
           bool_or_null(o, "on_roster", row->on_roster) && text_or_null(o, "regrade_of", row->regrade_of);
}

cJSON *rd_grade_row_json(const rd_grade_row *row)
{
    int error = rd_grade_row_is_error(row);
    char at[40] = "";
    if (row->graded_at_ms)
        rd_time_text(row->graded_at_ms, at, sizeof at);
    cJSON *o = cJSON_CreateObject();
    int ok = o && cJSON_AddStringToObject(o, "student", row->student);
    ok = ok && (row->assignment[0] ? cJSON_AddStringToObject(o, "assignment", row->assignment)
                                   : cJSON_AddNullToObject(o, "assignment"));
    ok = ok && cJSON_AddBoolToObject(o, "pass", row->pass && !error);
    if (error) {
        ok = ok && cJSON_AddNullToObject(o, "failed_fraction") && cJSON_AddNullToObject(o, "max_abs") &&
             cJSON_AddNullToObject(o, "psnr_db") && cJSON_AddNullToObject(o, "ssim");
    } else {
        ok = ok && add_number(o, "failed_fraction", row->failed_fraction) && add_number(o, "max_abs", row->max_abs) &&
             add_number(o, "psnr_db", row->psnr_db) && add_number(o, "ssim", row->ssim);
    }
    ok = ok && text_or_null(o, "graded_at", at) && record_json(o, row);
    ok = ok && (error ? cJSON_AddStringToObject(o, "error", row->error) : cJSON_AddNullToObject(o, "error"));
    if (!ok) {
        cJSON_Delete(o);
        return NULL;
    }
    return o;
}
