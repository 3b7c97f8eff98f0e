/* POST /v1/grade, GET /v1/assignments, GET /v1/grades/{id}/...: the form
 * read, the grade handed to the grading service (grading_service.h), which
 * runs it on the render queue, and its answer. */
#include <cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "assignment.h"
#include "file_io.h"
#include "http_internal.h"
#include "json_text.h"
#include "metrics.h"
#include "scene_load.h"
#include "utf8.h"

/* A form holds up to three fields (image, scene, assignment) of at most
 * --max-body-bytes each; a bad one is read to its end and dropped, up to
 * DISCARD_MAX more, before the connection is closed instead. */
enum { FORM_FIELDS = 3, DISCARD_MAX = 1 << 20 };

/* The form as it arrives, on the HTTP thread (the request's state). */
typedef struct {
    rd_form form;
    rd_form_blob image, scene;
    char assignment[80];
    char student[256];
} grade_form;

#define AT(f) offsetof(grade_form, f)
#define FLAG(f) offsetof(rd_server_options, f)
static const rd_form_field fields[] = {
    {"image", RD_FORM_BLOB, AT(image), FLAG(max_body_bytes), "--max-body-bytes", NULL},
    {"scene", RD_FORM_BLOB, AT(scene), FLAG(max_body_bytes), "--max-body-bytes", NULL},
    RD_FORM_ASSIGNMENT(grade_form),
    RD_FORM_STUDENT(grade_form),
    {NULL, RD_FORM_TEXT, 0, 0, NULL, NULL},
};
#undef AT
#undef FLAG

static void free_form(rd_req *r)
{
    grade_form *g = r->state;
    if (!g)
        return;
    rd_form_end(&g->form);
    rd_form_blob_free(&g->image);
    rd_form_blob_free(&g->scene);
    free(g);
    r->state = NULL;
}

enum MHD_Result rd_route_grade_begin(rd_req *r)
{
    rd_form_spec spec = {.size = sizeof(grade_form),
                         .fields = fields,
                         .max_total = FORM_FIELDS * r->srv->opt.max_body_bytes,
                         .too_large = "--max-body-bytes for each of its 3 fields",
                         .hint = "send multipart/form-data with 'image' and 'assignment' or 'scene'",
                         .free_state = free_form};
    return rd_form_begin(r, &spec);
}

enum MHD_Result rd_route_grade_data(rd_req *r, const char *data, size_t size)
{
    return rd_form_data(r, data, size, FORM_FIELDS * r->srv->opt.max_body_bytes + DISCARD_MAX);
}

enum MHD_Result rd_route_grade(rd_req *r, const char *rest)
{
    (void)rest;
    enum MHD_Result ret;
    if (rd_form_refused(r, &ret))
        return ret;
    grade_form *g = r->state;
    rd_grading *grading = rd_server_grading(r->srv);
    if (atomic_load(&r->srv->draining))
        return rd_reply_draining(r);
    if (!grading)
        return rd_reply_starting(r);
    if (!g->image.len)
        return rd_reply_error(r, 400, "parse_error", NULL, "the form has no 'image' file");
    if (!g->assignment[0] == !g->scene.data)
        return rd_reply_error(r, 400, "parse_error", NULL, "give exactly one of 'assignment' or 'scene'");
    /* Its record could not hold it: refused before it is graded. */
    if (rd_utf8_invalid_at(g->student, strlen(g->student)) != strlen(g->student))
        return rd_reply_error(r, 400, "parse_error", NULL, "the 'student' field is not UTF-8 text");
    char why[300];
    const char *refused = g->assignment[0] ? rd_grading_window_refusal(grading, g->assignment, why, sizeof why) : NULL;
    if (refused)
        return rd_reply_error(r, 403, refused, NULL, why);
    rd_grading_image in = {(char *)g->image.data, g->image.len,  (char *)g->scene.data,
                           g->scene.len,          g->assignment, g->student};
    g->image.data = g->scene.data = NULL;
    rd_jq_task task;
    rd_error err = {0};
    if (rd_grading_image_task(grading, &in, &task, &err))
        return rd_reply_failed(r, &err);
    rd_jq_submit_options so = {0};
    return rd_req_submit(r, &task, &so);
}

enum MHD_Result rd_route_grade_resumed(rd_req *r)
{
    rd_jq_info info;
    rd_jq_info_get(r->srv->jobs, r->job, &info);
    rd_grading_answer a = rd_grading_image_answer(rd_jq_task_arg(r->job));
    if (info.status == RD_JQ_DONE && a.json) {
        rd_metrics_grade(r->srv, a.pass ? RD_VERDICT_PASS : RD_VERDICT_FAIL);
        return rd_reply_json(r, 200, a.json);
    }
    free(a.json);
    if (info.status == RD_JQ_FAILED) {
        rd_metrics_grade(r->srv, RD_VERDICT_ERROR);
        return rd_reply_answer(r, rd_grade_error_answer(a.stage, info.error.code), &info.error);
    }
    return rd_reply_cancelled(r, &info, "grade");
}

/* A browser's navigation asks for text/html before JSON; a client naming
 * neither, or JSON at least as much (curl's wildcard), keeps the JSON. */
static int prefers_html(rd_req *r)
{
    const char *accept = MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_ACCEPT);
    int html = rd_accept_quality(accept, "text/html", NULL);
    return html > 0 && html > rd_accept_quality(accept, "application/json", NULL);
}

/* GET /v1/grades/{id}: the verdict's JSON, or for a browser the page,
 * which reads that JSON and shows the grade. The page's status is the
 * JSON's, so a link to no grade is a 404 either way. The page's address
 * is the capability: no Referer carries it elsewhere. */
static enum MHD_Result reply_verdict(rd_req *r, rd_grading *g, const char *id)
{
    rd_error err = {0};
    char *text = NULL;
    rd_error_code rc = rd_cap_valid(id, 'g') ? rd_grading_verdict(g, id, &text, &err)
                                             : rd_error_set(&err, RD_ERR_NOT_FOUND, 0, 0, "no such grade");
    if (!prefers_html(r))
        return rc ? rd_reply_failed(r, &err) : rd_reply_json(r, 200, text);
    free(text);
    rd_error_answer a = rc ? rd_error_answer_for(err.code) : (rd_error_answer){.http = 200};
    char after[16];
    snprintf(after, sizeof after, "%u", a.retry_after);
    const char *headers[] = {"Referrer-Policy", "no-referrer", a.retry_after ? "Retry-After" : NULL, after, NULL};
    return rd_reply_page(r, a.http, headers);
}

enum MHD_Result rd_route_grade_files(rd_req *r, const char *path)
{
    int del = strcmp(r->method, "DELETE") == 0;
    if (!*path)
        return del ? rd_route_grades_delete(r) : rd_route_grades_list(r);
    const char *rest = path + 1;
    /* rest: "{id}", "{id}/diff.png", "{id}/reference.png" or "{id}/image.png" */
    const char *slash = strchr(rest, '/');
    if (del)
        return rd_route_grade_delete(r, rest);
    if (!slash)
        r->vary = "Accept";
    rd_grading *g = rd_server_grading(r->srv);
    if (!g)
        return rd_reply_starting(r);
    if (!slash)
        return reply_verdict(r, g, rest);
    rd_error err = {0};
    if (slash - rest >= RD_CAP_MAX)
        return rd_reply_error(r, 404, "not_found", NULL, "no such grade");
    char id[RD_CAP_MAX];
    memcpy(id, rest, (size_t)(slash - rest));
    id[slash - rest] = 0;
    unsigned char *png;
    size_t len;
    if (rd_grading_image_file(g, id, slash + 1, &png, &len, &err))
        return rd_reply_failed(r, &err);
    /* A grade's images never change under its id; they stay while the
     * last 256 grades do, so an hour of caching is safe enough. */
    char tag[64];
    snprintf(tag, sizeof tag, "%s-%s", id, slash + 1);
    return rd_reply_immutable(r, "image/png", png, len, 1, tag, 3600);
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
