#include <cJSON.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "http_internal.h"
#include "job_status.h"
#include "scene_open.h"

/* An uploaded scene, parsed and given its assets on a render thread: for
 * POST /v1/render by the queue, which renders it; for POST /v1/jobs by the
 * farm, which commits it (farm set). */
typedef struct {
    char *body;
    size_t len;
    rd_scene_format fmt;
    rd_job_params params;
    const rd_server_options *opt;
    rd_farm *farm;
    char id[RD_STORE_ID_MAX]; /* the stored job's, once committed */
    char *committed;          /* its 202's JSON */
} render_task;

static rd_error_code prepare_render(void *arg, rd_scene *s, int *render, rd_error *err)
{
    (void)render;
    render_task *t = arg;
    rd_scene_source src = {
        .text = t->body, .len = t->len, .source = "<upload>", .format = t->fmt, .assets_dir = t->opt->scenes_dir};
    rd_error_code rc = rd_scene_open(&src, &t->params.ov, &t->opt->limits, s, NULL, err);
    free(t->body);
    t->body = NULL;
    return rc;
}

static rd_error_code prepare_submit(void *arg, rd_scene *s, int *render, rd_error *err)
{
    (void)s;
    render_task *t = arg;
    *render = 0;
    rd_error_code rc = rd_farm_submit(t->farm, t->body, t->len, t->fmt, &t->params, t->id, &t->committed, err);
    free(t->body);
    t->body = NULL;
    return rc;
}

static void free_render(void *arg)
{
    render_task *t = arg;
    if (t) {
        free(t->body);
        free(t->committed);
        free(t);
    }
}

/* Whether the Accept header names image/x-exr (q-values are not weighed:
 * naming it asks for it). */
static int accepts_exr(struct MHD_Connection *c)
{
    int named;
    rd_accept_quality(MHD_lookup_connection_value(c, MHD_HEADER_KIND, MHD_HTTP_HEADER_ACCEPT), "image/x-exr", &named);
    return named;
}

/* The query's parameters (http-api.md), read on the HTTP thread (each
 * with its own range) and applied once the scene is parsed; Accept:
 * image/x-exr asks for the EXR as hdr=1 does. 0, or fills err
 * (RD_ERR_SYNTAX) naming the parameter. */
static int read_params(struct MHD_Connection *c, rd_job_params *p, rd_error *err)
{
    rd_job_params_init(p);
    for (int i = 0; rd_job_param_name(i); i++) {
        const char *name = rd_job_param_name(i);
        const char *v = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, name);
        if (v && rd_job_params_set(p, name, v, err))
            return 1;
    }
    if (accepts_exr(c) && !p->hdr && rd_job_params_set(p, "hdr", "1", err))
        return 1;
    return 0;
}

/* A job in memory as GET /v1/jobs/{id} gives it: the view a stored job
 * has too (job_status.h). */
static char *job_json(const rd_jq_info *in)
{
    rd_job_status s = {.id = in->id,
                       .status = in->status,
                       .progress = in->progress,
                       .elapsed_ms = in->elapsed_ms,
                       .queued_ms = in->queued_ms,
                       .width = in->width,
                       .height = in->height,
                       .stats = in->stats};
    /* While it runs, the samples per pixel of the passes done as the queue
     * counts them; once done, the rounded mean (rd_jq_info_get). */
    s.stats.samples = in->samples;
    if (in->status == RD_JQ_FAILED) {
        s.error_code = rd_error_answer_for(in->error.code).code;
        s.error_message = in->error.message;
    }
    return rd_job_status_json(&s);
}

/* Scene types we read; other families are refused with 415 (a PNG or a
 * form posted to /v1/render by mistake), anything else is sniffed. */
static int refused_type(const char *ct)
{
    static const char *const families[] = {"image/",           "audio/",     "video/",          "font/",
                                           "model/",           "multipart/", "application/pdf", "application/zip",
                                           "application/gzip", NULL};
    if (!ct)
        return 0;
    for (int i = 0; families[i]; i++)
        if (strncasecmp(ct, families[i], strlen(families[i])) == 0)
            return 1;
    return 0;
}

/* Before the body of either: refuse what would be thrown away once read. */
static enum MHD_Result scene_begin(rd_req *r)
{
    rd_server *srv = r->srv;
    if (atomic_load(&srv->draining))
        return rd_reply_draining(r);
    const char *ct = MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_CONTENT_TYPE);
    if (refused_type(ct))
        return rd_reply_error(r, 415, "unsupported_media_type", NULL,
                              "send a scene as application/json, text/plain or text/x-rayd-cfg");
    const char *cl = MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_CONTENT_LENGTH);
    if (cl && strtoull(cl, NULL, 10) > srv->opt.max_body_bytes)
        return rd_reply_too_large(r, "the body");
    return MHD_YES;
}

/* POST /v1/render renders here: this daemon's queue bounds it (with the
 * stored jobs it has taken up). A stored job's queue is the store's, which
 * the farm checks as it commits. */
enum MHD_Result rd_render_begin(rd_req *r)
{
    rd_jq_metrics m;
    rd_jq_metrics_get(r->srv->jobs, &m);
    if (m.queued + m.running + m.external_jobs >= r->srv->opt.jobs.queue_length)
        return rd_reply_error_hdr(r, 503, "queue_full", "the render queue is full; try again shortly", "Retry-After",
                                  "1");
    return scene_begin(r);
}

enum MHD_Result rd_jobs_begin(rd_req *r) { return scene_begin(r); }

static enum MHD_Result render(rd_req *r, int async)
{
    rd_server *srv = r->srv;
    if (atomic_load(&srv->draining))
        return rd_reply_draining(r);
    if (!r->body || r->len == 0)
        return rd_reply_error(r, 400, "parse_error", NULL, "the request has no scene in its body");
    const char *ct = MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_CONTENT_TYPE);
    rd_error err = {0};
    rd_jq_submit_options so = {.watch_fd = -1};
    render_task *t = calloc(1, sizeof *t);
    if (!t)
        return rd_reply_error(r, 503, "unavailable", NULL, "out of memory");
    t->fmt = RD_FMT_AUTO;
    if (ct && strncasecmp(ct, "application/json", 16) == 0)
        t->fmt = RD_FMT_JSON;
    else if (ct && (strncasecmp(ct, "text/plain", 10) == 0 || strncasecmp(ct, "text/x-rayd-cfg", 15) == 0))
        t->fmt = RD_FMT_CFG;
    t->opt = &srv->opt;
    if (read_params(r->conn, &t->params, &err)) {
        free(t);
        return rd_reply_error(r, 400, "parse_error", &err, NULL);
    }
    so.progress = t->params.progress;
    so.hdr = t->params.hdr;
    t->body = r->body;
    t->len = r->len;
    r->body = NULL;
    /* Both wait on the connection: an asynchronous submission until its
     * scene is read and the job committed (so a bad one still gets its 4xx,
     * and 202 means it survives a crash), a synchronous one until its image
     * is ready. */
    if (async && !(t->farm = rd_server_farm(srv))) {
        free(t->body);
        free(t);
        return rd_reply_error_hdr(r, 503, "starting", "the server is starting", "Retry-After", "1");
    }
    so.internal = async;
    so.renders_nothing = async;
    rd_jq_task task = {async ? prepare_submit : prepare_render, NULL, free_render, t, t->len, NULL};
    return rd_req_submit(r, &task, &so);
}

static enum MHD_Result reply_ended(rd_req *r, const rd_jq_info *info);
/* The answer to POST /v1/jobs once its scene is read: 202 with the job as
 * committed, or why it was not. */
enum MHD_Result rd_route_jobs_resumed(rd_req *r)
{
    rd_jq_info info;
    rd_jq_info_get(r->srv->jobs, r->job, &info);
    render_task *t = rd_jq_task_arg(r->job);
    if (info.status == RD_JQ_CANCELLED)
        return reply_ended(r, &info);
    if (info.status != RD_JQ_DONE || !t->committed)
        return rd_reply_failed(r, &info.error);
    char loc[16 + RD_STORE_ID_MAX];
    snprintf(loc, sizeof loc, "/v1/jobs/%s", t->id);
    snprintf(r->job_id, sizeof r->job_id, "%s", t->id);
    const char *headers[] = {MHD_HTTP_HEADER_LOCATION, loc, NULL};
    char *text = t->committed;
    t->committed = NULL;
    return rd_reply_with(r, 202, "application/json", text, strlen(text), 1, headers);
}

/* The answer for a job that failed or was cancelled. */
static enum MHD_Result reply_ended(rd_req *r, const rd_jq_info *info)
{
    if (info->status == RD_JQ_FAILED) {
        rd_error_code c = info->error.code;
        if (c == RD_ERR_TIMEOUT)
            return rd_reply_error(r, 422, "time_limit", &info->error, NULL);
        return rd_reply_error(r, rd_error_answer_for(c).http, rd_error_answer_for(c).code, &info->error, NULL);
    }
    return rd_reply_cancelled(r, info, "render");
}

enum MHD_Result rd_route_render_resumed(rd_req *r)
{
    rd_server *srv = r->srv;
    rd_jq_info info;
    rd_jq_info_get(srv->jobs, r->job, &info);
    if (info.status == RD_JQ_FAILED || info.status == RD_JQ_CANCELLED)
        return reply_ended(r, &info);
    if (info.status != RD_JQ_DONE)
        return rd_reply_error(r, 503, "unavailable", NULL, "the render ended without an image");
    unsigned char *png;
    size_t len;
    rd_error err = {0};
    int exr = accepts_exr(r->conn);
    rd_error_code rc =
        exr ? rd_jq_exr(srv->jobs, r->job, &png, &len, &err) : rd_jq_png(srv->jobs, r->job, 0, &png, &len, &err);
    if (rc)
        return rd_reply_error(r, 503, "unavailable", &err, NULL);
    rd_jq_release_png(srv->jobs, r->job);
    /* The figures of its status (GET /v1/jobs/{X-Rayd-Job}) under the
     * spec's header names: X-Rayd-Render-Ms is its elapsed_ms, the others
     * are named as its keys are. */
    char ms[32], spp[32], est[32], passes[32];
    snprintf(ms, sizeof ms, "%.3f", info.elapsed_ms);
    snprintf(spp, sizeof spp, "%d", info.samples);
    snprintf(est, sizeof est, "%.6f", info.error_estimate);
    snprintf(passes, sizeof passes, "%d", info.passes);
    const char *headers[] = {"X-Rayd-Render-Ms",
                             ms,
                             "X-Rayd-Samples",
                             spp,
                             "X-Rayd-Error-Estimate",
                             est,
                             "X-Rayd-Stopped-By",
                             rd_stop_reason_name(info.stopped_by),
                             "X-Rayd-Passes",
                             passes,
                             NULL};
    return rd_reply_with(r, 200, exr ? "image/x-exr" : "image/png", png, len, 1, headers);
}

/* A running job's image so far, encoded on a render thread. */
typedef struct {
    rd_jq *q;
    rd_jq_job *target; /* held by the snapshot's job (rd_jq_submit_options.hold) */
    rd_farm *farm;     /* or a stored job's, by id */
    char id[RD_STORE_ID_MAX];
    unsigned char *png;
    size_t len;
} partial_task;

static rd_error_code prepare_partial(void *arg, rd_scene *s, int *render, rd_error *err)
{
    (void)s;
    partial_task *t = arg;
    *render = 0;
    if (t->farm)
        return rd_farm_partial_png(t->farm, t->id, &t->png, &t->len, err);
    return rd_jq_png(t->q, t->target, 1, &t->png, &t->len, err);
}

static void free_partial(void *arg)
{
    partial_task *t = arg;
    if (t) {
        free(t->png);
        free(t);
    }
}

/* Takes over the caller's reference to job; job NULL: the stored job id. */
static enum MHD_Result submit_partial(rd_req *r, rd_jq_job *job, const char *id)
{
    rd_server *srv = r->srv;
    partial_task *t = calloc(1, sizeof *t);
    if (!t) {
        if (job)
            rd_jq_job_unref(job);
        return rd_reply_error(r, 503, "unavailable", NULL, "out of memory");
    }
    t->q = srv->jobs;
    t->target = job;
    if (!job) {
        t->farm = rd_server_farm(srv);
        snprintf(t->id, sizeof t->id, "%s", id);
    }
    rd_jq_task task = {prepare_partial, NULL, free_partial, t, 0, NULL};
    rd_jq_submit_options so = {.watch_fd = rd_req_socket(r),
                               .watch_http11 = r->http11,
                               .done = rd_req_on_done,
                               .user = r,
                               .internal = 1,
                               .renders_nothing = 1,
                               .hold = job};
    rd_jq_job *snap;
    rd_error err = {0};
    rd_error_code rc = rd_jq_submit(srv->jobs, &task, &so, &snap, &err);
    if (rc == RD_ERR_BUSY)
        return rd_reply_error_hdr(r, 503, "queue_full", err.message, "Retry-After", "1");
    if (rc)
        return rd_reply_error(r, 503, "unavailable", &err, NULL);
    return rd_req_wait(r, snap) ? rd_route_job_image_resumed(r) : MHD_YES;
}

enum MHD_Result rd_route_job_image_resumed(rd_req *r)
{
    rd_jq_info info;
    rd_jq_info_get(r->srv->jobs, r->job, &info);
    partial_task *t = rd_jq_task_arg(r->job);
    if (info.status == RD_JQ_DONE && t->png) {
        unsigned char *png = t->png;
        t->png = NULL;
        static const char *const no_store[] = {MHD_HTTP_HEADER_CACHE_CONTROL, "no-store", NULL};
        return rd_reply_with(r, 200, "image/png", png, t->len, 1, no_store);
    }
    if (info.status == RD_JQ_FAILED && rd_error_answer_for(info.error.code).http >= 500)
        return rd_reply_failed(r, &info.error);
    if (info.status == RD_JQ_FAILED)
        return rd_reply_error(r, 409, "not_ready", &info.error, NULL);
    return rd_reply_cancelled(r, &info, "render");
}

enum MHD_Result rd_route_render_sync(rd_req *r, const char *rest)
{
    (void)rest;
    return render(r, 0);
}

enum MHD_Result rd_route_jobs_post(rd_req *r, const char *rest)
{
    (void)rest;
    return render(r, 1);
}

/* Why a job has no image to give. */
static enum MHD_Result no_image(rd_req *r, rd_jq_job *job, const rd_error *err)
{
    rd_jq_info info;
    rd_jq_info_get(r->srv->jobs, job, &info);
    if (info.status == RD_JQ_DONE)
        return rd_reply_error(r, 404, "expired", err, NULL);
    if (info.status == RD_JQ_QUEUED || info.status == RD_JQ_RUNNING)
        return rd_reply_error(r, 409, "not_ready", err, NULL);
    return rd_reply_error(r, 409, "no_image", err, NULL);
}

/* GET /v1/jobs/{id}/image with Accept: image/x-exr: only a job submitted
 * with hdr kept one (encoding an EXR for every job would cost every
 * client for what few ask for). */
static enum MHD_Result reply_job_exr(rd_req *r, rd_jq_job *job)
{
    rd_jq_info info;
    rd_jq_info_get(r->srv->jobs, job, &info);
    if (!info.hdr)
        return rd_reply_error(r, 406, "not_acceptable", NULL,
                              "this job keeps no EXR: submit it with POST /v1/jobs?hdr=1 to get its image as "
                              "image/x-exr");
    unsigned char *exr;
    size_t len;
    rd_error err = {0};
    if (rd_jq_exr(r->srv->jobs, job, &exr, &len, &err))
        return no_image(r, job, &err);
    char tag[40];
    snprintf(tag, sizeof tag, "%s.exr", info.id);
    return rd_reply_immutable(r, "image/x-exr", exr, len, 1, tag, r->srv->opt.jobs.result_ttl_ms / 1e3);
}

static const char no_job[] = "no job with that id (finished jobs expire, see --result-ttl)";

/* The store's answer for a stored job, saying what expires one it lacks. */
static enum MHD_Result stored_failed(rd_req *r, const rd_error *err)
{
    if (err->code == RD_ERR_NOT_FOUND)
        return rd_reply_error(r, 404, "not_found", NULL, no_job);
    return rd_reply_failed(r, err);
}

/* Why a stored job has no image of the kind asked for. */
static enum MHD_Result stored_no_image(rd_req *r, rd_store_status st, int exr, int hdr, const rd_error *err)
{
    if (exr && st == RD_STORE_DONE && !hdr)
        return rd_reply_error(r, 406, "not_acceptable", NULL,
                              "this job keeps no EXR: submit it with POST /v1/jobs?hdr=1 to get its image as "
                              "image/x-exr");
    if (st == RD_STORE_QUEUED || st == RD_STORE_RUNNING)
        return rd_reply_error(r, 409, "not_ready", err, NULL);
    return rd_reply_error(r, 409, "no_image", err, NULL);
}

static enum MHD_Result stored_image(rd_req *r, const char *id)
{
    rd_server *srv = r->srv;
    int exr = accepts_exr(r->conn), hdr = 0;
    const char *p = MHD_lookup_connection_value(r->conn, MHD_GET_ARGUMENT_KIND, "partial");
    int partial = p && strcmp(p, "0") != 0;
    unsigned char *data;
    size_t len;
    rd_store_status st;
    rd_error err = {0};
    rd_error_code rc =
        rd_farm_image(rd_server_farm(srv), id, exr ? RD_STORE_EXR : RD_STORE_PNG, &data, &len, &st, &hdr, &err);
    if (rc == RD_ERR_INVALID && partial && !exr && st == RD_STORE_RUNNING)
        return submit_partial(r, NULL, id);
    if (rc == RD_ERR_INVALID)
        return stored_no_image(r, st, exr, hdr, &err);
    if (rc)
        return stored_failed(r, &err);
    /* A finished job's image never changes under its id. */
    char tag[40];
    snprintf(tag, sizeof tag, "%s.%s", id, exr ? "exr" : "png");
    return rd_reply_immutable(r, exr ? "image/x-exr" : "image/png", data, len, 1, tag,
                              srv->opt.jobs.result_ttl_ms / 1e3);
}

/* A job POST /v1/jobs committed: the store answers, whichever daemon
 * accepted or renders it. */
static enum MHD_Result stored_job(rd_req *r, const char *id, const char *rest)
{
    rd_server *srv = r->srv;
    rd_error err = {0};
    rd_farm *farm = rd_server_farm(srv);
    if (!farm)
        return rd_reply_error_hdr(r, 503, "starting", "the server is starting", "Retry-After", "1");
    if (!rd_cap_valid(id, 0))
        return rd_reply_error(r, 404, "not_found", NULL, no_job);
    snprintf(r->job_id, sizeof r->job_id, "%s", id);
    if (strcmp(rest, "/image") == 0)
        return stored_image(r, id);
    if (*rest)
        return rd_reply_error(r, 404, "not_found", NULL, "no such route");
    if (strcmp(r->method, "DELETE") == 0 && rd_farm_cancel(farm, id, NULL, &err))
        return stored_failed(r, &err);
    char *text;
    if (rd_farm_job_json(farm, id, &text, NULL, &err))
        return stored_failed(r, &err);
    return rd_reply_json(r, 200, text);
}

/* rest: "/{id}" or "/{id}/image". */
enum MHD_Result rd_route_job(rd_req *r, const char *path)
{
    char id[RD_CAP_MAX];
    const char *slash = strchr(path + 1, '/');
    size_t n = slash ? (size_t)(slash - path - 1) : strlen(path + 1);
    if (n >= sizeof id)
        return rd_reply_error(r, 404, "not_found", NULL, no_job);
    memcpy(id, path + 1, n);
    id[n] = 0;
    const char *rest = slash ? slash : "";
    rd_server *srv = r->srv;
    rd_jq_job *job = rd_jq_find(srv->jobs, id);
    if (!job)
        return stored_job(r, id, rest);
    snprintf(r->job_id, sizeof r->job_id, "%s", id);
    enum MHD_Result ret;
    if (strcmp(r->method, "DELETE") == 0 && !*rest) {
        rd_jq_cancel(srv->jobs, job);
        rd_jq_info info;
        rd_jq_info_get(srv->jobs, job, &info);
        ret = rd_reply_json(r, 200, job_json(&info));
    } else if (!*rest) {
        rd_jq_info info;
        rd_jq_info_get(srv->jobs, job, &info);
        ret = rd_reply_json(r, 200, job_json(&info));
    } else if (strcmp(rest, "/image") == 0 && accepts_exr(r->conn)) {
        ret = reply_job_exr(r, job);
    } else if (strcmp(rest, "/image") == 0) {
        const char *p = MHD_lookup_connection_value(r->conn, MHD_GET_ARGUMENT_KIND, "partial");
        int partial = p && strcmp(p, "0") != 0;
        rd_jq_info now;
        rd_jq_info_get(srv->jobs, job, &now);
        if (partial && now.status == RD_JQ_RUNNING)
            return submit_partial(r, job, NULL);
        unsigned char *png;
        size_t len;
        rd_error err = {0};
        if (rd_jq_png(srv->jobs, job, partial, &png, &len, &err)) {
            ret = no_image(r, job, &err);
        } else if (now.status == RD_JQ_DONE) {
            /* A finished job's image never changes under its id. */
            char tag[40];
            snprintf(tag, sizeof tag, "%s.png", now.id);
            ret = rd_reply_immutable(r, "image/png", png, len, 1, tag, srv->opt.jobs.result_ttl_ms / 1e3);
        } else {
            static const char *const no_store[] = {MHD_HTTP_HEADER_CACHE_CONTROL, "no-store", NULL};
            ret = rd_reply_with(r, 200, "image/png", png, len, 1, no_store);
        }
    } else {
        ret = rd_reply_error(r, 404, "not_found", NULL, "no such route");
    }
    rd_jq_job_unref(job);
    return ret;
}
