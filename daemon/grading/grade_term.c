/* A record's term (docs/grading.md, "A term"): its submission time judged
 * against its assignment's schedule, its score, whether it is the one of
 * its student's that counts, and the record object answers carry. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "assignment.h"
#include "grading_internal.h"
#include "json_text.h"
#include "rayd/clock.h"
#include "time_text.h"

rd_term grading_term_of(rd_grading *g, const char *assignment)
{
    rd_assignment a;
    rd_error err = {0};
    /* An assignment that no longer loads keeps its records readable: they
     * are judged as if it had no schedule. */
    if (!assignment || !*assignment || rd_assignment_load(g->opt.assignments_dir, assignment, &a, &err))
        return rd_term_default();
    return a.term;
}

rd_term grading_term_fields(rd_grading *g, rd_store_grade *rec, const grading_sub *sub, int pass)
{
    rd_term t = grading_term_of(g, rec->assignment);
    rec->kind = sub->code ? "code" : "image";
    rec->submitted_ms = sub->submitted_ms > 0 ? sub->submitted_ms : rd_wall_ms();
    long long late = 0;
    rd_term_window w = rd_term_when(&t, rec->submitted_ms, &late);
    /* A batch is the instructor's collection of the class's work: its
     * time says when it was graded, not when each student handed it in. */
    if (sub->batch_id && !sub->regrade_of)
        w = RD_TERM_ON_TIME, late = 0;
    rec->late_ms = late;
    rec->closed = w == RD_TERM_CLOSED;
    rd_term_outcome o = {.graded = !rec->error,
                         .pass = pass,
                         .code = sub->code,
                         .failed_fraction = rec->failed_fraction,
                         .share = sub->share,
                         .late_ms = late};
    rec->points = t.points;
    rec->score = rd_term_score(&t, &o);
    return t;
}

const char *rd_grading_window_refusal(rd_grading *g, const char *assignment, char *why, size_t size)
{
    rd_term t = grading_term_of(g, assignment);
    rd_term_window w = rd_term_when(&t, rd_wall_ms(), NULL);
    char at[40];
    if (w == RD_TERM_NOT_RELEASED) {
        rd_time_text(t.release_ms, at, sizeof at);
        snprintf(why, size, "%s opens for submissions at %s", assignment, at);
        return "not_released";
    }
    if (w == RD_TERM_CLOSED) {
        rd_time_text(t.due_ms + llround(t.late_days * (double)RD_TERM_DAY_MS), at, sizeof at);
        snprintf(why, size, "%s closed for submissions at %s (its due time%s)", assignment, at,
                 t.late_days > 0 ? " and late window" : "");
        return "closed";
    }
    return NULL;
}

/* A time as text, or null. */
static cJSON *time_or_null(long long ms)
{
    if (ms < 0)
        return cJSON_CreateNull();
    char at[40];
    rd_time_text(ms, at, sizeof at);
    return cJSON_CreateString(at);
}

static cJSON *number_or_null(double v) { return isfinite(v) ? cJSON_CreateNumber(v) : cJSON_CreateNull(); }

cJSON *grading_record_json(const rd_store_grade *rec, const rd_term *t, int counts)
{
    cJSON *o = cJSON_CreateObject();
    int f = !o;
    rd_json_add(o, "student", cJSON_CreateString(rec->student ? rec->student : ""), &f);
    rd_json_add(o, "assignment", cJSON_CreateString(rec->assignment ? rec->assignment : ""), &f);
    rd_json_add(o, "kind", cJSON_CreateString(rec->kind ? rec->kind : "image"), &f);
    rd_json_add(o, "submitted_at", time_or_null(rec->submitted_ms > 0 ? rec->submitted_ms : rec->graded_ms), &f);
    rd_json_add(o, "due_at", time_or_null(t->due_ms), &f);
    rd_json_add(o, "late", cJSON_CreateBool(rec->late_ms > 0), &f);
    rd_json_add(o, "late_days", cJSON_CreateNumber(rd_term_late_days(rec->late_ms)), &f);
    rd_json_add(o, "closed", cJSON_CreateBool(rec->closed), &f);
    rd_json_add(o, "counts", counts < 0 ? cJSON_CreateNull() : cJSON_CreateBool(counts), &f);
    rd_json_add(o, "score", number_or_null(rec->score), &f);
    rd_json_add(o, "points", number_or_null(rec->points), &f);
    rd_json_add(o, "regrade_of", rec->regrade_of ? cJSON_CreateString(rec->regrade_of) : cJSON_CreateNull(), &f);
    if (f) {
        cJSON_Delete(o);
        return NULL;
    }
    return o;
}

char *grading_with_record(char *verdict, const rd_store_grade *rec, const rd_term *t, int counts)
{
    cJSON *root = cJSON_Parse(verdict);
    cJSON *r = root ? grading_record_json(rec, t, counts) : NULL;
    char *text = NULL;
    if (r) {
        cJSON_DeleteItemFromObject(root, "record");
        if (cJSON_AddItemToObject(root, "record", r))
            text = cJSON_PrintUnformatted(root);
        else
            cJSON_Delete(r);
    }
    cJSON_Delete(root);
    if (!text)
        return verdict;
    free(verdict);
    return text;
}

/* Whether a record of rows was regraded: a newer verdict of the same
 * image stands in its place. */
static int regraded(const rd_store_grade *rows, size_t n, const char *id)
{
    for (size_t i = 0; i < n; i++)
        if (rows[i].regrade_of && strcmp(rows[i].regrade_of, id) == 0)
            return 1;
    return 0;
}

/* The entries of one student's records, for rd_term_pick: one that was
 * regraded, or came after the window, never counts. */
static long pick_of(const rd_store_grade *rows, size_t n, rd_counts_rule rule)
{
    rd_term_entry *e = calloc(n ? n : 1, sizeof *e);
    if (!e)
        return -2;
    for (size_t i = 0; i < n; i++)
        e[i] = (rd_term_entry){rows[i].submitted_ms, isfinite(rows[i].score) ? rows[i].score : 0,
                               rows[i].closed || regraded(rows, n, rows[i].id)};
    long k = rd_term_pick(rule, e, n);
    free(e);
    return k;
}

int grading_counts(rd_grading *g, const rd_store_grade *rec, const rd_term *t)
{
    rd_store_grade_filter f = {
        .assignment = rec->assignment, .student = rec->student ? rec->student : "", .max = 10000};
    rd_store_grade *rows = NULL;
    size_t n = 0;
    rd_error err = {0};
    if (rd_store_grades_list(g->store, &f, &rows, &n, &err))
        return -1;
    long k = pick_of(rows, n, t->counts);
    int counts = k < -1 ? -1 : k >= 0 && strcmp(rows[k].id, rec->id) == 0;
    rd_store_grades_free(rows, n);
    return counts;
}

/* The terms of a listing's assignments, each .grade read once. */
typedef struct {
    const char *name[16];
    rd_term term[16];
    size_t n;
} term_cache;

static rd_term cached_term(rd_grading *g, term_cache *c, const char *assignment)
{
    for (size_t i = 0; i < c->n; i++)
        if (strcmp(c->name[i], assignment) == 0)
            return c->term[i];
    rd_term t = grading_term_of(g, assignment);
    size_t k = c->n < 16 ? c->n++ : 15;
    c->name[k] = assignment;
    c->term[k] = t;
    return t;
}

void grading_mark_counts(rd_grading *g, rd_store_grade *rows, size_t n, int *counts)
{
    term_cache cache = {0};
    /* each run of one student's records of one assignment is picked alone */
    for (size_t i = 0; i < n;) {
        size_t j = i + 1;
        while (j < n && strcmp(rows[j].assignment, rows[i].assignment) == 0 &&
               strcmp(rows[j].student, rows[i].student) == 0)
            j++;
        rd_term t = cached_term(g, &cache, rows[i].assignment);
        long k = pick_of(rows + i, j - i, t.counts);
        for (size_t m = i; m < j; m++)
            counts[m] = k < -1 ? -1 : (long)(m - i) == k;
        i = j;
    }
}
