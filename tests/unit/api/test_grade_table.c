/* A class's table (api/grading/grade_table.h): rows from results and
 * errors, the CSV's header, quoting and formula guard read back by an RFC
 * 4180 reader, numbers that read back to the same double, the JSON row. */
#include <criterion/criterion.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "grade.h"
#include "grade_table.h"
#include "grading.h"
#include "rayd/clock.h"
#include "strbuf.h"
#include "time_text.h"

/* 2024-05-01T09:30:00.123Z */
#define AT_MS 1714555800123LL
#define AT_TEXT "2024-05-01T09:30:00.123Z"
/* The record's ten cells of a row that is no record, each with its comma. */
#define NO_RECORD ",,,,,,,,,,"

static char *csv_of(const rd_grade_row *row)
{
    rd_strbuf b = {0};
    rd_grade_csv_row(&b, row);
    char *t = rd_strbuf_take(&b, NULL);
    cr_assert(t);
    return t;
}

/* Reads one CSV record of text as RFC 4180 says (quoted fields, "" for a
 * quote, CRLF at the end) into at most max malloc'ed fields; the number of
 * fields, or -1 when the text is not one well-formed record. */
static int read_record(const char *text, char **fields, int max)
{
    const char *p = text;
    int n = 0;
    for (;;) {
        if (n == max)
            return -1;
        size_t cap = strlen(text) + 1, len = 0;
        char *f = malloc(cap);
        cr_assert(f);
        if (*p == '"') {
            p++;
            for (;;) {
                if (!*p) {
                    free(f);
                    return -1;
                }
                if (*p == '"' && p[1] == '"') {
                    f[len++] = '"';
                    p += 2;
                } else if (*p == '"') {
                    p++;
                    break;
                } else {
                    f[len++] = *p++;
                }
            }
        } else {
            while (*p && *p != ',' && *p != '\r' && *p != '\n' && *p != '"')
                f[len++] = *p++;
            if (*p == '"' || *p == '\n') {
                free(f);
                return -1;
            }
        }
        f[len] = 0;
        fields[n++] = f;
        if (*p == ',') {
            p++;
            continue;
        }
        return strcmp(p, "\r\n") == 0 ? n : -1;
    }
}

static void free_fields(char **f, int n)
{
    for (int i = 0; i < n; i++)
        free(f[i]);
}

static rd_grade_result known_result(void)
{
    rd_grade_result r;
    memset(&r, 0, sizeof r);
    r.pass = 0;
    r.failed_fraction = 1.0 / 3.0;
    r.max_abs = 57;
    r.psnr_db = 38.2;
    r.ssim = 0.1 + 0.2; /* 0.30000000000000004: 17 digits to read back */
    r.rmse = 0.0123;
    return r;
}

Test(grade_table, header_names_the_columns_in_order)
{
    rd_strbuf b = {0};
    rd_grade_csv_header(&b);
    char *t = rd_strbuf_take(&b, NULL);
    cr_assert_str_eq(t, "student,assignment,pass,failed_fraction,max_abs,psnr_db,ssim,graded_at,grade_id,url,kind,"
                        "counts,submitted_at,late,score,points,on_roster,regrade_of,error\r\n");
    free(t);
}

Test(grade_table, a_row_from_a_known_result)
{
    rd_grade_result r = known_result();
    rd_grade_row row;
    rd_error err = {0};
    cr_assert_eq(rd_grade_row_from_result(&row, "alice", "phong", &r, AT_MS, &err), RD_OK, "%s", err.message);
    cr_assert_not(rd_grade_row_is_error(&row));
    char *t = csv_of(&row);
    cr_assert_str_eq(t,
                     "alice,phong,false,0.3333333333333333,57,38.2,0.30000000000000004," AT_TEXT "," NO_RECORD "\r\n");
    char *f[20];
    int n = read_record(t, f, 20);
    cr_assert_eq(n, 19, "%d fields in %s", n, t);
    /* Every number reads back to the double it was. */
    cr_assert(strtod(f[3], NULL) == r.failed_fraction, "%s", f[3]);
    cr_assert(strtod(f[5], NULL) == r.psnr_db, "%s", f[5]);
    cr_assert(strtod(f[6], NULL) == r.ssim, "%s", f[6]);
    cr_assert_str_eq(f[18], "", "a graded row has no error");
    free_fields(f, n);
    free(t);

    /* A pass, from a finished grade's output: its assignment and result. */
    rd_grade_output o;
    memset(&o, 0, sizeof o);
    snprintf(o.assignment, sizeof o.assignment, "diffuse");
    o.result.pass = 1;
    o.result.psnr_db = 99;
    o.result.ssim = 1;
    cr_assert_eq(rd_grade_row_from_output(&row, "bob", &o, AT_MS, &err), RD_OK);
    t = csv_of(&row);
    cr_assert_str_eq(t, "bob,diffuse,true,0,0,99,1," AT_TEXT "," NO_RECORD "\r\n");
    free(t);

    /* A given scene: no assignment, an empty cell. */
    cr_assert_eq(rd_grade_row_from_result(&row, "carol", NULL, &r, AT_MS, &err), RD_OK);
    t = csv_of(&row);
    cr_assert(strncmp(t, "carol,,false,", 13) == 0, "%s", t);
    free(t);
}

Test(grade_table, an_error_row_has_no_metrics_and_says_why)
{
    rd_grade_row row;
    rd_error err = {0};
    cr_assert_eq(
        rd_grade_row_error(&row, "dave", "phong", "the image is 96x72; the assignment renders 320x240", AT_MS, &err),
        RD_OK);
    cr_assert(rd_grade_row_is_error(&row));
    cr_assert_not(row.pass);
    char *t = csv_of(&row);
    /* Quoted: it holds a ';'. */
    cr_assert_str_eq(t, "dave,phong,false,,,,," AT_TEXT "," NO_RECORD
                        "\"the image is 96x72; the assignment renders 320x240\"\r\n");
    free(t);
    /* No message still makes an error row. */
    cr_assert_eq(rd_grade_row_error(&row, "dave", "phong", "", AT_MS, &err), RD_OK);
    cr_assert(rd_grade_row_is_error(&row));
    cr_assert_str_eq(row.error, "not graded");
}

/* Each student id read back by an RFC 4180 reader is the id, and a cell
 * that needs no quotes has none. */
Test(grade_table, ids_with_commas_quotes_and_newlines_are_quoted)
{
    static const struct {
        const char *id, *cell;
    } cases[] = {
        {"plain_id", "plain_id,"},
        {"smith, john", "\"smith, john\","},
        {"the \"ace\"", "\"the \"\"ace\"\"\","},
        {"two\nlines", "\"two\nlines\","},
        {"cr\rhere", "\"cr\rhere\","},
        {"\"", "\"\"\"\","},
        {"O'Brien", "O'Brien,"},
        {"Zoë", "Zoë,"},
    };
    rd_grade_result r = known_result();
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        rd_grade_row row;
        rd_error err = {0};
        cr_assert_eq(rd_grade_row_from_result(&row, cases[i].id, "phong", &r, AT_MS, &err), RD_OK, "%s", err.message);
        char *t = csv_of(&row);
        cr_assert(strncmp(t, cases[i].cell, strlen(cases[i].cell)) == 0, "'%s' written %s", cases[i].id, t);
        char *f[20];
        int n = read_record(t, f, 20);
        cr_assert_eq(n, 19, "'%s': %d fields in %s", cases[i].id, n, t);
        cr_assert_str_eq(f[0], cases[i].id);
        cr_assert_str_eq(f[1], "phong");
        free_fields(f, n);
        free(t);
    }
}

/* A text cell a spreadsheet would run as a formula starts with a '; the
 * numbers are numbers (a negative SSIM too); the JSON keeps the text. */
Test(grade_table, formulas_are_not_left_to_run)
{
    static const struct {
        const char *id, *read_back;
    } cases[] = {
        {"=HYPERLINK(\"http://x\",\"y\")", "'=HYPERLINK(\"http://x\",\"y\")"},
        {"+1+1", "'+1+1"},
        {"-2+3", "'-2+3"},
        {"@SUM(A1)", "'@SUM(A1)"},
        {"\tcmd", "'\tcmd"},
        {"\r=1", "'\r=1"},
        {"=1,2", "'=1,2"},
        {"a=1", "a=1"},
        {"x-1", "x-1"},
    };
    rd_grade_result r = known_result();
    r.ssim = -0.25;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        rd_grade_row row;
        cr_assert_eq(rd_grade_row_from_result(&row, cases[i].id, "phong", &r, AT_MS, NULL), RD_OK);
        char *t = csv_of(&row);
        char *f[20];
        int n = read_record(t, f, 20);
        cr_assert_eq(n, 19, "'%s': %d fields in %s", cases[i].id, n, t);
        cr_assert_str_eq(f[0], cases[i].read_back, "'%s' written %s", cases[i].id, t);
        cr_assert_str_eq(f[6], "-0.25", "a negative number is written as a number: %s", t);
        free_fields(f, n);
        free(t);
        cJSON *j = rd_grade_row_json(&row);
        cr_assert(j);
        cr_assert_str_eq(cJSON_GetObjectItem(j, "student")->valuestring, cases[i].id, "the JSON changed the id");
        cJSON_Delete(j);
    }
    /* The error cell is guarded too. */
    rd_grade_row row;
    cr_assert_eq(rd_grade_row_error(&row, "eve", "phong", "-rf: cannot open", AT_MS, NULL), RD_OK);
    char *t = csv_of(&row);
    cr_assert(strstr(t, "," AT_TEXT "," NO_RECORD "'-rf: cannot open\r\n"), "%s", t);
    free(t);
}

static int formula_start(const char *s) { return s[0] && strchr("=+-@\t", s[0]) != NULL; }

/* A cell holding ';' is quoted, so that a spreadsheet splitting at ';'
 * (many European locales' CSV) keeps it one cell; and whatever follows a
 * ',' or ';' inside a text cell does not start a formula, for a reader
 * that splits at either without honouring quotes. */
Test(grade_table, semicolons_are_quoted_and_what_follows_a_separator_is_guarded)
{
    static const struct {
        const char *id, *read_back;
    } cases[] = {
        {"semi;=1+1", "semi;'=1+1"},       {"a,=HYPERLINK(\"x\")", "a,'=HYPERLINK(\"x\")"},
        {"x;+1;-2;@A1", "x;'+1;'-2;'@A1"}, {"=1;=2", "'=1;'=2"},
        {"semi;colon", "semi;colon"},
    };
    rd_grade_result r = known_result();
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        rd_grade_row row;
        cr_assert_eq(rd_grade_row_from_result(&row, cases[i].id, "phong", &r, AT_MS, NULL), RD_OK);
        char *t = csv_of(&row);
        cr_assert_eq(t[0], '"', "'%s' is not quoted: %s", cases[i].id, t);
        char *f[20];
        int n = read_record(t, f, 20);
        cr_assert_eq(n, 19, "'%s': %d fields in %s", cases[i].id, n, t);
        cr_assert_str_eq(f[0], cases[i].read_back, "'%s' written %s", cases[i].id, t);
        free_fields(f, n);
        /* Split at both separators, quotes ignored. */
        for (const char *p = t;;) {
            cr_assert(!formula_start(*p == '"' ? p + 1 : p), "'%s': a piece starts a formula: %s", cases[i].id, p);
            size_t k = strcspn(p, ",;");
            if (!p[k])
                break;
            p += k + 1;
        }
        free(t);
    }
}

Test(grade_table, json_row_has_the_csv_keys)
{
    static const char *const keys[] = {
        "student",   "assignment", "pass", "failed_fraction", "max_abs",      "psnr_db", "ssim",  "graded_at",
        "grade_id",  "url",        "kind", "counts",          "submitted_at", "late",    "score", "points",
        "on_roster", "regrade_of", "error"};
    rd_grade_result r = known_result();
    rd_grade_row row;
    cr_assert_eq(rd_grade_row_from_result(&row, "alice", "phong", &r, AT_MS, NULL), RD_OK);
    /* Printed and parsed again: every key, and the numbers the same doubles. */
    cJSON *made = rd_grade_row_json(&row);
    cr_assert(made);
    char *text = cJSON_PrintUnformatted(made);
    cr_assert(text);
    cJSON_Delete(made);
    cJSON *j = cJSON_Parse(text);
    cr_assert(j, "%s", text);
    cr_assert_eq(cJSON_GetArraySize(j), 19, "%s", text);
    for (int i = 0; i < 19; i++)
        cr_assert(cJSON_GetObjectItem(j, keys[i]), "no %s", keys[i]);
    cr_assert_str_eq(cJSON_GetObjectItem(j, "student")->valuestring, "alice");
    cr_assert_str_eq(cJSON_GetObjectItem(j, "assignment")->valuestring, "phong");
    cr_assert(cJSON_IsFalse(cJSON_GetObjectItem(j, "pass")));
    cr_assert(cJSON_GetObjectItem(j, "failed_fraction")->valuedouble == r.failed_fraction, "%s", text);
    cr_assert_eq(cJSON_GetObjectItem(j, "max_abs")->valueint, 57, "%s", text);
    cr_assert(cJSON_GetObjectItem(j, "psnr_db")->valuedouble == r.psnr_db, "%s", text);
    cr_assert(cJSON_GetObjectItem(j, "ssim")->valuedouble == r.ssim, "%s", text);
    cr_assert_str_eq(cJSON_GetObjectItem(j, "graded_at")->valuestring, AT_TEXT);
    cr_assert(cJSON_IsNull(cJSON_GetObjectItem(j, "error")));
    cr_assert(strstr(text, "\"ssim\":0.30000000000000004,"), "%s", text);
    free(text);
    cJSON_Delete(j);

    /* An error row: the metrics null, the error said, a scene's assignment null. */
    cr_assert_eq(rd_grade_row_error(&row, "dave", NULL, "the image is not a PNG file", AT_MS, NULL), RD_OK);
    j = rd_grade_row_json(&row);
    cr_assert(j);
    cr_assert_eq(cJSON_GetArraySize(j), 19);
    cr_assert(cJSON_IsNull(cJSON_GetObjectItem(j, "assignment")));
    cr_assert(cJSON_IsFalse(cJSON_GetObjectItem(j, "pass")));
    for (int i = 3; i < 7; i++)
        cr_assert(cJSON_IsNull(cJSON_GetObjectItem(j, keys[i])), "%s is not null", keys[i]);
    cr_assert_str_eq(cJSON_GetObjectItem(j, "error")->valuestring, "the image is not a PNG file");
    cJSON_Delete(j);
}

Test(grade_table, ids_that_make_no_row_are_refused)
{
    rd_grade_result r = known_result();
    rd_grade_row row;
    rd_error err = {0};
    cr_assert_eq(rd_grade_row_from_result(&row, "", "phong", &r, AT_MS, &err), RD_ERR_INVALID);
    cr_assert_eq(rd_grade_row_from_result(&row, NULL, "phong", &r, AT_MS, &err), RD_ERR_INVALID);
    char longest[RD_GRADE_STUDENT_MAX + 2];
    memset(longest, 'a', sizeof longest - 1);
    longest[RD_GRADE_STUDENT_MAX] = 0;
    cr_assert_eq(rd_grade_row_from_result(&row, longest, "phong", &r, AT_MS, &err), RD_OK, "%s", err.message);
    longest[RD_GRADE_STUDENT_MAX] = 'a';
    longest[RD_GRADE_STUDENT_MAX + 1] = 0;
    cr_assert_eq(rd_grade_row_error(&row, longest, "phong", "x", AT_MS, &err), RD_ERR_INVALID);
    cr_assert(strstr(err.message, "student id"), "%s", err.message);
    cr_assert_eq(rd_grade_row_from_result(&row, "caf\xe9", "phong", &r, AT_MS, &err), RD_ERR_INVALID,
                 "a Latin-1 id is not UTF-8");
    char name[100];
    memset(name, 'n', sizeof name - 1);
    name[sizeof name - 1] = 0;
    cr_assert_eq(rd_grade_row_from_result(&row, "alice", name, &r, AT_MS, &err), RD_ERR_INVALID);
}

Test(grade_table, an_error_message_is_kept_utf8)
{
    rd_grade_row row;
    cr_assert_eq(rd_grade_row_error(&row, "eve", "phong", "/home/caf\xe9/eve.png: cannot open", AT_MS, NULL), RD_OK);
    cr_assert_str_eq(row.error, "/home/caf?/eve.png: cannot open");
    /* Cut to the row's size, never inside a character. */
    char big[2000] = "";
    while (strlen(big) + 2 < sizeof big)
        strcat(big, "\xc3\xa9"); /* é */
    cr_assert_eq(rd_grade_row_error(&row, "eve", "phong", big, AT_MS, NULL), RD_OK);
    size_t n = strlen(row.error);
    cr_assert(n == sizeof row.error - 2, "%zu bytes", n);
    cr_assert_str_eq(row.error + n - 2, "\xc3\xa9");
}

Test(grade_table, graded_at_is_rfc3339_utc)
{
    char buf[40];
    rd_time_text(AT_MS, buf, sizeof buf);
    cr_assert_str_eq(buf, AT_TEXT);
    rd_time_text(0, buf, sizeof buf);
    cr_assert_str_eq(buf, "1970-01-01T00:00:00.000Z");
    rd_time_text(-1, buf, sizeof buf);
    cr_assert_str_eq(buf, "1969-12-31T23:59:59.999Z");
    /* time() may read a coarser clock than clock_gettime: a second either side. */
    long long before = (long long)time(NULL) * 1000, now = rd_wall_ms(), after = (long long)time(NULL) * 1000;
    cr_assert(now >= before - 1000 && now < after + 2000, "%lld ms is not between %lld and %lld", now, before - 1000,
              after + 1999);
}

Test(grade_table, a_record_fills_its_columns)
{
    rd_grade_result r = known_result();
    rd_grade_row row;
    cr_assert_eq(rd_grade_row_from_result(&row, "alice", "phong", &r, AT_MS, NULL), RD_OK);
    snprintf(row.grade_id, sizeof row.grade_id, "g0123");
    snprintf(row.url, sizeof row.url, "/v1/grades/g0123");
    snprintf(row.kind, sizeof row.kind, "code");
    row.counts = 1;
    row.late = 0;
    row.submitted_at_ms = AT_MS - 1000;
    row.score = 7.5;
    row.points = 10;
    char *t = csv_of(&row);
    cr_assert_eq(row.on_roster, -1, "no roster: unknown");
    cr_assert(strstr(t, "," AT_TEXT ",g0123,/v1/grades/g0123,code,true,2024-05-01T09:29:59.123Z,false,7.5,10,,,\r\n"),
              "%s", t);
    free(t);
    cJSON *made = rd_grade_row_json(&row);
    cr_assert(made);
    t = cJSON_PrintUnformatted(made); /* its numbers are raw text until printed */
    cJSON_Delete(made);
    cJSON *j = cJSON_Parse(t);
    free(t);
    cr_assert(j);
    cr_assert_str_eq(cJSON_GetObjectItem(j, "kind")->valuestring, "code");
    cr_assert(cJSON_IsTrue(cJSON_GetObjectItem(j, "counts")));
    cr_assert(cJSON_IsFalse(cJSON_GetObjectItem(j, "late")));
    cr_assert(cJSON_GetObjectItem(j, "score")->valuedouble == 7.5);
    cr_assert_str_eq(cJSON_GetObjectItem(j, "submitted_at")->valuestring, "2024-05-01T09:29:59.123Z");
    cJSON_Delete(j);
}

Test(grade_table, a_student_without_a_submission_has_no_time)
{
    rd_grade_row row;
    cr_assert_eq(rd_grade_row_error(&row, "ann", "phong", "no submission", 0, NULL), RD_OK);
    row.on_roster = 1;
    char *t = csv_of(&row);
    cr_assert_str_eq(t, "ann,phong,false,,,,,,,,,,,,,,true,,no submission\r\n");
    free(t);
    cJSON *j = rd_grade_row_json(&row);
    cr_assert(cJSON_IsNull(cJSON_GetObjectItem(j, "graded_at")));
    cr_assert(cJSON_IsTrue(cJSON_GetObjectItem(j, "on_roster")));
    cJSON_Delete(j);
}
