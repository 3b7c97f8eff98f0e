#include <cJSON.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "http_internal.h"
#include "scene_open.h"

/* The query's overrides of the scene's render section (http-api.md), read
 * on the HTTP thread (the scene keys' own ranges) and applied once the
 * scene is parsed. 0, or fills err (RD_ERR_SYNTAX) naming the parameter. */
static int read_overrides(struct MHD_Connection *c, rd_scene_overrides *ov, rd_error *err)
{
    memset(ov, 0, sizeof *ov);
    for (int i = 0; rd_override_names[i]; i++) {
        const char *v = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, rd_override_names[i]);
        char what[48];
        snprintf(what, sizeof what, "query parameter %s", rd_override_names[i]);
        if (v && rd_override_set(ov, rd_override_names[i], v, what, err))
            return 1;
    }
    return 0;
}

/* An uploaded scene, parsed and given its assets on a render thread. */
typedef struct {
    char *body;
    size_t len;
    rd_scene_format fmt;
    rd_scene_overrides ov;
    const rd_server_options *opt;
} render_task;

static rd_error_code prepare_render(void *arg, rd_scene *s, int *render, rd_error *err)
{
    (void)render;
    render_task *t = arg;
    rd_scene_source src = {
        .text = t->body, .len = t->len, .source = "<upload>", .format = t->fmt, .assets_dir = t->opt->scenes_dir};
    rd_warnings w = {0, ""};
    rd_error_code rc = rd_scene_open(&src, &t->ov, &t->opt->limits, s, &w, err);
    free(t->body);
    t->body = NULL;
    return rc;
}

static void free_render(void *arg)
{
    render_task *t = arg;
    if (t) {
        free(t->body);
        free(t);
    }
}

/* time_budget_ms, target_error and adaptive from the query. */
static int progress_params(struct MHD_Connection *c, rd_progress_settings *p, rd_error *err)
{
    memset(p, 0, sizeof *p);
    static const char *const names[] = {"time_budget_ms", "target_error"};
    double *dst[] = {&p->time_budget_ms, &p->target_error};
    for (int i = 0; i < 2; i++) {
        const char *v = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, names[i]);
        if (!v)
            continue;
        char *end;
        double x = strtod(v, &end);
        if (!*v || *end || !(x > 0) || !(x < 1e15)) {
            rd_error_set(err, RD_ERR_SYNTAX, 0, 0, "query parameter %s: expected a number > 0, got '%.40s'", names[i],
                         v);
            return 1;
        }
        *dst[i] = x;
    }
    const char *a = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "adaptive");
    if (a) {
        if (strcmp(a, "1") == 0 || strcmp(a, "true") == 0)
            p->adaptive = 1;
        else if (strcmp(a, "0") != 0 && strcmp(a, "false") != 0) {
            rd_error_set(err, RD_ERR_SYNTAX, 0, 0, "query parameter adaptive: expected 0 or 1, got '%.40s'", a);
            return 1;
        }
    }
    return 0;
}

/* Whether the Accept header names image/x-exr (q-values are not weighed:
 * naming it asks for it). */
static int accepts_exr(struct MHD_Connection *c)
{
    const char *a = MHD_lookup_connection_value(c, MHD_HEADER_KIND, MHD_HTTP_HEADER_ACCEPT);
    static const char exr[] = "image/x-exr";
    for (const char *p = a; p && *p;) {
        p += strspn(p, " \t,");
        size_t n = strcspn(p, ";, \t");
        if (n == sizeof exr - 1 && strncasecmp(p, exr, n) == 0)
            return 1;
        p += strcspn(p, ",");
    }
    return 0;
}

/* hdr=1 in the query, or Accept: image/x-exr: keep the job's EXR. */
static int hdr_param(struct MHD_Connection *c, int *hdr, rd_error *err)
{
    const char *v = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "hdr");
    *hdr = accepts_exr(c);
    if (!v)
        return 0;
    if (strcmp(v, "1") == 0 || strcmp(v, "true") == 0)
        *hdr = 1;
    else if (strcmp(v, "0") != 0 && strcmp(v, "false") != 0) {
        rd_error_set(err, RD_ERR_SYNTAX, 0, 0, "query parameter hdr: expected 0 or 1, got '%.40s'", v);
        return 1;
    }
    return 0;
}

static char *job_json(const rd_jq_info *in)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "id", in->id);
    cJSON_AddStringToObject(o, "status", rd_jq_status_name(in->status));
    cJSON_AddNumberToObject(o, "progress", in->progress);
    cJSON_AddNumberToObject(o, "elapsed_ms", in->elapsed_ms);
    cJSON_AddNumberToObject(o, "queued_ms", in->queued_ms);
    cJSON_AddNumberToObject(o, "samples", in->samples);
    cJSON_AddNumberToObject(o, "error_estimate", in->error_estimate);
    cJSON_AddNumberToObject(o, "width", in->width);
    cJSON_AddNumberToObject(o, "height", in->height);
    cJSON *curve = cJSON_AddArrayToObject(o, "curve");
    for (int i = 0; i < in->curve_len; i++) {
        double pt[3] = {in->curve[i].ms, in->curve[i].samples, in->curve[i].error};
        cJSON_AddItemToArray(curve, cJSON_CreateDoubleArray(pt, 3));
    }
    cJSON_AddNumberToObject(o, "passes", in->passes);
    if (in->status == RD_JQ_DONE)
        cJSON_AddStringToObject(o, "stopped_by", rd_stop_reason_name(in->stopped_by));
    if (in->status == RD_JQ_DONE || in->status == RD_JQ_RUNNING) {
        cJSON *st = cJSON_AddObjectToObject(o, "stats");
        cJSON_AddNumberToObject(st, "camera_rays", (double)in->stats.camera_rays);
        cJSON_AddNumberToObject(st, "shadow_rays", (double)in->stats.shadow_rays);
        cJSON_AddNumberToObject(st, "secondary_rays", (double)in->stats.secondary_rays);
        cJSON_AddNumberToObject(st, "rays_per_second", in->stats.rays_per_second);
        cJSON_AddNumberToObject(st, "prepare_ms", in->stats.prepare_ms);
        cJSON_AddNumberToObject(st, "primitives", (double)in->stats.primitives);
    }
    if (in->status == RD_JQ_FAILED) {
        cJSON *e = cJSON_AddObjectToObject(o, "error");
        cJSON_AddStringToObject(e, "code", rd_error_answer_for(in->error.code).code);
        cJSON_AddStringToObject(e, "message", in->error.message);
    }
    char *t = cJSON_PrintUnformatted(o);
    cJSON_Delete(o);
    return t;
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

/* Before the body: refuse what would be thrown away once read. */
enum MHD_Result rd_render_begin(rd_req *r)
{
    rd_server *srv = r->srv;
    if (atomic_load(&srv->draining))
        return rd_reply_draining(r);
    rd_jq_metrics m;
    rd_jq_metrics_get(srv->jobs, &m);
    if (m.queued + m.running >= srv->opt.jobs.queue_length)
        return rd_reply_error_hdr(r, 503, "queue_full", "the render queue is full; try again shortly", "Retry-After",
                                  "1");
    const char *ct = MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_CONTENT_TYPE);
    if (refused_type(ct))
        return rd_reply_error(r, 415, "unsupported_media_type", NULL,
                              "send a scene as application/json, text/plain or text/x-rayd-cfg");
    const char *cl = MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_CONTENT_LENGTH);
    if (cl && strtoull(cl, NULL, 10) > srv->opt.max_body_bytes)
        return rd_reply_too_large(r, "the body");
    return MHD_YES;
}

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
    if (progress_params(r->conn, &so.progress, &err) || read_overrides(r->conn, &t->ov, &err) ||
        hdr_param(r->conn, &so.hdr, &err)) {
        free(t);
        return rd_reply_error(r, 400, "parse_error", &err, NULL);
    }
    t->body = r->body;
    t->len = r->len;
    r->body = NULL;
    rd_jq_task task = {prepare_render, NULL, free_render, t, t->len};
    /* Both wait on the connection: an asynchronous submission until its
     * scene is read (so a bad one still gets its 4xx), a synchronous one
     * until its image is ready. */
    so.notify_prepared = async;
    r->async = async;
    return rd_req_submit(r, &task, &so);
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
    if (info->hung_up)
        return MHD_NO; /* nobody to answer: close, and the log says so */
    return rd_reply_error_hdr(r, 503, "cancelled", "the render was cancelled (the server is shutting down)",
                              "Retry-After", "5");
}

/* The 202 of an asynchronous submission whose scene was read; the job
 * goes on without this connection. */
static enum MHD_Result reply_accepted(rd_req *r, const rd_jq_info *info)
{
    rd_server *srv = r->srv;
    char loc[64];
    snprintf(loc, sizeof loc, "/v1/jobs/%s", info->id);
    char *text = job_json(info);
    rd_jq_detach(srv->jobs, r->job);
    rd_jq_job_unref(r->job);
    r->job = NULL;
    if (!text)
        return MHD_NO;
    const char *headers[] = {MHD_HTTP_HEADER_LOCATION, loc, NULL};
    return rd_reply_with(r, 202, "application/json", text, strlen(text), 1, headers);
}

enum MHD_Result rd_route_render_resumed(rd_req *r)
{
    rd_server *srv = r->srv;
    rd_jq_info info;
    rd_jq_info_get(srv->jobs, r->job, &info);
    if (info.status == RD_JQ_FAILED || info.status == RD_JQ_CANCELLED)
        return reply_ended(r, &info);
    if (r->async)
        return reply_accepted(r, &info);
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
    unsigned char *png;
    size_t len;
} partial_task;

static rd_error_code prepare_partial(void *arg, rd_scene *s, int *render, rd_error *err)
{
    (void)s;
    partial_task *t = arg;
    *render = 0;
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

/* Takes over the caller's reference to job. */
static enum MHD_Result submit_partial(rd_req *r, rd_jq_job *job)
{
    rd_server *srv = r->srv;
    partial_task *t = calloc(1, sizeof *t);
    if (!t) {
        rd_jq_job_unref(job);
        return rd_reply_error(r, 503, "unavailable", NULL, "out of memory");
    }
    t->q = srv->jobs;
    t->target = job;
    rd_jq_task task = {prepare_partial, NULL, free_partial, t, 0};
    rd_jq_submit_options so = {.watch_fd = rd_req_socket(r),
                               .watch_http11 = r->http11,
                               .done = rd_req_on_done,
                               .user = r,
                               .internal = 1,
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
    if (info.status == RD_JQ_FAILED)
        return rd_reply_error(r, 409, "not_ready", &info.error, NULL);
    if (info.hung_up)
        return MHD_NO;
    return rd_reply_error_hdr(r, 503, "cancelled", "the server is shutting down", "Retry-After", "5");
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

/* rest: "/{id}" or "/{id}/image". */
enum MHD_Result rd_route_job(rd_req *r, const char *path)
{
    char id[24];
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
        return rd_reply_error(r, 404, "not_found", NULL, no_job);
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
            return submit_partial(r, job);
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
