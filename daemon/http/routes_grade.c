/* POST /v1/grade, GET /v1/assignments, GET /v1/grades/{id}/...: grading
 * through the same render queue as everything else, so no HTTP thread ever
 * renders a reference. References stay in memory (and in --cache-dir) by
 * scene and renderer; finished grades keep their images for the page. */
#include <cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "assignment.h"
#include "error_map.h"
#include "file_io.h"
#include "grading.h"
#include "http_internal.h"
#include "json_text.h"
#include "metrics.h"
#include "png_write.h"
#include "rayd/clock.h"
#include "scene_load.h"
#include "utf8.h"

enum { GRADES_KEPT = 256 };

/* A form holds up to three fields (image, scene, assignment) of at most
 * --max-body-bytes each; a bad one is read to its end and dropped, up to
 * DISCARD_MAX more, before the connection is closed instead. */
enum { FORM_FIELDS = 3, DISCARD_MAX = 1 << 20 };

typedef struct {
    char id[RD_CAP_MAX];
    unsigned char *diff, *reference, *image; /* PNGs */
    size_t diff_len, reference_len, image_len;
    double t;
} grade_entry;

/* The references (api/grading's cache, in memory and --cache-dir) and the
 * images of finished grades share --grade-cache-bytes: kept grades shrink
 * what references may hold, and the oldest grades go once references hold
 * nothing. */
struct rd_grades {
    pthread_mutex_t mu;
    rd_grader grader;
    grade_entry kept[GRADES_KEPT];
    size_t next;
    rd_jq *jobs; /* told of every byte the caches hold */
    size_t kept_bytes, cap;
    /* The records (docs/grading.md): set once the store is open, before the
     * server is ready; NULL until then. The grades own it. */
    _Atomic(rd_store *) store;
    double ttl_ms;
    atomic_llong last_expire_ms;
    rd_log *log;
};

/* The form as it arrives, on the HTTP thread (the request's state). */
typedef struct {
    rd_form form;
    char *image;
    size_t image_len;
    char *scene;
    size_t scene_len;
    char assignment[80];
    char student[256];
} grade_form;

/* One grade on a render thread: prepared (rd_grade_prepare, which finds a
 * cached reference), rendered only when there is none, then finished
 * (compare, heat map, the kept PNGs, the verdict). */
typedef struct {
    char *image;
    size_t image_len;
    char *scene;
    size_t scene_len;
    char assignment[80];
    char student[256];
    rd_server *srv;
    rd_grade_output out;
    char *json; /* the verdict */
} grade_task;

static void count_bytes(void *jobs, long long delta) { rd_jq_external_bytes(jobs, delta); }

struct rd_grades *rd_grades_new(rd_jq *jobs, const rd_server_options *opt)
{
    struct rd_grades *g = calloc(1, sizeof *g);
    if (!g)
        return NULL;
    g->grader.cache = rd_ref_cache_new(opt->grade_cache_bytes, opt->cache_dir, count_bytes, jobs);
    if (!g->grader.cache) {
        free(g);
        return NULL;
    }
    g->grader.assignments_dir = opt->assignments_dir;
    g->grader.assets_dir = opt->scenes_dir;
    g->grader.limits = opt->limits;
    g->jobs = jobs;
    g->cap = opt->grade_cache_bytes;
    g->ttl_ms = opt->grade_ttl_ms;
    g->log = opt->log;
    pthread_mutex_init(&g->mu, NULL);
    return g;
}

static size_t entry_bytes(const grade_entry *e) { return e->diff_len + e->reference_len + e->image_len; }

static void drop_kept(struct rd_grades *g, grade_entry *e)
{
    size_t n = entry_bytes(e);
    g->kept_bytes -= n;
    rd_jq_external_bytes(g->jobs, -(long long)n);
    free(e->diff);
    free(e->reference);
    free(e->image);
    memset(e, 0, sizeof *e);
}

void rd_grades_free(struct rd_grades *g)
{
    if (!g)
        return;
    /* The queue is gone by now: nobody is told of these bytes. */
    for (int i = 0; i < GRADES_KEPT; i++) {
        free(g->kept[i].diff);
        free(g->kept[i].reference);
        free(g->kept[i].image);
    }
    rd_ref_cache_free(g->grader.cache);
    rd_store_close(atomic_load(&g->store));
    pthread_mutex_destroy(&g->mu);
    free(g);
}

void rd_grades_set_store(struct rd_grades *g, rd_store *s) { atomic_store(&g->store, s); }

rd_store *rd_grades_store(struct rd_grades *g) { return atomic_load(&g->store); }

const rd_grader *rd_grades_grader(struct rd_grades *g) { return &g->grader; }

/* Past the cap the references give way first, then the oldest grades.
 * Under g->mu. */
static void fit(struct rd_grades *g)
{
    while (g->kept_bytes > g->cap) {
        grade_entry *old = NULL;
        for (int i = 0; i < GRADES_KEPT; i++)
            if (g->kept[i].id[0] && (!old || g->kept[i].t < old->t))
                old = &g->kept[i];
        if (!old)
            break;
        drop_kept(g, old);
    }
    rd_ref_cache_set_max_bytes(g->grader.cache, g->cap - g->kept_bytes);
}

static unsigned char *encode(const uint8_t *rgb, int w, int h, size_t *len)
{
    unsigned char *png = NULL;
    rd_error err;
    rd_png_options po = rd_png_options_default();
    if (rd_png_encode(rgb, w, h, &po, &png, len, &err))
        return NULL;
    return png;
}

/* Keeps the images of a finished grade for GET /v1/grades/{id}/...; returns
 * its id and a copy of the diff PNG for the record (NULL when out of
 * memory; the caller frees it). */
static rd_error_code keep(struct rd_grades *g, const rd_grade_output *o, char id[RD_CAP_MAX], unsigned char **diff,
                          size_t *diff_len, rd_error *err)
{
    if (rd_cap_new(id, 'g', err))
        return err ? err->code : RD_ERR_IO;
    size_t n = (size_t)o->width * (size_t)o->height * 3;
    uint8_t *heat = malloc(n);
    grade_entry e;
    memset(&e, 0, sizeof e);
    if (heat) {
        rd_grade_heatmap(o->reference, o->image, o->width, o->height, o->thresholds.fail, heat);
        e.diff = encode(heat, o->width, o->height, &e.diff_len);
        free(heat);
    }
    e.reference = encode(o->reference, o->width, o->height, &e.reference_len);
    e.image = encode(o->image, o->width, o->height, &e.image_len);
    *diff = e.diff ? malloc(e.diff_len) : NULL;
    *diff_len = *diff ? e.diff_len : 0;
    if (*diff)
        memcpy(*diff, e.diff, e.diff_len);
    e.t = rd_now_ms();
    memcpy(e.id, id, sizeof e.id);
    pthread_mutex_lock(&g->mu);
    grade_entry *slot = &g->kept[g->next++ % GRADES_KEPT];
    drop_kept(g, slot);
    *slot = e;
    g->kept_bytes += entry_bytes(&e);
    rd_jq_external_bytes(g->jobs, (long long)entry_bytes(&e));
    fit(g);
    pthread_mutex_unlock(&g->mu);
    return RD_OK;
}

static void free_form(rd_req *r)
{
    grade_form *g = r->state;
    if (!g)
        return;
    rd_form_end(&g->form);
    free(g->image);
    free(g->scene);
    free(g);
    r->state = NULL;
}

static enum MHD_Result on_field(void *cls, enum MHD_ValueKind kind, const char *key, const char *filename,
                                const char *content_type, const char *encoding, const char *data, uint64_t off,
                                size_t size)
{
    (void)kind, (void)filename, (void)content_type, (void)encoding, (void)off;
    rd_req *r = cls;
    grade_form *g = r->state;
    /* A part without a Content-Disposition name (or with an unquoted one)
     * comes with no key at all. */
    if (!key) {
        g->form.bad = "a form part has no field name (Content-Disposition: form-data; name=\"...\")";
        return MHD_NO;
    }
    if (size && !data)
        return MHD_YES;
    char **buf = NULL;
    size_t *len = NULL;
    if (strcmp(key, "image") == 0) {
        buf = &g->image;
        len = &g->image_len;
    } else if (strcmp(key, "scene") == 0) {
        buf = &g->scene;
        len = &g->scene_len;
    } else if (strcmp(key, "student") == 0) {
        size_t have = strlen(g->student);
        if (have + size < sizeof g->student) {
            memcpy(g->student + have, data, size);
            g->student[have + size] = 0;
            return MHD_YES;
        }
        g->form.bad = "the 'student' field is longer than a student id can be";
        return MHD_NO;
    } else if (strcmp(key, "assignment") == 0) {
        size_t have = strlen(g->assignment);
        if (have + size < sizeof g->assignment) {
            memcpy(g->assignment + have, data, size);
            g->assignment[have + size] = 0;
            return MHD_YES;
        }
        g->form.bad = "the 'assignment' field is longer than an assignment name can be";
        return MHD_NO;
    } else {
        return MHD_YES; /* other fields are ignored */
    }
    if (*len + size > r->srv->opt.max_body_bytes) {
        g->form.too_big = "--max-body-bytes";
        return MHD_NO;
    }
    char *p = realloc(*buf, *len + size + 1);
    if (!p)
        return MHD_NO;
    memcpy(p + *len, data, size);
    *len += size;
    p[*len] = 0;
    *buf = p;
    return MHD_YES;
}

enum MHD_Result rd_route_grade_begin(rd_req *r)
{
    rd_form_spec spec = {sizeof(grade_form),
                         FORM_FIELDS * r->srv->opt.max_body_bytes,
                         "the form (each field may have --max-body-bytes)",
                         "send multipart/form-data with 'image' and 'assignment' or 'scene'",
                         on_field,
                         free_form};
    return rd_form_begin(r, &spec);
}

enum MHD_Result rd_route_grade_data(rd_req *r, const char *data, size_t size)
{
    return rd_form_data(r, data, size, FORM_FIELDS * r->srv->opt.max_body_bytes + DISCARD_MAX);
}

/* The verdict with the kept images' addresses, the grade's id and its
 * student (when known). */
static char *verdict_json(const rd_grade_output *o, const char *id, const char *student)
{
    cJSON *root = rd_grade_json(o);
    if (!root)
        return NULL;
    if (student && *student && !cJSON_AddStringToObject(root, "student", student)) {
        cJSON_Delete(root);
        return NULL;
    }
    static const char *const files[][2] = {
        {"diff_url", "diff"}, {"reference_url", "reference"}, {"image_url", "image"}};
    char url[80];
    int ok = cJSON_AddStringToObject(root, "id", id) != NULL;
    for (int i = 0; i < 3 && ok; i++) {
        snprintf(url, sizeof url, "/v1/grades/%s/%s.png", id, files[i][1]);
        ok = cJSON_AddStringToObject(root, files[i][0], url) != NULL;
    }
    char *text = ok ? cJSON_PrintUnformatted(root) : NULL;
    cJSON_Delete(root);
    return text;
}

static rd_grade_input input_of(const grade_task *t)
{
    rd_grade_input in = {0};
    in.assignment = t->assignment[0] ? t->assignment : NULL;
    in.scene_text = t->scene;
    in.scene_len = t->scene_len;
    in.source = "<upload>";
    in.png = (const unsigned char *)t->image;
    in.png_len = t->image_len;
    return in;
}

static rd_error_code prepare_grade(void *arg, rd_scene *s, int *render, rd_error *err)
{
    grade_task *t = arg;
    rd_grade_input in = input_of(t);
    rd_error_code rc = rd_grade_prepare(&t->srv->grades->grader, &in, s, &t->out, err);
    free(t->image);
    t->image = NULL;
    if (rc)
        return rc;
    rd_metrics_reference(t->srv, t->out.reference != NULL);
    *render = !t->out.reference;
    return RD_OK;
}

static rd_error_code finish_grade(void *arg, const uint8_t *rgb, int w, int h, rd_error *err)
{
    grade_task *t = arg;
    struct rd_grades *g = t->srv->grades;
    rd_grade_output *o = &t->out;
    if (rgb) {
        rd_error_code rc = rd_grade_set_reference(&g->grader, o, rgb, w, h, err);
        if (rc)
            return rc;
    }
    if (rd_grade_finish(o))
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory comparing the images");
    char id[RD_CAP_MAX];
    return rd_grades_one(t->srv, o, t->student, NULL, id, &t->json, err);
}

/* Stores rec; a record the store refuses (a text it will not take) becomes
 * an error row saying why, with its texts made valid, so that a batch
 * still counts every student. What still fails (the store unreachable, the
 * batch ended) is logged. */
static void put_record(struct rd_grades *g, rd_store *s, const rd_store_grade *rec, const unsigned char *diff,
                       size_t diff_len)
{
    rd_error err = {0};
    rd_error_code rc = rd_store_grade_put(s, rec, diff, diff_len, &err);
    if (rc == RD_ERR_INVALID || rc == RD_ERR_LIMIT) {
        char student[RD_STORE_NAME_MAX], why[600];
        rd_utf8_readable(rec->student, strlen(rec->student), student, sizeof student);
        snprintf(
            why, sizeof why, "%s%s",
            rec->error ? "not graded; its message was refused: " : "graded, but its record was refused: ", err.message);
        char message[600];
        rd_utf8_readable(why, strlen(why), message, sizeof message);
        rd_store_grade row = {.id = rec->id,
                              .batch_id = rec->batch_id,
                              .assignment = rec->assignment,
                              .student = student,
                              .graded_ms = rec->graded_ms,
                              .error = message};
        rc = rd_store_grade_put(s, &row, NULL, 0, &err);
    }
    if (rc)
        rd_log_msg(g->log, "warning", "grade %s was not recorded: %s", rec->id, err.message);
}

/* A grade's record: kept until --grade-ttl, expired here about once a
 * minute. A store that cannot take it is logged, a record it refuses is
 * an error row (put_record); the grade is answered anyway (its images
 * stay in memory). Grades of a given scene rather than an assignment are
 * not records: they belong to no course. */
void rd_grades_record(rd_server *srv, const rd_grade_output *o, const char *id, const char *student,
                      const char *batch_id, int pass, const char *verdict, const unsigned char *diff, size_t diff_len)
{
    struct rd_grades *g = srv->grades;
    rd_store *s = atomic_load(&g->store);
    if (!s || !o->assignment[0])
        return;
    char key[96];
    snprintf(key, sizeof key, "%s/%s", o->key, rd_renderer_id());
    rd_store_grade rec = {.id = id,
                          .batch_id = batch_id,
                          .assignment = o->assignment,
                          .student = student ? student : "",
                          .pass = pass,
                          .failed_fraction = o->result.failed_fraction,
                          .max_abs = o->result.max_abs,
                          .psnr_db = o->result.psnr_db,
                          .ssim = o->result.ssim,
                          .verdict = verdict,
                          .reference_key = key,
                          .graded_ms = rd_wall_ms()};
    put_record(g, s, &rec, diff, diff_len);
    rd_error err = {0};
    long long now = rd_wall_ms(), last = atomic_load(&g->last_expire_ms);
    if (now - last > 60000 && atomic_compare_exchange_strong(&g->last_expire_ms, &last, now))
        rd_store_grades_expire(s, (int64_t)g->ttl_ms, NULL, &err);
}

rd_error_code rd_grades_keep(rd_server *srv, const rd_grade_output *o, const char *student, char id[RD_CAP_MAX],
                             char **verdict, unsigned char **diff, size_t *diff_len, rd_error *err)
{
    *diff = NULL;
    *diff_len = 0;
    *verdict = NULL;
    if (keep(srv->grades, o, id, diff, diff_len, err))
        return err ? err->code : RD_ERR_IO;
    *verdict = verdict_json(o, id, student);
    if (*verdict)
        return RD_OK;
    free(*diff);
    *diff = NULL;
    return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
}

rd_error_code rd_grades_one(rd_server *srv, const rd_grade_output *o, const char *student, const char *batch_id,
                            char id[RD_CAP_MAX], char **verdict, rd_error *err)
{
    unsigned char *diff;
    size_t diff_len;
    rd_error_code rc = rd_grades_keep(srv, o, student, id, verdict, &diff, &diff_len, err);
    if (!rc)
        rd_grades_record(srv, o, id, student, batch_id, o->result.pass, *verdict, diff, diff_len);
    free(diff);
    return rc;
}

void rd_grades_error_record(rd_server *srv, const char *assignment, const char *student, const char *batch_id,
                            const char *message, char id[RD_CAP_MAX])
{
    struct rd_grades *g = srv->grades;
    rd_error made = {0};
    rd_store *s = atomic_load(&g->store);
    if (rd_cap_new(id, 'g', &made)) {
        rd_log_msg(g->log, "warning", "a grade of %s was not recorded: %s", student, made.message);
        return;
    }
    if (!s)
        return;
    rd_store_grade rec = {.id = id,
                          .batch_id = batch_id,
                          .assignment = assignment,
                          .student = student ? student : "",
                          .graded_ms = rd_wall_ms(),
                          .error = message && *message ? message : "not graded"};
    put_record(g, s, &rec, NULL, 0);
}

static void free_grade(void *arg)
{
    grade_task *t = arg;
    if (!t)
        return;
    free(t->image);
    free(t->scene);
    free(t->json);
    rd_grade_output_free(&t->out);
    free(t);
}

enum MHD_Result rd_route_grade(rd_req *r, const char *rest)
{
    (void)rest;
    rd_server *srv = r->srv;
    grade_form *g = r->state;
    if (!g)
        return rd_reply_error(r, 400, "parse_error", NULL, "no form");
    if (g->form.too_big)
        return rd_reply_too_large(r, "a form field");
    if (g->form.bad)
        return rd_reply_error(r, 400, "parse_error", NULL, g->form.bad);
    if (atomic_load(&srv->draining))
        return rd_reply_draining(r);
    if (!g->image || !g->image_len)
        return rd_reply_error(r, 400, "parse_error", NULL, "the form has no 'image' file");
    if (!g->assignment[0] == !g->scene)
        return rd_reply_error(r, 400, "parse_error", NULL, "give exactly one of 'assignment' or 'scene'");
    /* Its record could not hold it: refused before it is graded. */
    if (rd_utf8_invalid_at(g->student, strlen(g->student)) != strlen(g->student))
        return rd_reply_error(r, 400, "parse_error", NULL, "the 'student' field is not UTF-8 text");
    grade_task *t = calloc(1, sizeof *t);
    if (!t)
        return rd_reply_error(r, 503, "unavailable", NULL, "out of memory");
    t->srv = srv;
    t->image = g->image;
    t->image_len = g->image_len;
    t->scene = g->scene;
    t->scene_len = g->scene_len;
    memcpy(t->assignment, g->assignment, sizeof t->assignment);
    memcpy(t->student, g->student, sizeof t->student);
    g->image = g->scene = NULL;
    rd_jq_task task = {prepare_grade, finish_grade, free_grade, t, t->image_len + t->scene_len, NULL};
    rd_jq_submit_options so = {0};
    return rd_req_submit(r, &task, &so);
}

enum MHD_Result rd_route_grade_resumed(rd_req *r)
{
    rd_jq_info info;
    rd_jq_info_get(r->srv->jobs, r->job, &info);
    grade_task *t = rd_jq_task_arg(r->job);
    if (info.status == RD_JQ_DONE && t->json) {
        char *json = t->json;
        t->json = NULL;
        rd_metrics_grade(r->srv, t->out.result.pass ? RD_VERDICT_PASS : RD_VERDICT_FAIL);
        return rd_reply_json(r, 200, json);
    }
    if (info.status == RD_JQ_FAILED) {
        /* A failed render of the reference fails the grade there. */
        rd_grade_stage stage = t->out.stage ? t->out.stage : RD_GRADE_STAGE_REFERENCE;
        rd_error_answer a = rd_grade_error_answer(stage, info.error.code);
        rd_metrics_grade(r->srv, RD_VERDICT_ERROR);
        return rd_reply_error(r, a.http, a.code, &info.error, NULL);
    }
    return rd_reply_cancelled(r, &info, "grade");
}

/* GET /v1/grades/{id}: the record's verdict, for whoever has the id. */
static enum MHD_Result stored_verdict(rd_req *r, const char *id)
{
    rd_store *s = rd_grades_store(r->srv->grades);
    rd_store_grade g = {0};
    rd_error err = {0};
    rd_error_code rc = s ? rd_store_grade_get(s, id, &g, &err) : RD_ERR_NOT_FOUND;
    if (rc == RD_ERR_NOT_FOUND || rc == RD_ERR_INVALID)
        return rd_reply_error(r, 404, "not_found", NULL, "no such grade (records are kept for --grade-ttl)");
    if (rc)
        return rd_reply_store_error(r, &err);
    char *text = g.verdict ? strdup(g.verdict) : NULL;
    if (!text && g.error) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "id", id);
        cJSON_AddStringToObject(o, "student", g.student ? g.student : "");
        cJSON_AddStringToObject(o, "assignment", g.assignment ? g.assignment : "");
        cJSON_AddBoolToObject(o, "pass", 0);
        cJSON_AddStringToObject(o, "error", g.error);
        text = cJSON_PrintUnformatted(o);
        cJSON_Delete(o);
    }
    rd_store_grade_free(&g);
    if (!text)
        return rd_reply_error(r, 503, "unavailable", NULL, "out of memory");
    return rd_reply_json(r, 200, text);
}

/* A diff PNG from the record once the grade has left memory. */
static unsigned char *stored_diff(rd_req *r, const char *id, size_t *len)
{
    rd_store *s = rd_grades_store(r->srv->grades);
    unsigned char *png = NULL;
    rd_error err = {0};
    if (!s || rd_store_grade_image(s, id, RD_STORE_GRADE_DIFF, &png, len, &err))
        return NULL;
    return png;
}

enum MHD_Result rd_route_grade_files(rd_req *r, const char *path)
{
    if (!*path)
        return rd_route_grades_list(r);
    const char *rest = path + 1;
    /* rest: "{id}", "{id}/diff.png", "{id}/reference.png" or "{id}/image.png" */
    const char *slash = strchr(rest, '/');
    if (!slash && rd_cap_valid(rest, 'g'))
        return stored_verdict(r, rest);
    if (!slash || slash - rest >= RD_CAP_MAX)
        return rd_reply_error(r, 404, "not_found", NULL, "no such grade");
    char id[RD_CAP_MAX];
    memcpy(id, rest, (size_t)(slash - rest));
    id[slash - rest] = 0;
    const char *what = slash + 1;
    struct rd_grades *g = r->srv->grades;
    unsigned char *copy = NULL;
    size_t len = 0;
    pthread_mutex_lock(&g->mu);
    for (int i = 0; i < GRADES_KEPT; i++) {
        grade_entry *e = &g->kept[i];
        if (!e->id[0] || !rd_cap_equal(e->id, id))
            continue;
        const unsigned char *src = strcmp(what, "diff.png") == 0        ? e->diff
                                   : strcmp(what, "reference.png") == 0 ? e->reference
                                   : strcmp(what, "image.png") == 0     ? e->image
                                                                        : NULL;
        len = strcmp(what, "diff.png") == 0        ? e->diff_len
              : strcmp(what, "reference.png") == 0 ? e->reference_len
                                                   : e->image_len;
        if (src && (copy = malloc(len)))
            memcpy(copy, src, len);
        break;
    }
    pthread_mutex_unlock(&g->mu);
    if (!copy && strcmp(what, "diff.png") == 0)
        copy = stored_diff(r, id, &len);
    if (!copy)
        return rd_reply_error(r, 404, "not_found", NULL,
                              "no such grade image (the last 256 grades' images are kept; a record keeps its diff)");
    /* A grade's images never change under its id; they stay while the
     * last GRADES_KEPT grades do, so an hour of caching is safe enough. */
    char tag[64];
    snprintf(tag, sizeof tag, "%s-%s", id, what);
    return rd_reply_immutable(r, "image/png", copy, len, 1, tag, 3600);
}

/* One assignment of the list: name, title, size, thresholds, scene address. */
static cJSON *assignment_json(const rd_assignment *a, int *f)
{
    cJSON *o = cJSON_CreateObject();
    rd_json_add(o, "name", cJSON_CreateString(a->name), f);
    rd_json_add(o, "title", cJSON_CreateString(a->title), f);
    if (a->error[0]) {
        rd_json_add(o, "error", cJSON_CreateString(a->error), f);
        return o;
    }
    rd_scene s;
    rd_scene_init(&s);
    rd_error e2 = {0};
    char name[80];
    snprintf(name, sizeof name, "%s.cfg", a->name);
    rd_error_code rc = rd_scene_load_file_named(a->scene_path, name, NULL, &s, &e2);
    int width = s.render.width, height = s.render.height;
    rd_scene_free(&s);
    /* A scene that does not parse cannot be graded: said as for a .grade. */
    if (rc) {
        rd_json_add(o, "error", cJSON_CreateString(e2.message), f);
        return o;
    }
    rd_json_add(o, "width", cJSON_CreateNumber(width), f);
    rd_json_add(o, "height", cJSON_CreateNumber(height), f);
    cJSON *t = rd_json_add(o, "thresholds", cJSON_CreateObject(), f);
    rd_json_add(t, "fail", cJSON_CreateNumber(a->thresholds.fail), f);
    rd_json_add(t, "fail_fraction", cJSON_CreateNumber(a->thresholds.fail_fraction), f);
    rd_json_add(t, "hard_fail", cJSON_CreateNumber(a->thresholds.hard_fail), f);
    rd_json_add(t, "hard_fail_pixels", cJSON_CreateNumber(a->thresholds.hard_fail_pixels), f);
    char url[200];
    snprintf(url, sizeof url, "/v1/assignments/%s/scene", a->name);
    rd_json_add(o, "scene_url", cJSON_CreateString(url), f);
    return o;
}

enum MHD_Result rd_route_assignments(rd_req *r, const char *rest)
{
    const char *name = *rest ? rest + 1 : NULL;
    if (name && *name) {
        char n[80];
        const char *slash = strchr(name, '/');
        size_t len = slash ? (size_t)(slash - name) : strlen(name);
        if (len >= sizeof n || (slash && strcmp(slash, "/scene") != 0))
            return rd_reply_error(r, 404, "not_found", NULL, "no such assignment");
        memcpy(n, name, len);
        n[len] = 0;
        rd_assignment a;
        rd_error err = {0};
        char *text;
        size_t tl;
        if (rd_assignment_load(r->srv->opt.assignments_dir, n, &a, &err) ||
            rd_read_file(a.scene_path, r->srv->opt.limits.max_bytes,
                         rd_limit_flag(offsetof(rd_scene_limits, max_bytes)), &text, &tl, &err))
            return rd_reply_error(r, 404, "not_found", NULL, "no such assignment");
        return rd_reply(r, 200, "text/x-rayd-cfg", text, tl, 1);
    }
    rd_assignment *list;
    size_t n;
    rd_error err = {0};
    rd_error_code rc = rd_assignment_list(r->srv->opt.assignments_dir, &list, &n, &err);
    if (rc == RD_ERR_NOMEM)
        return rd_reply_error(r, 503, "unavailable", &err, NULL);
    if (rc)
        return rd_reply_json(r, 200, strdup("{\"assignments\":[]}"));
    int f = 0;
    cJSON *root = cJSON_CreateObject();
    cJSON *arr = rd_json_add(root, "assignments", cJSON_CreateArray(), &f);
    for (size_t i = 0; arr && !f && i < n; i++)
        rd_json_add(arr, NULL, assignment_json(&list[i], &f), &f);
    free(list);
    char *text = f ? NULL : cJSON_PrintUnformatted(root);
    cJSON_Delete(root);
    if (!text)
        return rd_reply_error(r, 503, "unavailable", NULL, "out of memory");
    return rd_reply_json(r, 200, text);
}
