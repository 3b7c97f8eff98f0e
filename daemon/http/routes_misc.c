#include <cJSON.h>
#include <dirent.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "asset_source.h"
#include "file_io.h"
#include "http_internal.h"
#include "json_text.h"
#include "scene_load.h"
#include "strbuf.h"

static int scene_file(const char *name) { return rd_ends_with(name, ".cfg") || rd_ends_with(name, ".json"); }

static int listed(const struct dirent *e) { return e->d_name[0] != '.' && scene_file(e->d_name); }

/* Links that lead out of the folder are neither listed nor served. */
static int inside(const char *dir, const char *name)
{
    char real[PATH_MAX];
    rd_error err;
    return rd_path_inside(dir, name, real, &err) == RD_OK;
}

enum MHD_Result rd_route_scenes(rd_req *r, const char *rest)
{
    const char *name = *rest ? rest + 1 : NULL;
    const char *dir = r->srv->opt.scenes_dir;
    if (!name || !*name) {
        struct dirent **names;
        int n = scandir(dir, &names, listed, alphasort);
        if (n < 0)
            return rd_reply_json(r, 200, strdup("{\"scenes\":[]}"));
        int f = 0;
        cJSON *root = cJSON_CreateObject();
        cJSON *arr = rd_json_add(root, "scenes", cJSON_CreateArray(), &f);
        for (int i = 0; i < n; i++) {
            const char *file = names[i]->d_name;
            if (arr && !f && inside(dir, file)) {
                cJSON *o = rd_json_add(arr, NULL, cJSON_CreateObject(), &f);
                int json = rd_ends_with(file, ".json");
                char base[256], url[300];
                snprintf(base, sizeof base, "%.*s", (int)(strlen(file) - (json ? 5 : 4)), file);
                snprintf(url, sizeof url, "/v1/scenes/%s", file);
                rd_json_add(o, "name", cJSON_CreateString(file), &f);
                rd_json_add(o, "scene", cJSON_CreateString(base), &f);
                rd_json_add(o, "format", cJSON_CreateString(json ? "json" : "cfg"), &f);
                rd_json_add(o, "url", cJSON_CreateString(url), &f);
            }
            free(names[i]);
        }
        free(names);
        char *t = f ? NULL : cJSON_PrintUnformatted(root);
        cJSON_Delete(root);
        if (!t)
            return rd_reply_error(r, 503, "unavailable", NULL, "out of memory");
        return rd_reply_json(r, 200, t);
    }
    /* A bare name ("phong") means its cfg; only plain file names are served. */
    char file[300];
    if (strchr(name, '/') || name[0] == '.' || strlen(name) > 200)
        return rd_reply_error(r, 404, "not_found", NULL, "no bundled scene by that name");
    snprintf(file, sizeof file, "%s%s", name, scene_file(name) ? "" : ".cfg");
    char path[PATH_MAX];
    char *text;
    size_t len;
    rd_error err = {0};
    if (rd_path_inside(dir, file, path, &err) ||
        rd_read_file(path, r->srv->opt.limits.max_bytes, rd_limit_flag(offsetof(rd_scene_limits, max_bytes)), &text,
                     &len, &err))
        return rd_reply_error(r, 404, "not_found", NULL, "no bundled scene by that name");
    const char *type = rd_ends_with(file, ".json") ? "application/json" : "text/x-rayd-cfg";
    return rd_reply(r, 200, type, text, len, 1);
}

enum MHD_Result rd_route_metrics(rd_req *r, const char *rest)
{
    (void)rest;
    rd_jq_metrics m;
    rd_jq_metrics_get(r->srv->jobs, &m);
    rd_strbuf out = {0};
#define PUT(...) rd_strbuf_printf(&out, __VA_ARGS__)
    PUT("# HELP rayd_queue_depth Render jobs waiting for a render thread.\n# TYPE rayd_queue_depth gauge\n");
    PUT("rayd_queue_depth %zu\n", m.queued);
    PUT("# HELP rayd_jobs_running Render jobs being rendered.\n# TYPE rayd_jobs_running gauge\n");
    PUT("rayd_jobs_running %zu\n", m.running);
    PUT("# HELP rayd_jobs_total Render jobs ended, by outcome.\n# TYPE rayd_jobs_total counter\n");
    PUT("rayd_jobs_total{outcome=\"done\"} %llu\n", (unsigned long long)m.done);
    PUT("rayd_jobs_total{outcome=\"failed\"} %llu\n", (unsigned long long)m.failed);
    PUT("rayd_jobs_total{outcome=\"cancelled\"} %llu\n", (unsigned long long)m.cancelled);
    PUT("# HELP rayd_render_seconds Time from a job's start to its image.\n# TYPE rayd_render_seconds histogram\n");
    for (int b = 0; b < RD_JQ_BUCKETS; b++)
        PUT("rayd_render_seconds_bucket{le=\"%g\"} %llu\n", rd_jq_buckets[b],
            (unsigned long long)m.render_seconds_bucket[b]);
    PUT("rayd_render_seconds_bucket{le=\"+Inf\"} %llu\n", (unsigned long long)m.render_count);
    PUT("rayd_render_seconds_sum %.6f\nrayd_render_seconds_count %llu\n", m.render_seconds_sum,
        (unsigned long long)m.render_count);
    PUT("# HELP rayd_rays_traced_total Camera, shadow and secondary rays traced.\n# TYPE rayd_rays_traced_total "
        "counter\n");
    PUT("rayd_rays_traced_total %llu\n", (unsigned long long)m.rays);
    PUT("# HELP rayd_result_bytes PNG bytes kept for finished jobs.\n# TYPE rayd_result_bytes gauge\n");
    PUT("rayd_result_bytes %zu\n", m.result_bytes);
    PUT("# HELP rayd_jobs_kept Jobs whose status can still be read.\n# TYPE rayd_jobs_kept gauge\n");
    PUT("rayd_jobs_kept %zu\n", m.jobs_kept);
    PUT("# HELP rayd_memory_budget_bytes The --memory-budget (0: none).\n# TYPE rayd_memory_budget_bytes gauge\n");
    PUT("rayd_memory_budget_bytes %zu\n", m.memory_budget);
    PUT("# HELP rayd_memory_reserved_bytes Estimated bytes held by queued and running jobs.\n"
        "# TYPE rayd_memory_reserved_bytes gauge\n");
    PUT("rayd_memory_reserved_bytes %zu\n", m.memory_reserved);
    PUT("# HELP rayd_grade_cache_bytes Grading references and kept grade images.\n"
        "# TYPE rayd_grade_cache_bytes gauge\n");
    PUT("rayd_grade_cache_bytes %zu\n", m.external_bytes);
    PUT("# HELP rayd_jobs_waiting_memory Prepared jobs waiting for the memory budget.\n"
        "# TYPE rayd_jobs_waiting_memory gauge\n");
    PUT("rayd_jobs_waiting_memory %zu\n", m.waiting_memory);
    PUT("# HELP rayd_http_deadline_closed_total Connections closed by the header or body deadline.\n"
        "# TYPE rayd_http_deadline_closed_total counter\n");
    PUT("rayd_http_deadline_closed_total %llu\n", (unsigned long long)atomic_load(&r->srv->deadline_closed));
    PUT("# HELP rayd_http_refused_total Requests answered 431 before parsing (--max-query-args).\n"
        "# TYPE rayd_http_refused_total counter\n");
    PUT("rayd_http_refused_total %llu\n", (unsigned long long)atomic_load(&r->srv->raw_refused));
    PUT("# HELP rayd_http_responses_total HTTP answers by status class.\n# TYPE rayd_http_responses_total counter\n");
    for (int c = 1; c <= 5; c++)
        PUT("rayd_http_responses_total{code=\"%dxx\"} %llu\n", c,
            (unsigned long long)atomic_load(&r->srv->http_count[c]));
#undef PUT
    size_t n;
    char *text = rd_strbuf_take(&out, &n);
    if (!text)
        return rd_reply_error(r, 503, "unavailable", NULL, "out of memory");
    return rd_reply(r, 200, "text/plain; version=0.0.4", text, n, 1);
}

enum MHD_Result rd_route_page(rd_req *r, const char *rest)
{
    (void)rest;
    return rd_reply(r, 200, "text/html; charset=utf-8", (void *)rd_web_index_html, strlen(rd_web_index_html), 0);
}
