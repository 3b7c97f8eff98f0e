/* POST /v1/grade/code (a student's calcReflectedLight, codegrade.h),
 * GET /v1/grade/code/skeleton/{material}, GET /v1/grade/code/{id}/lobe.svg.
 * A code grade runs on a render thread like any grade (the sandbox, then
 * two renders of the assignment); at most --max-code-jobs at once, the
 * rest answered 503 with Retry-After, and at most
 * --max-code-jobs-per-client of one client, so that one client cannot
 * hold every slot. A client that hangs up cancels its grade: the queue's
 * watchdog sees it, and the job's stop flag ends the sandbox. */
#include <cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "code_frames.h"
#include "code_lobe.h"
#include "codegrade.h"
#include "error_map.h"
#include "http_internal.h"
#include "json_text.h"
#include "log.h"
#include "metrics.h"
#include "sandbox.h"

enum { LOBES_KEPT = 128, DISCARD_MAX = 1 << 20 };

typedef struct {
    char id[RD_CAP_MAX];
    char *svg;
} lobe_entry;

struct rd_codegrades {
    rd_codegrade_config cfg; /* the grader's cache is the grades' */
    int available;           /* the sandbox started at start-up */
    char why[512];           /* else why not */
    pthread_mutex_t mu;
    lobe_entry lobes[LOBES_KEPT];
    size_t next;
    /* The slots, under mu: active of max_total taken, by clients holding
     * n each (max_total entries, as no more clients can hold one). */
    int active, max_total, max_client;
    struct {
        char client[64];
        int n;
    } * holders;
};

struct rd_codegrades *rd_codegrades_new(const rd_server_options *opt, const rd_grader *grader)
{
    struct rd_codegrades *c = calloc(1, sizeof *c);
    if (!c)
        return NULL;
    c->cfg = rd_codegrade_config_default();
    c->cfg.grader = *grader;
    c->cfg.bwrap = opt->bwrap;
    c->cfg.course_dir = opt->course_dir;
    c->cfg.eval = opt->code_eval;
    c->cfg.max_bytes = opt->max_code_bytes;
    c->cfg.compile_ms = opt->code_compile_ms;
    c->cfg.run_ms = opt->code_run_ms;
    c->cfg.uid = c->cfg.gid = (uid_t)opt->sandbox_uid;
    c->max_total = opt->max_code_jobs > 0 ? opt->max_code_jobs : 1;
    c->max_client = opt->max_code_jobs_per_client > 0 ? opt->max_code_jobs_per_client : 1;
    c->holders = calloc((size_t)c->max_total, sizeof *c->holders);
    if (!c->holders) {
        free(c);
        return NULL;
    }
    pthread_mutex_init(&c->mu, NULL);
    rd_error err = {0};
    c->available = rd_sandbox_probe(opt->bwrap, &err) == RD_OK;
    if (!c->available) {
        snprintf(c->why, sizeof c->why, "%s", err.message);
        rd_log_msg(opt->log, "warning", "code grading is off (POST /v1/grade/code answers 503): %s", c->why);
    }
    return c;
}

void rd_codegrades_free(struct rd_codegrades *c)
{
    if (!c)
        return;
    for (size_t i = 0; i < LOBES_KEPT; i++)
        free(c->lobes[i].svg);
    pthread_mutex_destroy(&c->mu);
    free(c->holders);
    free(c);
}

const char *rd_codegrades_unavailable(const struct rd_codegrades *c) { return c->available ? NULL : c->why; }

static void keep_lobe(struct rd_codegrades *c, const char *id, char *svg)
{
    pthread_mutex_lock(&c->mu);
    lobe_entry *e = &c->lobes[c->next++ % LOBES_KEPT];
    free(e->svg);
    snprintf(e->id, sizeof e->id, "%s", id);
    e->svg = svg;
    pthread_mutex_unlock(&c->mu);
}

/* The form as it arrives: the assignment, the student, the file. */
typedef struct {
    rd_form form;
    unsigned char *code;
    size_t code_len;
    char filename[80];
    char assignment[80];
    char student[256];
} code_form;

static void free_form(rd_req *r)
{
    code_form *f = r->state;
    if (!f)
        return;
    rd_form_end(&f->form);
    free(f->code);
    free(f);
    r->state = NULL;
}

static enum MHD_Result on_field(void *cls, enum MHD_ValueKind kind, const char *key, const char *filename,
                                const char *content_type, const char *encoding, const char *data, uint64_t off,
                                size_t size)
{
    (void)kind, (void)content_type, (void)encoding;
    rd_req *r = cls;
    code_form *f = r->state;
    if (!key) {
        f->form.bad = "a form part has no field name (Content-Disposition: form-data; name=\"...\")";
        return MHD_NO;
    }
    if (size && !data)
        return MHD_YES;
    if (strcmp(key, "source") == 0 || strcmp(key, "code") == 0) {
        if (off == 0 && f->code_len) {
            f->form.bad = "the form has more than one 'source' file";
            return MHD_NO;
        }
        if (off == 0 &&
            !rd_form_text(f->filename, sizeof f->filename, filename ? filename : "", filename ? strlen(filename) : 0)) {
            f->form.bad = "the 'source' file's name is longer than a file name can be";
            return MHD_NO;
        }
        if (f->code_len + size > r->srv->codegrades->cfg.max_bytes) {
            f->form.too_big = "--max-code-bytes";
            return MHD_NO;
        }
        return rd_form_append(&f->code, &f->code_len, data, size) ? MHD_YES : MHD_NO;
    }
    char *dst = strcmp(key, "assignment") == 0 ? f->assignment : strcmp(key, "student") == 0 ? f->student : NULL;
    size_t cap = dst == f->assignment ? sizeof f->assignment : sizeof f->student;
    if (dst && !rd_form_text(dst, cap, data, size)) {
        f->form.bad = "a form field ('assignment' or 'student') is longer than such a name can be";
        return MHD_NO;
    }
    return MHD_YES; /* other fields are ignored */
}

enum MHD_Result rd_route_code_begin(rd_req *r)
{
    rd_form_spec spec = {sizeof(code_form),
                         r->srv->codegrades->cfg.max_bytes + 64 * 1024,
                         "the form (the code may have --max-code-bytes)",
                         "send multipart/form-data with 'assignment' and a 'source' file",
                         on_field,
                         free_form};
    return rd_form_begin(r, &spec);
}

enum MHD_Result rd_route_code_data(rd_req *r, const char *data, size_t size)
{
    return rd_form_data(r, data, size, r->srv->codegrades->cfg.max_bytes + DISCARD_MAX);
}

/* One code grade on a render thread. */
/* A slot for client: 0, or the status to answer (503 every slot taken,
 * 429 the client's own share taken). */
static unsigned take_slot(struct rd_codegrades *c, const char *client)
{
    pthread_mutex_lock(&c->mu);
    int mine = -1, unused = -1;
    for (int i = 0; i < c->max_total; i++)
        if (c->holders[i].n && strcmp(c->holders[i].client, client) == 0)
            mine = i;
        else if (!c->holders[i].n && unused < 0)
            unused = i;
    unsigned refused = c->active >= c->max_total ? 503 : mine >= 0 && c->holders[mine].n >= c->max_client ? 429 : 0;
    if (!refused) {
        if (mine < 0) {
            mine = unused; /* there is one: fewer clients than slots hold any */
            snprintf(c->holders[mine].client, sizeof c->holders[mine].client, "%s", client);
        }
        c->holders[mine].n++;
        c->active++;
    }
    pthread_mutex_unlock(&c->mu);
    return refused;
}

static void give_slot(struct rd_codegrades *c, const char *client)
{
    pthread_mutex_lock(&c->mu);
    for (int i = 0; i < c->max_total; i++)
        if (c->holders[i].n && strcmp(c->holders[i].client, client) == 0) {
            c->holders[i].n--;
            c->active--;
            break;
        }
    pthread_mutex_unlock(&c->mu);
}

typedef struct {
    rd_server *srv;
    unsigned char *code;
    size_t code_len;
    char filename[80], assignment[80], student[256];
    char client[64];        /* who holds the slot */
    const atomic_int *stop; /* the job's: a hang-up or DELETE ends the sandbox */
    rd_codegrade_result res;
    int counted;         /* holds a slot until its sandbox has run */
    unsigned status;     /* of the answer: 200, or 422 when it did not compile */
    char *json;          /* the answer */
    char id[RD_CAP_MAX]; /* the image's grade, once kept */
    unsigned char *diff; /* its heat map for the record */
    size_t diff_len;
} code_task;

static void free_task(void *arg)
{
    code_task *t = arg;
    if (!t)
        return;
    if (t->counted)
        give_slot(t->srv->codegrades, t->client);
    free(t->code);
    free(t->json);
    free(t->diff);
    rd_codegrade_result_free(&t->res);
    free(t);
}

static rd_error_code prepare_code(void *arg, rd_scene *s, int *render, rd_error *err)
{
    (void)s;
    code_task *t = arg;
    *render = 0;
    rd_codegrade_input in = {t->assignment, t->filename, (const char *)t->code, t->code_len};
    rd_codegrade_config cfg = t->srv->codegrades->cfg;
    cfg.cancel = t->stop;
    rd_error_code rc = rd_codegrade_run(&cfg, &in, &t->res, err);
    /* the job itself stays a while for its status: the slot goes now */
    give_slot(t->srv->codegrades, t->client);
    t->counted = 0;
    return rc;
}

/* The image's verdict as the grades keep it (with its id and addresses)
 * in place of the bare one; the record follows in finish_code. A grade
 * whose code made no image is recorded as an error, so that the
 * instructors see it too. */
static int add_ids(code_task *t, cJSON *root, rd_error *err)
{
    char *verdict = NULL;
    if (t->res.image_graded) {
        if (rd_grades_keep(t->srv, &t->res.grade, t->student, t->id, &verdict, &t->diff, &t->diff_len, err))
            return 0;
        cJSON *v = cJSON_Parse(verdict);
        free(verdict);
        cJSON *diff = cJSON_GetObjectItem(v, "diff_url");
        if (!v || !cJSON_ReplaceItemInObject(root, "image", v)) {
            cJSON_Delete(v);
            return 0;
        }
        /* the heat map's address beside the lobe's, as for an image's grade */
        if (!cJSON_AddStringToObject(root, "diff_url", cJSON_IsString(diff) ? diff->valuestring : ""))
            return 0;
    } else {
        if (!cJSON_AddNullToObject(root, "diff_url"))
            return 0;
        rd_grades_error_record(t->srv, t->res.assignment, t->student, NULL,
                               t->res.compile.result != 0 ? "the code did not compile" : "the code made no image",
                               t->id);
    }
    char url[96];
    snprintf(url, sizeof url, "/v1/grade/code/%s/lobe.svg", t->id);
    char *svg = t->res.values ? rd_code_lobe_svg(t->res.cases, t->res.values, t->res.ncases) : NULL;
    if (svg)
        keep_lobe(t->srv->codegrades, t->id, svg);
    return cJSON_AddStringToObject(root, "id", t->id) &&
           (!*t->student || cJSON_AddStringToObject(root, "student", t->student)) &&
           (svg ? cJSON_AddStringToObject(root, "lobe_url", url) : cJSON_AddNullToObject(root, "lobe_url"));
}

/* Code that does not compile is 422 with the grade's body and an error
 * naming the first of the compiler's errors. */
static int add_compile_error(code_task *t, cJSON *root)
{
    const rd_code_compile *c = &t->res.compile;
    t->status = c->result == 0 ? 200 : 422;
    if (t->status == 200)
        return 1;
    char msg[700];
    const rd_code_diag *d = NULL;
    for (int i = 0; i < c->ndiags && !d; i++)
        if (strstr(c->diags[i].severity, "error"))
            d = &c->diags[i];
    if (c->result == RD_COMPILE_TIME_LIMIT)
        snprintf(msg, sizeof msg, "the compiler ran past --code-compile-seconds (%.0f s)",
                 t->srv->codegrades->cfg.compile_ms / 1000);
    else if (d)
        snprintf(msg, sizeof msg, "the code does not compile: %s:%d:%d: %s", d->file, d->line, d->column, d->message);
    else
        snprintf(msg, sizeof msg, "the code does not compile (see compile.messages)");
    cJSON *e = cJSON_AddObjectToObject(root, "error");
    return e &&
           cJSON_AddStringToObject(e, "code", c->result == RD_COMPILE_TIME_LIMIT ? "time_limit" : "compile_error") &&
           cJSON_AddStringToObject(e, "message", msg) &&
           (!d || (cJSON_AddNumberToObject(e, "line", d->line) && cJSON_AddNumberToObject(e, "column", d->column)));
}

static rd_error_code finish_code(void *arg, const uint8_t *rgb, int w, int h, rd_error *err)
{
    (void)rgb, (void)w, (void)h;
    code_task *t = arg;
    cJSON *root = rd_codegrade_json(&t->res);
    int ok = root && add_ids(t, root, err) && add_compile_error(t, root);
    t->json = ok ? cJSON_PrintUnformatted(root) : NULL;
    cJSON_Delete(root);
    /* the record's pass is the whole grade's, its verdict this answer */
    if (t->json && t->res.image_graded)
        rd_grades_record(t->srv, &t->res.grade, t->id, t->student, NULL, t->res.pass, t->json, t->diff, t->diff_len);
    return t->json ? RD_OK : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
}

static enum MHD_Result submit(rd_req *r, code_form *f)
{
    struct rd_codegrades *c = r->srv->codegrades;
    code_task *t = calloc(1, sizeof *t);
    if (!t)
        return rd_reply_error(r, 503, "unavailable", NULL, "out of memory");
    snprintf(t->client, sizeof t->client, "%s", r->client);
    unsigned refused = take_slot(c, t->client);
    if (refused) {
        free(t);
        return refused == 429 ? rd_reply_error_hdr(r, 429, "too_many_requests",
                                                   "this client already has --max-code-jobs-per-client code grades "
                                                   "running: try again once one has ended",
                                                   "Retry-After", "5")
                              : rd_reply_error_hdr(r, 503, "queue_full",
                                                   "as many code grades as --max-code-jobs are running: try again "
                                                   "in a few seconds",
                                                   "Retry-After", "5");
    }
    t->srv = r->srv;
    t->counted = 1;
    t->code = f->code;
    t->code_len = f->code_len;
    f->code = NULL;
    memcpy(t->filename, f->filename, sizeof t->filename);
    memcpy(t->assignment, f->assignment, sizeof t->assignment);
    memcpy(t->student, f->student, sizeof t->student);
    rd_jq_task task = {prepare_code, finish_code, free_task, t, t->code_len, &t->stop};
    /* internal: freed with the request, so a grade cancelled before it
     * started gives its slot back at once rather than when a kept job
     * would expire */
    /* what the sandbox may hold is reserved before it starts */
    rd_jq_submit_options so = {
        .internal = 1, .renders_nothing = 1, .prepare_bytes = rd_codegrade_memory_bytes(&c->cfg, t->code_len)};
    return rd_req_submit(r, &task, &so);
}

enum MHD_Result rd_route_code(rd_req *r, const char *rest)
{
    (void)rest;
    code_form *f = r->state;
    const char *why = rd_codegrades_unavailable(r->srv->codegrades);
    if (!f)
        return rd_reply_error(r, 400, "parse_error", NULL, "no form");
    if (f->form.too_big)
        return rd_reply_too_large(r, "the 'source' file (--max-code-bytes)");
    if (f->form.bad)
        return rd_reply_error(r, 400, "parse_error", NULL, f->form.bad);
    if (atomic_load(&r->srv->draining))
        return rd_reply_draining(r);
    if (why) {
        char msg[700];
        snprintf(msg, sizeof msg, "code grading is off on this server: its sandbox cannot start (%s)", why);
        return rd_reply_error_hdr(r, 503, "sandbox_unavailable", msg, "Retry-After", "3600");
    }
    if (!f->code_len)
        return rd_reply_error(r, 400, "parse_error", NULL, "the form has no 'source' file (the student's .h or .cpp)");
    if (!f->assignment[0])
        return rd_reply_error(r, 400, "parse_error", NULL, "the form has no 'assignment'");
    return submit(r, f);
}

enum MHD_Result rd_route_code_resumed(rd_req *r)
{
    rd_jq_info info;
    rd_jq_info_get(r->srv->jobs, r->job, &info);
    code_task *t = rd_jq_task_arg(r->job);
    if (info.status == RD_JQ_DONE && t->json) {
        char *json = t->json;
        t->json = NULL;
        rd_metrics_code_grade(r->srv, t->res.pass ? RD_VERDICT_PASS : RD_VERDICT_FAIL);
        return rd_reply_json(r, t->status, json);
    }
    if (info.status == RD_JQ_FAILED) {
        rd_error_answer a = rd_code_error_answer(t->res.grade.stage, info.error.code);
        rd_metrics_code_grade(r->srv, RD_VERDICT_ERROR);
        return rd_reply_error(r, a.http, a.code, &info.error, NULL);
    }
    return rd_reply_cancelled(r, &info, "grade");
}

static enum MHD_Result skeleton(rd_req *r, const char *material)
{
    char *text = NULL;
    size_t len = 0;
    rd_error err = {0};
    rd_error_code rc = rd_codegrade_skeleton(r->srv->codegrades->cfg.course_dir, material, &text, &len, &err);
    if (rc == RD_ERR_NOT_FOUND)
        return rd_reply_error(r, 404, "not_found", &err, NULL);
    if (rc)
        return rd_reply_error(r, 503, "unavailable", NULL, "the course's files cannot be read on this server");
    return rd_reply(r, 200, "text/x-c++hdr; charset=utf-8", text, len, 1);
}

static enum MHD_Result lobe(rd_req *r, const char *id)
{
    struct rd_codegrades *c = r->srv->codegrades;
    char *copy = NULL;
    pthread_mutex_lock(&c->mu);
    for (size_t i = 0; i < LOBES_KEPT && !copy; i++)
        if (c->lobes[i].svg && rd_cap_equal(c->lobes[i].id, id))
            copy = strdup(c->lobes[i].svg);
    pthread_mutex_unlock(&c->mu);
    if (!copy)
        return rd_reply_error(r, 404, "not_found", NULL, "no such code grade (or it is no longer kept)");
    return rd_reply(r, 200, "image/svg+xml", copy, strlen(copy), 1);
}

/* rest: "/skeleton/{material}" or "/{id}/lobe.svg" */
enum MHD_Result rd_route_code_get(rd_req *r, const char *rest)
{
    char a[80], b[8];
    if (sscanf(rest, "/skeleton/%63[a-z_]%1s", a, b) == 1)
        return skeleton(r, a);
    size_t n = strlen(rest);
    if (n > 10 && n < 10 + RD_CAP_MAX && strcmp(rest + n - 9, "/lobe.svg") == 0) {
        snprintf(a, sizeof a, "%.*s", (int)(n - 10), rest + 1);
        if (rd_cap_valid(a, 'g'))
            return lobe(r, a);
    }
    return rd_reply_error(r, 404, "not_found", NULL,
                          "no such resource: GET /v1/grade/code/skeleton/{material} or /v1/grade/code/{id}/lobe.svg");
}
