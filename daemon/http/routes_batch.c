/* Grading a class (docs/grading.md): POST /v1/grade/batch takes an
 * assignment and the students' images (parts of a form, or one archive),
 * answers 202 with the batch's id and grades them on the render threads:
 * the first image's task renders the reference (once: it is cached) and
 * then hands the rest out in slices, one a render thread. Every grade is a
 * record in the store; GET /v1/grade/batch/{id} reads them as they land. */
#include <cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "archive.h"
#include "assignment.h"
#include "grade_table.h"
#include "http_internal.h"
#include "rayd/clock.h"
#include "rayd/memory.h"
#include "utf8.h"

typedef rd_grade_batch_image batch_image;

/* A listing gives at most this many records, oldest first from `since`:
 * a longer history is read in pages by moving since on. */
enum { GRADES_LISTED = 10000 };

/* A student id: at most what a record holds. */
enum { STUDENT_MAX = sizeof(((batch_image *)0)->student) };

/* The form as it arrives (the request's state). */
typedef struct {
    rd_form form;
    char assignment[80];
    char student[STUDENT_MAX]; /* a `student` field names the image part after it */
    batch_image *images;
    size_t n, cap;
    unsigned char *archive;
    size_t archive_len;
    int archives; /* archive parts seen */
    size_t bytes; /* of every file part */
    /* libmicrohttpd may start a part with an empty call at offset 0 and
     * then give its first bytes at offset 0 again (a part that begins at
     * the end of a buffer): the file name of the part such a call started,
     * which the next call at offset 0 goes on; empty_start 0 when the last
     * call was another. */
    int empty_start;
    char empty_name[STUDENT_MAX];
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
    free(f->archive);
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

static int add_image(batch_form *f, const rd_server_options *o, const char *student, const char *error)
{
    if (f->n >= o->max_batch_images) {
        f->form.too_big = "--max-batch-images";
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

/* A file part's bytes; a new part starts at offset 0. */
static enum MHD_Result file_part(rd_req *r, batch_form *f, int archive, const char *filename, const char *data,
                                 uint64_t off, size_t size)
{
    const rd_server_options *o = &r->srv->opt;
    const char *name = filename ? filename : "";
    int again = off == 0 && size > 0 && f->empty_start && strncmp(f->empty_name, name, sizeof f->empty_name) == 0;
    f->empty_start = off == 0 && size == 0;
    if (f->empty_start)
        snprintf(f->empty_name, sizeof f->empty_name, "%s", name);
    if (off == 0 && !archive && !again && !add_part_image(f, o, filename))
        return MHD_NO;
    if (off == 0 && archive && !again && ++f->archives > 1) {
        f->form.bad = "give one 'archive' part";
        return MHD_NO;
    }
    f->bytes += size;
    if (f->bytes > o->max_batch_bytes) {
        f->form.too_big = "--max-batch-bytes";
        return MHD_NO;
    }
    if (archive)
        return rd_form_append(&f->archive, &f->archive_len, data, size) ? MHD_YES : MHD_NO;
    batch_image *im = &f->images[f->n - 1];
    if (im->len + size > o->max_body_bytes) {
        f->form.too_big = "--max-body-bytes (an image)";
        return MHD_NO;
    }
    return rd_form_append(&im->png, &im->len, data, size) ? MHD_YES : MHD_NO;
}

static enum MHD_Result on_field(void *cls, enum MHD_ValueKind kind, const char *key, const char *filename,
                                const char *content_type, const char *encoding, const char *data, uint64_t off,
                                size_t size)
{
    (void)kind, (void)content_type, (void)encoding;
    rd_req *r = cls;
    batch_form *f = r->state;
    if (!key) {
        f->form.bad = "a form part has no field name (Content-Disposition: form-data; name=\"...\")";
        return MHD_NO;
    }
    if (size && !data)
        return MHD_YES;
    if (strcmp(key, "image") == 0 || strcmp(key, "archive") == 0)
        return file_part(r, f, key[0] == 'a', filename, data, off, size);
    f->empty_start = 0;
    char *dst = strcmp(key, "assignment") == 0 ? f->assignment : strcmp(key, "student") == 0 ? f->student : NULL;
    size_t cap = dst == f->assignment ? sizeof f->assignment : sizeof f->student;
    if (dst && !rd_form_text(dst, cap, data, size)) {
        f->form.bad = dst == f->assignment ? "the 'assignment' field is longer than an assignment name can be"
                                           : "a 'student' field is longer than a student id can be";
        return MHD_NO;
    }
    return MHD_YES;
}

/* The instructors' routes: off without --instructor-tokens (404, as if they
 * were not there), 401 without a token, 403 with a wrong one. 0 when the
 * request may go on, else the answer was queued (*ret). */
int rd_require_instructor(rd_req *r, enum MHD_Result *ret)
{
    const rd_auth *a = r->srv->auth;
    if (!a) {
        *ret = rd_reply_error(r, 404, "not_found", NULL,
                              "no such route (grade records need the server's --instructor-tokens)");
        return 1;
    }
    const char *h = MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_AUTHORIZATION);
    rd_auth_result res = rd_auth_check(a, h);
    if (res == RD_AUTH_OK)
        return 0;
    if (res == RD_AUTH_MISSING)
        *ret = rd_reply_error_hdr(r, 401, "unauthorized", "an instructor's token is needed (Authorization: Bearer)",
                                  "WWW-Authenticate", "Bearer realm=\"rayd\"");
    else
        *ret = rd_reply_error(r, 403, "forbidden", NULL, "that token is not an instructor's");
    return 1;
}

enum MHD_Result rd_route_batch_begin(rd_req *r)
{
    enum MHD_Result ret;
    if (rd_require_instructor(r, &ret))
        return ret;
    rd_form_spec spec = {sizeof(batch_form),
                         r->srv->opt.max_batch_bytes + (1u << 20),
                         "the batch (--max-batch-bytes)",
                         "send multipart/form-data with 'assignment' and 'image' files or one 'archive'",
                         on_field,
                         free_form};
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
        return x->f->form.too_big ? rd_error_set(err, RD_ERR_LIMIT, 0, 0, "more than %zu images (--max-batch-images)",
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
    if (!f->archive)
        return RD_OK;
    rd_archive_limits lim = {o->max_batch_images, o->max_body_bytes, o->max_batch_expanded};
    expand_ctx x = {f, o};
    rd_error_code rc = rd_archive_each(f->archive, f->archive_len, &lim, take_file, &x, err);
    free(f->archive);
    f->archive = NULL;
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

static enum MHD_Result form_errors(rd_req *r, batch_form *f)
{
    if (f->form.too_big) {
        const rd_server_options *o = &r->srv->opt;
        char msg[160];
        if (strcmp(f->form.too_big, "--max-batch-images") == 0)
            snprintf(msg, sizeof msg, "the batch has more than %zu images (--max-batch-images)", o->max_batch_images);
        else if (strcmp(f->form.too_big, "--max-batch-bytes") == 0)
            snprintf(msg, sizeof msg, "the batch is over %zu bytes (--max-batch-bytes)", o->max_batch_bytes);
        else
            snprintf(msg, sizeof msg, "an image is over %zu bytes (--max-body-bytes)", o->max_body_bytes);
        return rd_reply_error(r, 413, "too_large", NULL, msg);
    }
    if (f->form.bad)
        return rd_reply_error(r, 400, "parse_error", NULL, f->form.bad);
    if (!f->assignment[0])
        return rd_reply_error(r, 400, "parse_error", NULL, "the form has no 'assignment'");
    if (f->archives && f->n)
        return rd_reply_error(r, 400, "parse_error", NULL, "give 'image' files or one 'archive', not both");
    return MHD_YES;
}

/* The form's images, an archive's expanded or not, become a batch. */
static enum MHD_Result start_batch(rd_req *r, batch_form *f)
{
    rd_server *srv = r->srv;
    rd_error err = {0};
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
        return rd_reply_error(r, err.code == RD_ERR_NOT_FOUND ? 404 : 422,
                              err.code == RD_ERR_NOT_FOUND ? "not_found" : "bad_assignment", &err, NULL);
    rd_grade_batch_image *images = f->images;
    size_t n = f->n;
    f->images = NULL;
    f->n = f->cap = 0;
    char id[RD_STORE_ID_MAX];
    rd_error_code rc = rd_grades_batch_start(srv, f->assignment, images, n, id, &err);
    if (rc)
        return rd_reply_store_error(r, &err);
    char *text = NULL;
    if (rd_grades_batch_json(srv, id, 0, &text, &err))
        return rd_reply_store_error(r, &err);
    char loc[32 + RD_STORE_ID_MAX];
    snprintf(loc, sizeof loc, "/v1/grade/batch/%s", id);
    const char *headers[] = {MHD_HTTP_HEADER_LOCATION, loc, NULL};
    return rd_reply_with(r, 202, "application/json", text, strlen(text), 1, headers);
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
    free(t->f.archive);
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
    t->f.archive_len = f->archive_len;
    f->archive = NULL;
    rd_jq_task task = {expand_archive, NULL, free_expand_task, t, t->f.archive_len, NULL};
    return rd_req_submit(r, &task, &so);
}

enum MHD_Result rd_route_batch_post(rd_req *r, const char *rest)
{
    (void)rest;
    batch_form *f = r->state;
    if (!f)
        return rd_reply_error(r, 400, "parse_error", NULL, "no form");
    if (f->form.too_big || f->form.bad || !f->assignment[0] || (f->archives && f->n))
        return form_errors(r, f);
    if (atomic_load(&r->srv->draining))
        return rd_reply_draining(r);
    return f->archive ? submit_expansion(r, f) : start_batch(r, f);
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

static const char NO_BATCH[] = "no batch with that id (batches expire with their grades, see --grade-ttl)";

/* GET /v1/grade/batch/{id}, .../results.csv, .../results.json */
enum MHD_Result rd_route_batch_get(rd_req *r, const char *path)
{
    enum MHD_Result ret;
    if (rd_require_instructor(r, &ret))
        return ret;
    char id[RD_STORE_ID_MAX];
    const char *p = path + 1, *slash = strchr(p, '/');
    size_t n = slash ? (size_t)(slash - p) : strlen(p);
    if (n == 0 || n >= sizeof id)
        return rd_reply_error(r, 404, "not_found", NULL, NO_BATCH);
    memcpy(id, p, n);
    id[n] = 0;
    const char *what = slash ? slash + 1 : "";
    int form = !*what ? 0 : strcmp(what, "results.json") == 0 ? 1 : strcmp(what, "results.csv") == 0 ? 2 : -1;
    if (form < 0)
        return rd_reply_error(r, 404, "not_found", NULL, "no such route");
    rd_error err = {0};
    char *text = NULL;
    rd_error_code rc = rd_grades_batch_json(r->srv, id, form, &text, &err);
    if (rc == RD_ERR_NOT_FOUND)
        return rd_reply_error(r, 404, "not_found", NULL, NO_BATCH);
    if (rc)
        return rd_reply_store_error(r, &err);
    if (form == 2)
        return rd_reply(r, 200, "text/csv; charset=utf-8", text, strlen(text), 1);
    return rd_reply_json(r, 200, text);
}

/* ---- grading a batch on the render threads ---- */

/* Shared by the batch's tasks; the last one to end frees it. */
typedef struct {
    rd_server *srv;
    char id[RD_STORE_ID_MAX];
    char assignment[80];
    rd_grade_batch_image *images;
    size_t n;
    uint8_t *ref; /* the reference, once rendered or found */
    int w, h;
    rd_error failed; /* the reference could not be had: every image is this error */
    pthread_mutex_t mu;
    int refs;
} grade_batch;

static void batch_unref(grade_batch *b)
{
    pthread_mutex_lock(&b->mu);
    int last = --b->refs == 0;
    pthread_mutex_unlock(&b->mu);
    if (!last)
        return;
    free_images(b->images, b->n);
    free(b->ref);
    pthread_mutex_destroy(&b->mu);
    free(b);
}

/* A task: the reference (first), or a slice of the images. */
typedef struct {
    grade_batch *b;
    size_t i0, i1;
    rd_grade_output out; /* the reference task's */
} batch_task;

static void free_batch_task(void *arg)
{
    batch_task *t = arg;
    rd_grade_output_free(&t->out);
    batch_unref(t->b);
    free(t);
}

/* The images' bytes count in --memory-budget from the batch's start until
 * each is graded (rd_grades_batch_start). */
static long long images_bytes(const rd_grade_batch_image *images, size_t n)
{
    long long sum = 0;
    for (size_t i = 0; i < n; i++)
        sum += (long long)images[i].len;
    return sum;
}

static void drop_png(grade_batch *b, rd_grade_batch_image *im)
{
    free(im->png);
    im->png = NULL;
    rd_jq_external_bytes(b->srv->jobs, -(long long)im->len);
}

static void grade_image(grade_batch *b, size_t i)
{
    rd_grade_batch_image *im = &b->images[i];
    if (im->error) {
        char id[RD_CAP_MAX];
        rd_grades_error_record(b->srv, b->assignment, im->student, b->id, im->error, id);
        drop_png(b, im);
        return;
    }
    const rd_grader *g = rd_grades_grader(b->srv->grades);
    rd_grade_input in = {.assignment = b->assignment, .png = im->png, .png_len = im->len};
    rd_grade_output o;
    rd_scene s;
    rd_scene_init(&s);
    rd_error err = {0};
    char id[RD_CAP_MAX];
    rd_error_code rc = b->failed.code ? b->failed.code : rd_grade_prepare(g, &in, &s, &o, &err);
    if (b->failed.code)
        err = b->failed;
    if (!rc && !o.reference)
        rc = rd_grade_set_reference(g, &o, b->ref, b->w, b->h, &err);
    if (!rc && rd_grade_finish(&o))
        rc = rd_error_set(&err, RD_ERR_NOMEM, 0, 0, "out of memory comparing the images");
    char *verdict = NULL;
    if (!rc)
        rc = rd_grades_one(b->srv, &o, im->student, b->id, id, &verdict, &err);
    if (rc)
        rd_grades_error_record(b->srv, b->assignment, im->student, b->id, err.message, id);
    free(verdict);
    if (!b->failed.code)
        rd_grade_output_free(&o);
    rd_scene_free(&s);
    drop_png(b, im);
}

static rd_error_code grade_slice(void *arg, rd_scene *s, int *render, rd_error *err)
{
    (void)s, (void)err;
    batch_task *t = arg;
    *render = 0;
    for (size_t i = t->i0; i < t->i1; i++)
        grade_image(t->b, i);
    return RD_OK;
}

/* The reference: found in the cache, or rendered by the queue as any
 * grade's is. */
static rd_error_code prepare_reference(void *arg, rd_scene *s, int *render, rd_error *err)
{
    batch_task *t = arg;
    rd_grade_input in = {.assignment = t->b->assignment};
    rd_error_code rc = rd_grade_prepare_reference(rd_grades_grader(t->b->srv->grades), &in, s, &t->out, err);
    *render = !rc && !t->out.reference;
    return rc;
}

static rd_error_code submit_slices(grade_batch *b, rd_error *err)
{
    rd_server *srv = b->srv;
    size_t k = (size_t)(srv->opt.jobs.workers > 0 ? srv->opt.jobs.workers : 1);
    if (k > b->n)
        k = b->n;
    for (size_t j = 0; j < k; j++) {
        batch_task *t = calloc(1, sizeof *t);
        if (!t)
            return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
        t->b = b;
        t->i0 = b->n * j / k;
        t->i1 = b->n * (j + 1) / k;
        pthread_mutex_lock(&b->mu);
        b->refs++;
        pthread_mutex_unlock(&b->mu);
        rd_jq_task task = {grade_slice, NULL, free_batch_task, t, 0, NULL};
        /* registered: the queue holds it until it ends */
        rd_jq_submit_options so = {.watch_fd = -1, .renders_nothing = 1};
        rd_jq_job *job;
        rd_error_code rc = rd_jq_submit(srv->jobs, &task, &so, &job, err);
        if (rc)
            return rc;
        rd_jq_job_unref(job);
    }
    return RD_OK;
}

/* The reference task's end: the slices go out (on a full queue, this
 * thread grades what could not be queued). */
static rd_error_code finish_reference(void *arg, const uint8_t *rgb, int w, int h, rd_error *err)
{
    batch_task *t = arg;
    grade_batch *b = t->b;
    rd_grade_output *o = &t->out;
    rd_error_code rc = rgb ? rd_grade_set_reference(rd_grades_grader(b->srv->grades), o, rgb, w, h, err) : RD_OK;
    size_t n = (size_t)o->width * (size_t)o->height * 3;
    if (!rc && !(b->ref = malloc(n ? n : 1)))
        rc = rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    if (!rc) {
        memcpy(b->ref, o->reference, n);
        b->w = o->width;
        b->h = o->height;
    } else {
        b->failed = *err;
    }
    rd_error qerr = {0};
    if (submit_slices(b, &qerr)) {
        batch_task all = {b, 0, b->n, {0}};
        int render = 0;
        grade_slice(&all, NULL, &render, &qerr);
    }
    return RD_OK;
}

/* The students' ids, each followed by '\n' (malloc'ed; NULL when out of
 * memory): what a restarted daemon needs to name the ones it did not
 * grade. A batch's ids never hold a control character (student_of). */
static char *students_text(const rd_grade_batch_image *images, size_t n)
{
    rd_strbuf t = {0};
    for (size_t i = 0; i < n; i++)
        rd_strbuf_printf(&t, "%s\n", images[i].student);
    return rd_strbuf_take(&t, NULL);
}

/* The batch's row: its daemon and students with it, or, when the students
 * are more than the store takes as one text, without them (a restart then
 * numbers the rows it could not grade). */
static rd_error_code create_batch(rd_server *srv, rd_store *s, const char *id, const char *assignment,
                                  const rd_grade_batch_image *images, size_t n, rd_error *err)
{
    char *students = students_text(images, n);
    if (!students)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    const char *daemon = rd_server_daemon_id(srv);
    rd_error_code rc = rd_store_batch_create(s, id, assignment, (int)n, daemon, students, err);
    if (rc == RD_ERR_LIMIT)
        rc = rd_store_batch_create(s, id, assignment, (int)n, daemon, NULL, err);
    free(students);
    return rc;
}

rd_error_code rd_grades_batch_start(rd_server *srv, const char *assignment, rd_grade_batch_image *images, size_t n,
                                    char id[RD_STORE_ID_MAX], rd_error *err)
{
    rd_store *s = rd_grades_store(srv->grades);
    grade_batch *b = calloc(1, sizeof *b);
    batch_task *t = calloc(1, sizeof *t);
    rd_error_code rc = !b || !t ? rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory")
                       : !s     ? rd_error_set(err, RD_ERR_UNAVAILABLE, 0, 0, "the store is not open yet")
                                : RD_OK;
    if (!rc)
        rc = rd_cap_new(b->id, 0, err);
    if (!rc)
        rc = create_batch(srv, s, b->id, assignment, images, n, err);
    if (rc) {
        free_images(images, n);
        free(b);
        free(t);
        return rc;
    }
    b->srv = srv;
    snprintf(b->assignment, sizeof b->assignment, "%s", assignment);
    b->images = images;
    b->n = n;
    b->refs = 1;
    pthread_mutex_init(&b->mu, NULL);
    t->b = b;
    memcpy(id, b->id, RD_STORE_ID_MAX);
    rd_jq_task task = {prepare_reference, finish_reference, free_batch_task, t, 0, NULL};
    rd_jq_submit_options so = {.watch_fd = -1}; /* registered: the queue holds it until it ends */
    rd_jq_job *job;
    long long held = images_bytes(images, n);
    rd_jq_external_bytes(srv->jobs, held);
    rc = rd_jq_submit(srv->jobs, &task, &so, &job, err);
    if (rc) {
        rd_jq_external_bytes(srv->jobs, -held);
        rd_store_batch_cancel(s, id, NULL, NULL);
        return rc;
    }
    rd_jq_job_unref(job);
    return RD_OK;
}

/* ---- batches a killed daemon left running ---- */

static const char RESTARTED[] = "not graded: the daemon restarted while grading the batch; grade this image again";

/* 1 when g (n grades) holds a row of student. */
static int has_row(const rd_store_grade *g, size_t n, const char *student)
{
    for (size_t i = 0; i < n; i++)
        if (g[i].student && strcmp(g[i].student, student) == 0)
            return 1;
    return 0;
}

/* Ends one batch: an error row for each student without a row, named from
 * the batch's students, or numbered when it has none (an older batch, or
 * one whose students the store could not take). Each row counts, so the
 * last one makes it done. */
static void end_batch(rd_server *srv, rd_store *s, const rd_store_batch *b)
{
    rd_store_grade_filter f = {.batch_id = b->id, .max = (size_t)b->total};
    rd_store_grade *g = NULL;
    size_t n = 0;
    char *students = NULL;
    rd_error err = {0};
    if (rd_store_grades_list(s, &f, &g, &n, &err) || rd_store_batch_students(s, b->id, &students, &err)) {
        rd_log_msg(srv->opt.log, "warning", "batch %s could not be ended: %s", b->id, err.message);
        rd_store_grades_free(g, n);
        return;
    }
    char id[RD_CAP_MAX];
    int left = b->total - b->done;
    for (char *p = students, *nl; left > 0 && (nl = strchr(p, '\n')); p = nl + 1) {
        *nl = 0;
        if (!has_row(g, n, p) && left-- > 0)
            rd_grades_error_record(srv, b->assignment, p, b->id, RESTARTED, id);
    }
    for (int k = b->total - left + 1; k <= b->total; k++) {
        char unnamed[48];
        snprintf(unnamed, sizeof unnamed, "(not graded %d of %d)", k, b->total);
        rd_grades_error_record(srv, b->assignment, unnamed, b->id, RESTARTED, id);
    }
    free(students);
    rd_store_grades_free(g, n);
    rd_log_msg(srv->opt.log, "info", "batch %s ended after a restart: %d of %d images had been graded", b->id, b->done,
               b->total);
}

void rd_grades_batches_end_restarted(rd_server *srv)
{
    rd_store *s = rd_grades_store(srv->grades);
    rd_store_batch *list = NULL;
    size_t n = 0;
    rd_error err = {0};
    if (!s || rd_store_batches_running(s, rd_server_daemon_id(srv), SIZE_MAX, &list, &n, &err)) {
        if (s)
            rd_log_msg(srv->opt.log, "warning", "the batches left running could not be read: %s", err.message);
        return;
    }
    for (size_t i = 0; i < n; i++)
        end_batch(srv, s, &list[i]);
    free(list);
}

/* ---- the records as rows ---- */

/* A record as a table row (grade_table.h). 0 when it cannot be one. */
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

/* The grades as the answer's rows: a JSON array, or CSV (header first). */
static char *rows_text(const rd_store_grade *g, size_t n, int csv)
{
    if (csv) {
        rd_strbuf b = {0};
        rd_grade_csv_header(&b);
        for (size_t i = 0; i < n; i++)
            row_csv(&b, &g[i]);
        return rd_strbuf_take(&b, NULL);
    }
    cJSON *a = cJSON_CreateArray();
    for (size_t i = 0; a && i < n; i++) {
        cJSON *o = row_json(&g[i]);
        if (o)
            cJSON_AddItemToArray(a, o);
    }
    char *t = a ? cJSON_PrintUnformatted(a) : NULL;
    cJSON_Delete(a);
    return t;
}

rd_error_code rd_grades_batch_json(rd_server *srv, const char *id, int form, char **text, rd_error *err)
{
    rd_store *s = rd_grades_store(srv->grades);
    if (!s)
        return rd_error_set(err, RD_ERR_UNAVAILABLE, 0, 0, "the store is not open yet");
    rd_store_batch b;
    rd_error_code rc = rd_store_batch_get(s, id, &b, err);
    if (rc == RD_ERR_INVALID)
        rc = rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "no such batch");
    if (rc)
        return rc;
    rd_store_grade_filter f = {.batch_id = id, .max = (size_t)b.total};
    rd_store_grade *g = NULL;
    size_t n = 0;
    if ((rc = rd_store_grades_list(s, &f, &g, &n, err)))
        return rc;
    char *rows = rows_text(g, n, form == 2);
    rd_store_grades_free(g, n);
    if (!rows)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    if (form) {
        *text = rows;
        return RD_OK;
    }
    /* The rows go in as written: cJSON would print their numbers again,
     * with fewer digits than grade_table.h gives. */
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "id", b.id);
    cJSON_AddStringToObject(o, "assignment", b.assignment);
    cJSON_AddStringToObject(o, "status", rd_store_batch_status_name(b.status));
    cJSON_AddNumberToObject(o, "total", b.total);
    cJSON_AddNumberToObject(o, "done", b.done);
    cJSON_AddRawToObject(o, "results", rows);
    free(rows);
    *text = cJSON_PrintUnformatted(o);
    cJSON_Delete(o);
    return *text ? RD_OK : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
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

/* since: Unix milliseconds, or a UTC date as 2026-12-01 or
 * 2026-12-01T09:30:00Z. -1 when it is neither. */
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
    if (*p == 'T') {
        int k = 0;
        if (sscanf(p, "T%2d:%2d:%2d%n", &h, &mi, &sec, &k) != 3 || k != 9)
            return -1;
        p += k;
        if (*p == 'Z')
            p++;
    }
    if (*p || mo < 1 || mo > 12 || d < 1 || d > 31 || h > 23 || mi > 59 || sec > 60 || y < 1970)
        return -1;
    return ((days_from_civil(y, (unsigned)mo, (unsigned)d) * 24 + h) * 60 + mi) * 60000LL + sec * 1000LL;
}

enum MHD_Result rd_route_grades_list(rd_req *r)
{
    enum MHD_Result ret;
    if (rd_require_instructor(r, &ret))
        return ret;
    rd_store *s = rd_grades_store(r->srv->grades);
    const char *since = MHD_lookup_connection_value(r->conn, MHD_GET_ARGUMENT_KIND, "since");
    long long from = since_ms(since);
    if (from < 0)
        return rd_reply_error(r, 400, "parse_error", NULL,
                              "query parameter since: expected Unix milliseconds or a date as 2026-12-01T09:30:00Z");
    rd_store_grade_filter f = {.assignment = MHD_lookup_connection_value(r->conn, MHD_GET_ARGUMENT_KIND, "assignment"),
                               .student = MHD_lookup_connection_value(r->conn, MHD_GET_ARGUMENT_KIND, "student"),
                               .since_ms = from,
                               .max = GRADES_LISTED};
    rd_store_grade *g = NULL;
    size_t n = 0;
    rd_error err = {0};
    rd_error_code rc =
        s ? rd_store_grades_list(s, &f, &g, &n, &err) : rd_error_set(&err, RD_ERR_UNAVAILABLE, 0, 0, "no store");
    if (rc == RD_ERR_INVALID)
        return rd_reply_error(r, 400, "parse_error", &err, NULL);
    if (rc)
        return rd_reply_store_error(r, &err);
    const char *accept = MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_ACCEPT);
    int csv = accept && strstr(accept, "text/csv");
    char *rows = rows_text(g, n, csv);
    rd_store_grades_free(g, n);
    if (!rows)
        return rd_reply_error(r, 503, "unavailable", NULL, "out of memory");
    if (csv)
        return rd_reply(r, 200, "text/csv; charset=utf-8", rows, strlen(rows), 1);
    size_t len = strlen(rows) + 16;
    char *text = malloc(len);
    if (!text) {
        free(rows);
        return rd_reply_error(r, 503, "unavailable", NULL, "out of memory");
    }
    snprintf(text, len, "{\"grades\":%s}", rows);
    free(rows);
    return rd_reply_json(r, 200, text);
}
