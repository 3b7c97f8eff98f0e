/* A student's calcReflectedLight graded on a render thread like any grade
 * (the sandbox, then two renders of the assignment): at most
 * --max-code-jobs at once, and at most --max-code-jobs-per-client of one
 * client, so that one client cannot hold every slot. The job's stop flag
 * (a hang-up, a DELETE) ends the sandbox. */
#include <cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "code_frames.h"
#include "code_lobe.h"
#include "grading_internal.h"
#include "rayd/clock.h"
#include "sandbox.h"

rd_error_code grading_code_init(rd_grading *g, rd_error *err)
{
    const rd_grading_options *o = &g->opt;
    g->code = rd_codegrade_config_default();
    g->code.grader = g->grader;
    g->code.bwrap = o->bwrap;
    g->code.course_dir = o->course_dir;
    g->code.eval = o->code_eval;
    g->code.max_bytes = o->max_code_bytes;
    g->code.compile_ms = o->code_compile_ms;
    g->code.run_ms = o->code_run_ms;
    g->code.uid = g->code.gid = (uid_t)o->sandbox_uid;
    g->max_total = o->max_code_jobs > 0 ? o->max_code_jobs : 1;
    g->max_client = o->max_code_jobs_per_client > 0 ? o->max_code_jobs_per_client : 1;
    g->holders = calloc((size_t)g->max_total, sizeof *g->holders);
    if (!g->holders)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    rd_error why = {0};
    g->sandbox_ok = rd_sandbox_probe(o->bwrap, &why) == RD_OK;
    if (!g->sandbox_ok) {
        snprintf(g->sandbox_why, sizeof g->sandbox_why, "%s", why.message);
        rd_log_msg(o->log, "warning", "code grading is off (POST /v1/grade/code answers 503): %s", g->sandbox_why);
    }
    return RD_OK;
}

void grading_code_free(rd_grading *g)
{
    for (size_t i = 0; i < LOBES_KEPT; i++)
        free(g->lobes[i].svg);
    free(g->holders);
}

const char *rd_grading_code_unavailable(const rd_grading *g) { return g->sandbox_ok ? NULL : g->sandbox_why; }

static void keep_lobe(rd_grading *g, const char *id, char *svg)
{
    pthread_mutex_lock(&g->code_mu);
    lobe_entry *e = &g->lobes[g->next_lobe++ % LOBES_KEPT];
    free(e->svg);
    snprintf(e->id, sizeof e->id, "%s", id);
    e->svg = svg;
    pthread_mutex_unlock(&g->code_mu);
}

rd_error_code rd_grading_lobe(rd_grading *g, const char *id, char **svg, rd_error *err)
{
    *svg = NULL;
    pthread_mutex_lock(&g->code_mu);
    for (size_t i = 0; i < LOBES_KEPT && !*svg; i++)
        if (g->lobes[i].svg && rd_cap_equal(g->lobes[i].id, id))
            *svg = strdup(g->lobes[i].svg);
    pthread_mutex_unlock(&g->code_mu);
    return *svg ? RD_OK : rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "no such code grade (or it is no longer kept)");
}

/* A slot for client: RD_OK, or RD_ERR_BUSY with *per_client saying whether
 * the client's own share is what is taken. */
static rd_error_code take_slot(rd_grading *g, const char *client, int *per_client, rd_error *err)
{
    pthread_mutex_lock(&g->code_mu);
    int mine = -1, unused = -1;
    for (int i = 0; i < g->max_total; i++)
        if (g->holders[i].n && strcmp(g->holders[i].client, client) == 0)
            mine = i;
        else if (!g->holders[i].n && unused < 0)
            unused = i;
    int full = g->active >= g->max_total;
    *per_client = !full && mine >= 0 && g->holders[mine].n >= g->max_client;
    if (!full && !*per_client) {
        if (mine < 0) {
            mine = unused; /* there is one: fewer clients than slots hold any */
            snprintf(g->holders[mine].client, sizeof g->holders[mine].client, "%s", client);
        }
        g->holders[mine].n++;
        g->active++;
    }
    pthread_mutex_unlock(&g->code_mu);
    if (*per_client)
        return rd_error_set(err, RD_ERR_BUSY, 0, 0,
                            "this client already has --max-code-jobs-per-client code grades running: try again once "
                            "one has ended");
    if (full)
        return rd_error_set(err, RD_ERR_BUSY, 0, 0,
                            "as many code grades as --max-code-jobs are running: try again in a few seconds");
    return RD_OK;
}

static void give_slot(rd_grading *g, const char *client)
{
    pthread_mutex_lock(&g->code_mu);
    for (int i = 0; i < g->max_total; i++)
        if (g->holders[i].n && strcmp(g->holders[i].client, client) == 0) {
            g->holders[i].n--;
            g->active--;
            break;
        }
    pthread_mutex_unlock(&g->code_mu);
}

typedef struct {
    rd_grading *g;
    unsigned char *code;
    size_t code_len;
    char filename[80], assignment[80], student[256];
    char client[64];        /* who holds the slot */
    long long submitted_ms; /* when the request came */
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
        give_slot(t->g, t->client);
    free(t->code);
    free(t->json);
    free(t->diff);
    rd_codegrade_result_free(&t->res);
    free(t);
}

static rd_error_code prepare(void *arg, rd_scene *s, int *render, rd_error *err)
{
    (void)s;
    code_task *t = arg;
    *render = 0;
    rd_codegrade_input in = {t->assignment, t->filename, (const char *)t->code, t->code_len};
    rd_codegrade_config cfg = t->g->code;
    cfg.cancel = t->stop;
    rd_error_code rc = rd_codegrade_run(&cfg, &in, &t->res, err);
    /* the job itself stays a while for its status: the slot goes now */
    give_slot(t->g, t->client);
    t->counted = 0;
    return rc;
}

/* The grade as its record's term sees it: code, with the share of its
 * configurations that are right (its partial credit). */
static grading_sub submission(const code_task *t)
{
    const rd_code_report *r = &t->res.report;
    double share = r->configurations ? (double)(r->configurations - r->failed) / (double)r->configurations : 0;
    return (grading_sub){.student = t->student, .submitted_ms = t->submitted_ms, .code = 1, .share = share};
}

/* The image's verdict as the grades keep it (with its id and addresses)
 * in place of the bare one; the record follows in finish. A grade whose
 * code made no image is recorded as an error, so that the instructors see
 * it too. */
static int add_ids(code_task *t, cJSON *root, rd_error *err)
{
    char *verdict = NULL;
    if (t->res.image_graded) {
        if (grading_keep(t->g, &t->res.grade, t->student, t->id, &verdict, &t->diff, &t->diff_len, err))
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
        grading_sub sub = submission(t);
        grading_error_record_sub(t->g, t->res.assignment, &sub,
                                 t->res.compile.result != 0 ? "the code did not compile" : "the code made no image",
                                 t->id);
    }
    char url[96];
    snprintf(url, sizeof url, "/v1/grade/code/%s/lobe.svg", t->id);
    char *svg = t->res.values ? rd_code_lobe_svg(t->res.cases, t->res.values, t->res.ncases) : NULL;
    if (svg)
        keep_lobe(t->g, t->id, svg);
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
                 t->g->code.compile_ms / 1000);
    else if (c->cause) { /* the student's reason, not the adapter's line */
        snprintf(msg, sizeof msg, "the code does not compile: %s", c->words);
        d = NULL;
    } else if (d)
        snprintf(msg, sizeof msg, "the code does not compile: %s:%d:%d: %s", d->file, d->line, d->column, d->message);
    else
        snprintf(msg, sizeof msg, "the code does not compile (see compile.messages)");
    cJSON *e = cJSON_AddObjectToObject(root, "error");
    return e &&
           cJSON_AddStringToObject(e, "code", c->result == RD_COMPILE_TIME_LIMIT ? "time_limit" : "compile_error") &&
           cJSON_AddStringToObject(e, "message", msg) &&
           (!d || (cJSON_AddNumberToObject(e, "line", d->line) && cJSON_AddNumberToObject(e, "column", d->column)));
}

static rd_error_code finish(void *arg, const uint8_t *rgb, int w, int h, rd_error *err)
{
    (void)rgb, (void)w, (void)h;
    code_task *t = arg;
    cJSON *root = rd_codegrade_json(&t->res);
    int ok = root && add_ids(t, root, err) && add_compile_error(t, root);
    t->json = ok ? cJSON_PrintUnformatted(root) : NULL;
    cJSON_Delete(root);
    /* the record's pass is the whole grade's, its verdict this answer */
    grading_sub sub = submission(t);
    if (t->json && t->res.image_graded)
        grading_record(t->g, &t->res.grade, t->id, &sub, t->res.pass, &t->json, t->diff, t->diff_len);
    return t->json ? RD_OK : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
}

/* Why code grading is off, for the answer. */
static rd_error_code off(const rd_grading *g, rd_error *err)
{
    return rd_error_set(err, RD_ERR_UNAVAILABLE, 0, 0,
                        "code grading is off on this server: its sandbox cannot start (%s)", g->sandbox_why);
}

rd_error_code rd_grading_code_task(rd_grading *g, rd_grading_code *in, rd_jq_task *task, rd_jq_submit_options *so,
                                   int *per_client, rd_error *err)
{
    *per_client = 0;
    code_task *t = NULL;
    rd_error_code rc = !g->sandbox_ok                ? off(g, err)
                       : !(t = calloc(1, sizeof *t)) ? rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory")
                                                     : take_slot(g, in->client ? in->client : "", per_client, err);
    if (rc) {
        free(t);
        free(in->code);
        in->code = NULL;
        return rc;
    }
    t->g = g;
    t->counted = 1;
    t->code = in->code;
    t->code_len = in->code_len;
    in->code = NULL;
    snprintf(t->client, sizeof t->client, "%s", in->client ? in->client : "");
    t->submitted_ms = rd_wall_ms();
    snprintf(t->filename, sizeof t->filename, "%s", in->filename ? in->filename : "");
    snprintf(t->assignment, sizeof t->assignment, "%s", in->assignment ? in->assignment : "");
    snprintf(t->student, sizeof t->student, "%s", in->student ? in->student : "");
    *task = (rd_jq_task){prepare, finish, free_task, t, t->code_len, &t->stop};
    /* internal: freed with the request, so a grade cancelled before it
     * started gives its slot back at once rather than when a kept job
     * would expire; what the sandbox may hold is reserved before it
     * starts */
    so->internal = 1;
    so->renders_nothing = 1;
    so->prepare_bytes = rd_codegrade_memory_bytes(&g->code, t->code_len);
    return RD_OK;
}

rd_grading_answer rd_grading_code_answer(void *task_arg)
{
    code_task *t = task_arg;
    rd_grading_answer a = {t->json, t->status, t->res.pass, t->res.grade.stage};
    t->json = NULL;
    return a;
}
