/* Every route of the service (docs/http-api.md), in one table: adding a
 * route means a row here and its handlers in a routes_*.c. The server only
 * looks rows up and calls them. */
#include <cJSON.h>
#include <string.h>

#include "http_internal.h"

static enum MHD_Result health(rd_req *r, const char *rest)
{
    (void)rest;
    static const char ok[] = "{\"status\":\"ok\"}\n";
    return rd_reply(r, 200, "application/json", (void *)ok, sizeof ok - 1, 0);
}

/* Ready, but a feature is off: 200 still (renders and image grades are
 * served, and a balancer that took the daemon out would stop them too),
 * with what is unavailable and why, for the operator to see. */
static enum MHD_Result ready_without(rd_req *r, const char *feature, const char *why)
{
    cJSON *root = cJSON_CreateObject(), *off = NULL;
    char *text = NULL;
    if (root && cJSON_AddStringToObject(root, "status", "ready") &&
        (off = cJSON_AddObjectToObject(root, "unavailable")) && cJSON_AddStringToObject(off, feature, why))
        text = cJSON_PrintUnformatted(root);
    cJSON_Delete(root);
    return text ? rd_reply_json(r, 200, text) : rd_reply_error(r, 503, "unavailable", NULL, "out of memory");
}

enum MHD_Result rd_route_ready(rd_req *r, const char *rest)
{
    (void)rest;
    static const char ok[] = "{\"status\":\"ready\"}\n";
    static const char starting[] = "{\"status\":\"not_ready\",\"reasons\":[\"starting\"]}\n";
    static const char draining[] = "{\"status\":\"not_ready\",\"reasons\":[\"draining\"]}\n";
    static const char no_store[] = "{\"status\":\"not_ready\",\"reasons\":[\"store_unreachable\"]}\n";
    static const char full[] = "{\"status\":\"not_ready\",\"reasons\":[\"store_full\"]}\n";
    static const char damaged[] = "{\"status\":\"not_ready\",\"reasons\":[\"store_damaged\"]}\n";
    rd_error err = {0};
    rd_error_code rc = RD_OK;
    const char *t = atomic_load(&r->srv->draining)                       ? draining
                    : !atomic_load(&r->srv->ready)                       ? starting
                    : !(rc = rd_farm_ping(rd_server_farm(r->srv), &err)) ? ok
                    : rc == RD_ERR_NOSPACE                               ? full
                    : rc == RD_ERR_DAMAGED                               ? damaged
                                                                         : no_store;
    const char *no_sandbox = t == ok ? rd_grading_code_unavailable(rd_server_grading(r->srv)) : NULL;
    if (no_sandbox)
        return ready_without(r, "code_grading", no_sandbox);
    const char *headers[] = {"Retry-After", "5", NULL};
    return rd_reply_with(r, t == ok ? 200 : 503, "application/json", (void *)t, strlen(t), 0, t == ok ? NULL : headers);
}

/* GET /v1/jobs/{id} may also be deleted; its image only read. So do a
 * batch and its tables, and a grade record and its images. */
static const char *job_allow(const char *rest) { return strchr(rest + 1, '/') ? "GET" : "GET, DELETE"; }

/* /v1/grades is listed and deleted from (a student's records), as is a
 * record. */
static const char *grades_allow(const char *rest) { return *rest ? job_allow(rest) : "GET, DELETE"; }

static const rd_route routes[] = {
    {"/v1/render", RD_ROUTE_EXACT, "POST", NULL, rd_render_begin, NULL, 1, rd_route_render_sync,
     rd_route_render_resumed},
    {"/v1/jobs", RD_ROUTE_EXACT, "POST", NULL, rd_jobs_begin, NULL, 1, rd_route_jobs_post, rd_route_jobs_resumed},
    {"/v1/jobs", RD_ROUTE_BELOW, "GET, DELETE", job_allow, NULL, NULL, 0, rd_route_job, rd_route_job_image_resumed},
    {"/v1/grade", RD_ROUTE_EXACT, "POST", NULL, rd_route_grade_begin, rd_route_grade_data, 0, rd_route_grade,
     rd_route_grade_resumed},
    {"/v1/assignments", RD_ROUTE_EXACT_OR_BELOW, "GET", NULL, NULL, NULL, 0, rd_route_assignments, NULL},
    {"/v1/grade/code", RD_ROUTE_EXACT, "POST", NULL, rd_route_code_begin, rd_route_code_data, 0, rd_route_code,
     rd_route_code_resumed},
    {"/v1/grade/code", RD_ROUTE_BELOW, "GET", NULL, NULL, NULL, 0, rd_route_code_get, NULL},
    {"/v1/grade/batch", RD_ROUTE_EXACT, "GET, POST", NULL, rd_route_batch_begin, rd_route_batch_data, 0,
     rd_route_batch_post, rd_route_batch_resumed},
    {"/v1/grade/batch", RD_ROUTE_BELOW, "GET, DELETE", job_allow, NULL, NULL, 0, rd_route_batch_get, NULL},
    {"/v1/grades", RD_ROUTE_EXACT_OR_BELOW, "GET, DELETE", grades_allow, NULL, NULL, 0, rd_route_grade_files, NULL},
    {"/v1/gradebook", RD_ROUTE_EXACT, "GET", NULL, NULL, NULL, 0, rd_route_gradebook, NULL},
    {"/v1/grade/regrade", RD_ROUTE_EXACT, "POST", NULL, NULL, NULL, 0, rd_route_regrade, NULL},
    {"/v1/scenes", RD_ROUTE_EXACT_OR_BELOW, "GET", NULL, NULL, NULL, 0, rd_route_scenes, NULL},
    {"/healthz", RD_ROUTE_EXACT, "GET", NULL, NULL, NULL, 0, health, NULL},
    {"/readyz", RD_ROUTE_EXACT, "GET", NULL, NULL, NULL, 0, rd_route_ready, NULL},
    {"/metrics", RD_ROUTE_EXACT, "GET", NULL, NULL, NULL, 0, rd_route_metrics, NULL},
    {"/openapi.json", RD_ROUTE_EXACT, "GET", NULL, NULL, NULL, 0, rd_route_openapi, NULL},
    {"/", RD_ROUTE_EXACT, "GET", NULL, NULL, NULL, 0, rd_route_page, NULL},
    {"/index.html", RD_ROUTE_EXACT, "GET", NULL, NULL, NULL, 0, rd_route_page, NULL},
};

const rd_route *rd_route_find(const char *url, size_t *rest)
{
    for (size_t i = 0; i < sizeof routes / sizeof routes[0]; i++) {
        const rd_route *t = &routes[i];
        size_t n = strlen(t->path);
        if (strncmp(url, t->path, n) != 0)
            continue;
        int exact = url[n] == 0, below = url[n] == '/' && url[n + 1] != 0;
        if ((exact && t->match != RD_ROUTE_BELOW) || (below && t->match != RD_ROUTE_EXACT)) {
            *rest = n;
            return t;
        }
    }
    return NULL;
}

const char *rd_route_allowed(const rd_route *t, const char *method, const char *rest)
{
    const char *allow = t->allow_for ? t->allow_for(rest) : t->methods;
    /* HEAD is GET without the body, which libmicrohttpd leaves out. */
    const char *m = strcmp(method, "HEAD") == 0 ? "GET" : method;
    size_t n = strlen(m);
    for (const char *p = allow; (p = strstr(p, m)); p += n)
        if ((p == allow || p[-1] == ' ') && (p[n] == 0 || p[n] == ','))
            return NULL;
    return allow;
}
