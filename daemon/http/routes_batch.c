/* Grading a class (docs/grading.md): POST /v1/grade/batch takes an
 * assignment and the students' images (parts of a form, or one archive,
 * expanded on the render threads), and answers 202 with the batch's id
 * once the grading service has it (grading_service.h); GET
 * /v1/grade/batch/{id} and GET /v1/grades read its records as they land. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "archive.h"
#include "assignment.h"
#include "http_internal.h"
#include "rayd/memory.h"
#include "utf8.h"

typedef rd_grade_batch_image batch_image;

/* A student id: at most what a record holds. */
enum { STUDENT_MAX = sizeof(((batch_image *)0)->student) };

/* The form as it arrives (the request's state). */
typedef struct {
    rd_form form;
    char assignment[80];
    char student[STUDENT_MAX]; /* a `student` field names the image part after it */
    batch_image *images;
    size_t n, cap;
    rd_form_blob archive;
} batch_form;

static void free_images(batch_image *im, size_t n)
{
    for (size_t i = 0; i < n; i++)
        free(im[i].png);
    free(im);
}

static void free_form(rd_req *r)
{
    batch_form *f = r->state;
    if (!f)
        return;
    rd_form_end(&f->form);
    free_images(f->images, f->n);
    rd_form_blob_free(&f->archive);
    free(f);
    r->state = NULL;
}

/* Why the image of a name that was not UTF-8 is an error row: its student
 * is the name shown with rd_utf8_readable. */
static const char NAME_NOT_UTF8[] = "the file name is not UTF-8 (the bytes that are not are shown as %HH): rename "
                                    "the file, or zip it with a tool that writes UTF-8 names, and grade it again";
static const char STUDENT_NOT_UTF8[] =
    "the 'student' field is not UTF-8 (the bytes that are not are shown as %HH): send it as UTF-8";

/* The student of a file: its name without folders and extension, as
 * readable UTF-8 cut at a character boundary (rd_utf8_readable). 1 when
 * the name was UTF-8. */
static int student_of(const char *filename, char *out, size_t size)
{
    const char *base = filename ? filename : "";
    for (const char *p = base; *p; p++)
        if (*p == '/' || *p == '\\')
            base = p + 1;
    size_t n = strlen(base);
    const char *dot = strrchr(base, '.');
    if (dot && dot != base)
        n = (size_t)(dot - base);
    return rd_utf8_readable(base, n, out, size);
}

/* 0 when the batch has its --max-batch-images (the form refused) or out
 * of memory. */
static int add_image(batch_form *f, const rd_server_options *o, const char *student, const char *error)
{
    if (f->n >= o->max_batch_images) {
        rd_form_refuse(&f->form, 413, "the batch has more than %zu images (--max-batch-images)", o->max_batch_images);
        return 0;
    }
    if (!rd_grow_array((void **)&f->images, &f->cap, f->n + 1, sizeof *f->images, 16))
        return 0;
    batch_image *im = &f->images[f->n++];
    memset(im, 0, sizeof *im);
    snprintf(im->student, sizeof im->student, "%s", student);
    im->error = error;
    return 1;
}

/* A new image part's student: the `student` field before it, else its
 * file name; an error when either is not UTF-8. */
static int add_part_image(batch_form *f, const rd_server_options *o, const char *filename)
{
    char student[STUDENT_MAX];
    const char *error = NULL;
    if (f->student[0] && !rd_utf8_readable(f->student, strlen(f->student), student, sizeof student))
        error = STUDENT_NOT_UTF8;
    else if (!f->student[0] && !student_of(filename, student, sizeof student))
        error = NAME_NOT_UTF8;
    f->student[0] = 0;
    return add_image(f, o, student, error);
}

/* An 'image' part's bytes: each part is one more image. */
static enum MHD_Result image_part(rd_req *r, rd_form *form, const char *filename, int starts, const char *data,
                                  size_t size)
{
    batch_form *f = (batch_form *)form;
    const rd_server_options *o = &r->srv->opt;
    if (starts && !add_part_image(f, o, filename))
        return form->refused ? MHD_NO : rd_form_refuse(form, 503, "out of memory");
    batch_image *im = &f->images[f->n - 1];
    return rd_form_take(form, "image", &im->png, &im->len, o->max_body_bytes, "--max-body-bytes", data, size);
}

#define AT(f) offsetof(batch_form, f)
static const rd_form_field fields[] = {
    {"image", RD_FORM_EACH, 0, 0, NULL, image_part},
    {"archive", RD_FORM_FILE, AT(archive), offsetof(rd_server_options, max_batch_bytes), "--max-batch-bytes", NULL},
    RD_FORM_ASSIGNMENT(batch_form),
    RD_FORM_STUDENT(batch_form),
    {NULL, RD_FORM_TEXT, 0, 0, NULL, NULL},
};
#undef AT

/* The instructors' routes: off without --instructor-tokens (404, as if they
 * were not there), 401 without a token, 403 with a wrong one. 0 when the
 * request may go on, else the answer was queued (*ret). */
int rd_require_instructor(rd_req *r, enum MHD_Result *ret)
{
    const char *h = MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_AUTHORIZATION);
    /* Under auth_mu: SIGHUP may replace the tokens meanwhile. */
    pthread_mutex_lock(&r->srv->auth_mu);
    const rd_auth *a = r->srv->auth;
    rd_auth_result res = a ? rd_auth_check(a, h) : RD_AUTH_MISSING;
    pthread_mutex_unlock(&r->srv->auth_mu);
    if (!a) {
        *ret = rd_reply_error(r, 404, "not_found", NULL,
                              "no such route (grade records need the server's --instructor-tokens)");
        return 1;
    }
    if (res == RD_AUTH_OK)
        return 0;
    if (res == RD_AUTH_MISSING)
        *ret = rd_reply_error_hdr(r, 401, "unauthorized", "an instructor's token is needed (Authorization: Bearer)",
                                  "WWW-Authenticate", "Bearer realm=\"rayd\"");
    else
        *ret = rd_reply_error(r, 403, "forbidden", NULL, "that token is not an instructor's");
    return 1;
}

/* The path takes GET (the list) too, which has no form: it is answered
 * once the request is in. */
static int is_post(const rd_req *r) { return strcmp(r->method, "POST") == 0; }

enum MHD_Result rd_route_batch_begin(rd_req *r)
{
    enum MHD_Result ret;
    if (!is_post(r))
        return MHD_YES;
    if (rd_require_instructor(r, &ret))
        return ret;
    const rd_server_options *o = &r->srv->opt;
    rd_form_spec spec = {.size = sizeof(batch_form),
                         .fields = fields,
                         .max_total = o->max_batch_bytes + (1u << 20),
                         .too_large = "--max-batch-bytes and 1 MiB of fields",
                         .files_max = o->max_batch_bytes,
                         .files_flag = "--max-batch-bytes",
                         .hint = "send multipart/form-data with 'assignment' and 'image' files or one 'archive'",
                         .free_state = free_form};
    return rd_form_begin(r, &spec);
}

enum MHD_Result rd_route_batch_data(rd_req *r, const char *data, size_t size)
{
    return rd_form_data(r, data, size, r->srv->opt.max_batch_bytes + (1u << 20));
}

/* An archive's files become the batch's images (folders and names as
 * api/archive reads them); its limits are the batch's. */
typedef struct {
    batch_form *f;
    const rd_server_options *o;
} expand_ctx;

static rd_error_code take_file(void *user, const char *name, int utf8, const unsigned char *data, size_t len,
                               rd_error *err)
{
    expand_ctx *x = user;
    char student[STUDENT_MAX];
    student_of(name, student, sizeof student);
    if (!add_image(x->f, x->o, student, utf8 ? NULL : NAME_NOT_UTF8))
        return x->f->form.refused ? rd_error_set(err, RD_ERR_LIMIT, 0, 0, "more than %zu images (--max-batch-images)",
                                                 x->o->max_batch_images)
                                  : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    batch_image *im = &x->f->images[x->f->n - 1];
    if (!(im->png = malloc(len ? len : 1)))
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    memcpy(im->png, data, len);
    im->len = len;
    return RD_OK;
}

static rd_error_code expand(batch_form *f, const rd_server_options *o, rd_error *err)
{
    if (!f->archive.data)
        return RD_OK;
    rd_archive_limits lim = {o->max_batch_images, o->max_body_bytes, o->max_batch_expanded};
    expand_ctx x = {f, o};
    rd_error_code rc = rd_archive_each(f->archive.data, f->archive.len, &lim, take_file, &x, err);
    rd_form_blob_free(&f->archive);
    /* The reader names its limits by field; the answer names the flag. */
    static const char *const flags[][2] = {{"(max_total_bytes)", "--max-batch-expanded"},
                                           {"(max_entry_bytes)", "--max-body-bytes, an image"},
                                           {"(max_entries)", "--max-batch-images"}};
    for (size_t i = 0; rc == RD_ERR_LIMIT && err && i < 3; i++) {
        char *at = strstr(err->message, flags[i][0]);
        if (at)
            snprintf(at, sizeof err->message - (size_t)(at - err->message), "(%s)", flags[i][1]);
    }
    return rc;
}

/* Two images of one student would make two rows nobody can tell apart. */
static const char *duplicate_student(const batch_form *f)
{
    for (size_t i = 0; i < f->n; i++)
        for (size_t j = i + 1; j < f->n; j++)
            if (strcmp(f->images[i].student, f->images[j].student) == 0)
                return f->images[i].student;
    return NULL;
}

/* 0 when the form holds a batch, else 1 with its answer in *ret. */
static int form_errors(rd_req *r, enum MHD_Result *ret)
{
    if (rd_form_refused(r, ret))
        return 1;
    const batch_form *f = r->state;
    if (!f->assignment[0])
        *ret = rd_reply_error(r, 400, "parse_error", NULL, "the form has no 'assignment'");
    else if (f->archive.parts && f->n)
        *ret = rd_reply_error(r, 400, "parse_error", NULL, "give 'image' files or one 'archive', not both");
    return !f->assignment[0] || (f->archive.parts && f->n);
}

/* The form's images, an archive's expanded or not, become a batch. */
/* 202 with batch id as it stands and its Location. */
static enum MHD_Result batch_accepted(rd_req *r, rd_grading *g, const char *id)
{
    rd_error err = {0};
    char *text = NULL;
    if (rd_grading_batch_text(g, id, RD_BATCH_STATUS, &text, &err))
        return rd_reply_failed(r, &err);
    char loc[32 + RD_STORE_ID_MAX];
    snprintf(loc, sizeof loc, "/v1/grade/batch/%s", id);
    const char *headers[] = {MHD_HTTP_HEADER_LOCATION, loc, NULL};
    return rd_reply_with(r, 202, "application/json", text, strlen(text), 1, headers);
}

static enum MHD_Result start_batch(rd_req *r, batch_form *f)
{
    rd_server *srv = r->srv;
    rd_grading *g = rd_server_grading(srv);
    rd_error err = {0};
    if (!g)
        return rd_reply_starting(r);
    if (f->n == 0)
        return rd_reply_error(r, 400, "parse_error", NULL, "the batch has no image");
    const char *dup = duplicate_student(f);
    if (dup) {
        char msg[STUDENT_MAX + 64];
        snprintf(msg, sizeof msg, "two images of student '%s'", dup);
        return rd_reply_error(r, 400, "parse_error", NULL, msg);
    }
    rd_assignment a;
    if (rd_assignment_load(srv->opt.assignments_dir, f->assignment, &a, &err))
        return rd_reply_answer(r, rd_grade_error_answer(RD_GRADE_STAGE_ASSIGNMENT, err.code), &err);
    rd_grade_batch_image *images = f->images;
    size_t n = f->n;
    f->images = NULL;
    f->n = f->cap = 0;
    char id[RD_STORE_ID_MAX];
    if (rd_grading_batch_start(g, f->assignment, images, n, id, &err))
        return rd_reply_failed(r, &err);
    return batch_accepted(r, g, id);
}

/* An archive is expanded by a job of the render queue, never on the HTTP
 * thread: its preparation may hold --max-batch-expanded (and one image of
 * --max-body-bytes being read), reserved in --memory-budget while it runs,
 * so that concurrent archives are expanded only as the budget allows. The
 * job owns the archive and the images it makes (its own batch_form, of
 * which only those are used), so that a client hanging up frees nothing
 * under it. */
typedef struct {
    rd_server *srv;
    batch_form f;
} expand_task;

static rd_error_code expand_archive(void *arg, rd_scene *s, int *render, rd_error *err)
{
    (void)s;
    expand_task *t = arg;
    *render = 0;
    rd_error_code rc = expand(&t->f, &t->srv->opt, err);
    if (rc) {
        free_images(t->f.images, t->f.n);
        t->f.images = NULL;
        t->f.n = t->f.cap = 0;
    }
    return rc;
}

static void free_expand_task(void *arg)
{
    expand_task *t = arg;
    free_images(t->f.images, t->f.n);
    rd_form_blob_free(&t->f.archive);
    free(t);
}

static enum MHD_Result submit_expansion(rd_req *r, batch_form *f)
{
    const rd_server_options *o = &r->srv->opt;
    rd_jq_submit_options so = {.renders_nothing = 1, .prepare_bytes = o->max_batch_expanded + o->max_body_bytes};
    size_t budget = o->jobs.memory_budget;
    if (budget && so.prepare_bytes > budget) {
        char msg[200];
        snprintf(msg, sizeof msg,
                 "an archive may expand to %zu MiB (--max-batch-expanded and --max-body-bytes), over the limit of "
                 "%zu MiB (--memory-budget)",
                 so.prepare_bytes >> 20, budget >> 20);
        return rd_reply_error(r, 413, "too_large", NULL, msg);
    }
    expand_task *t = calloc(1, sizeof *t);
    if (!t)
        return rd_reply_error(r, 503, "unavailable", NULL, "out of memory");
    t->srv = r->srv;
    t->f.archive = f->archive;
    memset(&f->archive, 0, sizeof f->archive);
    rd_jq_task task = {expand_archive, NULL, free_expand_task, t, t->f.archive.len, NULL};
    return rd_req_submit(r, &task, &so);
}

static enum MHD_Result batches_list(rd_req *r);

enum MHD_Result rd_route_batch_post(rd_req *r, const char *rest)
{
    (void)rest;
    enum MHD_Result ret;
    if (!is_post(r))
        return batches_list(r);
    if (form_errors(r, &ret))
        return ret;
    batch_form *f = r->state;
    if (atomic_load(&r->srv->draining))
        return rd_reply_draining(r);
    return f->archive.data ? submit_expansion(r, f) : start_batch(r, f);
}

enum MHD_Result rd_route_batch_resumed(rd_req *r)
{
    rd_jq_info info;
    rd_jq_info_get(r->srv->jobs, r->job, &info);
    batch_form *f = r->state;
    expand_task *t = rd_jq_task_arg(r->job);
    if (info.status == RD_JQ_DONE) {
        f->images = t->f.images;
        f->n = t->f.n;
        f->cap = t->f.cap;
        t->f.images = NULL;
        t->f.n = t->f.cap = 0;
        return start_batch(r, f);
    }
    if (info.status == RD_JQ_FAILED && info.error.code == RD_ERR_LIMIT)
        return rd_reply_error(r, 413, "too_large", &info.error, NULL);
    if (info.status == RD_JQ_FAILED && info.error.code != RD_ERR_NOMEM)
        return rd_reply_error(r, 400, "parse_error", &info.error, NULL);
    if (info.status == RD_JQ_FAILED)
        return rd_reply_error(r, 503, "unavailable", &info.error, NULL);
    if (info.hung_up)
        return MHD_NO;
    return rd_reply_error_hdr(
        r, 503, "cancelled", "the archive's expansion was cancelled (the server is shutting down)", "Retry-After", "5");
}

/* A table as CSV; with ?excel=1 the UTF-8 byte order mark first, which
 * Excel needs to read UTF-8 (a student 山田太郎) rather than the locale's
 * code page. Takes text over. */
static enum MHD_Result reply_csv(rd_req *r, char *text)
{
    const char *excel = MHD_lookup_connection_value(r->conn, MHD_GET_ARGUMENT_KIND, "excel");
    static const char bom[] = "\xEF\xBB\xBF";
    size_t len = strlen(text);
    if (excel && strcmp(excel, "1") == 0) {
        char *with = malloc(len + sizeof bom);
        if (!with) {
            free(text);
            return rd_reply_error(r, 503, "unavailable", NULL, "out of memory");
        }
        memcpy(with, bom, sizeof bom - 1);
        memcpy(with + sizeof bom - 1, text, len + 1);
        free(text);
        text = with;
        len += sizeof bom - 1;
    }
    return rd_reply(r, 200, "text/csv; charset=utf-8", text, len, 1);
}

/* GET /v1/grade/batch/{id}, .../results.csv, .../results.json */
/* The grading service for an instructor's request; NULL with the answer
 * queued (*ret) when the request may not go on, or the service is not up
 * yet. */
static rd_grading *instructors_grading(rd_req *r, enum MHD_Result *ret)
{
    if (rd_require_instructor(r, ret))
        return NULL;
    rd_grading *g = rd_server_grading(r->srv);
    if (!g)
        *ret = rd_reply_starting(r);
    return g;
}

/* A query the service refused: a bad filter is the query's fault (400),
 * whatever the store calls it; the rest as the error says. */
static enum MHD_Result query_refused(rd_req *r, rd_error_code rc, const rd_error *err)
{
    if (rc == RD_ERR_INVALID || rc == RD_ERR_LIMIT)
        return rd_reply_error(r, 400, "parse_error", err, NULL);
    return rd_reply_failed(r, err);
}

/* The query's value of name. */
static const char *arg(rd_req *r, const char *name)
{
    return MHD_lookup_connection_value(r->conn, MHD_GET_ARGUMENT_KIND, name);
}

/* GET /v1/grade/batch: the batches, newest first. */
static enum MHD_Result batches_list(rd_req *r)
{
    enum MHD_Result ret;
    rd_grading *g = instructors_grading(r, &ret);
    if (!g)
        return ret;
    rd_grading_batch_filter f = {
        .assignment = arg(r, "assignment"), .until = arg(r, "until"), .limit = arg(r, "limit")};
    rd_error err = {0};
    char *text = NULL;
    rd_error_code rc = rd_grading_batches_list(g, &f, &text, &err);
    return rc ? query_refused(r, rc, &err) : rd_reply_json(r, 200, text);
}

/* DELETE /v1/grade/batch/{id}: a running batch cancelled (200, its status),
 * an ended one deleted (204). */
static enum MHD_Result batch_delete(rd_req *r, rd_grading *g, const char *id)
{
    rd_error err = {0};
    char *status = NULL;
    if (rd_grading_batch_delete(g, id, &status, &err))
        return rd_reply_failed(r, &err);
    if (status)
        return rd_reply_json(r, 200, status);
    return rd_reply(r, 204, NULL, (void *)"", 0, 0);
}

/* GET /v1/grade/batch/{id}, .../results.csv, .../results.json; DELETE
 * /v1/grade/batch/{id} */
enum MHD_Result rd_route_batch_get(rd_req *r, const char *path)
{
    enum MHD_Result ret;
    rd_grading *g = instructors_grading(r, &ret);
    if (!g)
        return ret;
    /* An id too long for one is no batch's, as the service says. */
    char id[RD_STORE_ID_MAX] = "";
    const char *p = path + 1, *slash = strchr(p, '/');
    size_t n = slash ? (size_t)(slash - p) : strlen(p);
    if (n < sizeof id) {
        memcpy(id, p, n);
        id[n] = 0;
    }
    const char *what = slash ? slash + 1 : "";
    int form = !*what                              ? RD_BATCH_STATUS
               : strcmp(what, "results.json") == 0 ? RD_BATCH_ROWS_JSON
               : strcmp(what, "results.csv") == 0  ? RD_BATCH_ROWS_CSV
                                                   : -1;
    if (form < 0)
        return rd_reply_error(r, 404, "not_found", NULL, "no such route");
    if (strcmp(r->method, "DELETE") == 0)
        return batch_delete(r, g, id);
    rd_error err = {0};
    char *text = NULL;
    if (rd_grading_batch_text(g, id, (rd_grading_batch_form)form, &text, &err))
        return rd_reply_failed(r, &err);
    if (form == RD_BATCH_ROWS_CSV)
        return reply_csv(r, text);
    return rd_reply_json(r, 200, text);
}

/* GET /v1/grades: the records, for instructors. */
enum MHD_Result rd_route_grades_list(rd_req *r)
{
    enum MHD_Result ret;
    rd_grading *g = instructors_grading(r, &ret);
    if (!g)
        return ret;
    const char *accept = MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_ACCEPT);
    rd_grading_filter f = {.assignment = arg(r, "assignment"),
                           .student = arg(r, "student"),
                           .since = arg(r, "since"),
                           .csv = accept && strstr(accept, "text/csv")};
    rd_error err = {0};
    char *text = NULL;
    rd_error_code rc = rd_grading_list(g, &f, &text, &err);
    if (rc)
        return query_refused(r, rc, &err);
    if (f.csv)
        return reply_csv(r, text);
    return rd_reply_json(r, 200, text);
}

/* GET /v1/gradebook: the scores that count, for an LMS's import. */
enum MHD_Result rd_route_gradebook(rd_req *r, const char *rest)
{
    (void)rest;
    enum MHD_Result ret;
    rd_grading *g = instructors_grading(r, &ret);
    if (!g)
        return ret;
    const char *format = arg(r, "format");
    int canvas = format && strcmp(format, "canvas") == 0;
    if (!format || (!canvas && strcmp(format, "moodle") != 0))
        return rd_reply_error(r, 400, "parse_error", NULL, "query parameter format: expected moodle or canvas");
    rd_error err = {0};
    char *text = NULL;
    rd_error_code rc = rd_grading_gradebook(g, canvas ? RD_GRADEBOOK_CANVAS : RD_GRADEBOOK_MOODLE, &text, &err);
    /* The roster is the server's file, not the request's: as a broken
     * assignment is. */
    if (rc == RD_ERR_SYNTAX || rc == RD_ERR_IO)
        return rd_reply_error(r, 422, "bad_roster", &err, NULL);
    if (rc == RD_ERR_LIMIT)
        return rd_reply_error(r, 413, "too_large", &err, NULL);
    if (rc)
        return rd_reply_failed(r, &err);
    return reply_csv(r, text);
}

/* POST /v1/grade/regrade?assignment=NAME: the assignment's image records
 * graded again against its reference as it is now, as a batch. */
enum MHD_Result rd_route_regrade(rd_req *r, const char *rest)
{
    (void)rest;
    enum MHD_Result ret;
    rd_grading *g = instructors_grading(r, &ret);
    if (!g)
        return ret;
    if (atomic_load(&r->srv->draining))
        return rd_reply_draining(r);
    const char *name = arg(r, "assignment");
    rd_assignment a;
    rd_error err = {0};
    if (!name || !*name)
        return rd_reply_error(r, 400, "parse_error", NULL, "query parameter assignment: the assignment to regrade");
    if (rd_assignment_load(r->srv->opt.assignments_dir, name, &a, &err))
        return rd_reply_answer(r, rd_grade_error_answer(RD_GRADE_STAGE_ASSIGNMENT, err.code), &err);
    char id[RD_STORE_ID_MAX];
    if (rd_grading_regrade(g, a.name, id, &err))
        return rd_reply_failed(r, &err);
    return batch_accepted(r, g, id);
}

/* DELETE /v1/grades?student=NAME: a student's records, for instructors. The
 * student is required: deleting every record is not offered. */
enum MHD_Result rd_route_grades_delete(rd_req *r)
{
    enum MHD_Result ret;
    rd_grading *g = instructors_grading(r, &ret);
    if (!g)
        return ret;
    const char *student = arg(r, "student");
    if (!student || !*student)
        return rd_reply_error(r, 400, "parse_error", NULL, "give the student whose records go: ?student=NAME");
    rd_error err = {0};
    size_t n = 0;
    rd_error_code rc = rd_grading_student_delete(g, student, &n, &err);
    if (rc)
        return query_refused(r, rc, &err);
    char *text = malloc(64);
    if (!text)
        return rd_reply_error(r, 503, "unavailable", NULL, "out of memory");
    snprintf(text, 64, "{\"deleted\":%zu}", n);
    return rd_reply_json(r, 200, text);
}

/* DELETE /v1/grades/{id}: one record, for instructors (its id reads it,
 * but does not delete it). */
enum MHD_Result rd_route_grade_delete(rd_req *r, const char *id)
{
    enum MHD_Result ret;
    rd_grading *g = instructors_grading(r, &ret);
    if (!g)
        return ret;
    rd_error err = {0};
    if (!rd_cap_valid(id, 'g'))
        return rd_reply_error(r, 404, "not_found", NULL, "no such grade");
    if (rd_grading_grade_delete(g, id, &err))
        return rd_reply_failed(r, &err);
    return rd_reply(r, 204, NULL, (void *)"", 0, 0);
}
