/* POST /v1/grade/code (a student's calcReflectedLight, graded by the
 * grading service in the sandbox: grading_service.h),
 * GET /v1/grade/code/skeleton/{material}, GET /v1/grade/code/{id}/lobe.svg.
 * A client that hangs up cancels its grade: the queue's watchdog sees it,
 * and the job's stop flag ends the sandbox. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "codegrade.h"
#include "http_internal.h"
#include "metrics.h"

enum { DISCARD_MAX = 1 << 20 };

/* The form as it arrives: the assignment, the student, the file. */
typedef struct {
    rd_form form;
    rd_form_blob source;
    char assignment[80];
    char student[256];
} code_form;

#define AT(f) offsetof(code_form, f)
static const rd_form_field fields[] = {
    {"source", RD_FORM_FILE, AT(source), offsetof(rd_server_options, max_code_bytes), "--max-code-bytes", NULL},
    {"code", RD_FORM_FILE, AT(source), offsetof(rd_server_options, max_code_bytes), "--max-code-bytes", NULL},
    RD_FORM_ASSIGNMENT(code_form),
    RD_FORM_STUDENT(code_form),
    {NULL, RD_FORM_TEXT, 0, 0, NULL, NULL},
};
#undef AT

static void free_form(rd_req *r)
{
    code_form *f = r->state;
    if (!f)
        return;
    rd_form_end(&f->form);
    rd_form_blob_free(&f->source);
    free(f);
    r->state = NULL;
}

enum MHD_Result rd_route_code_begin(rd_req *r)
{
    rd_form_spec spec = {.size = sizeof(code_form),
                         .fields = fields,
                         .max_total = r->srv->opt.max_code_bytes + 64 * 1024,
                         .too_large = "--max-code-bytes and 64 KiB of fields",
                         .hint = "send multipart/form-data with 'assignment' and a 'source' file",
                         .free_state = free_form};
    return rd_form_begin(r, &spec);
}

enum MHD_Result rd_route_code_data(rd_req *r, const char *data, size_t size)
{
    return rd_form_data(r, data, size, r->srv->opt.max_code_bytes + DISCARD_MAX);
}

static enum MHD_Result submit(rd_req *r, rd_grading *g, code_form *f)
{
    rd_grading_code in = {f->source.data, f->source.len, f->source.filename, f->assignment, f->student, r->client};
    f->source.data = NULL;
    rd_jq_task task;
    rd_jq_submit_options so = {0};
    rd_error err = {0};
    int per_client = 0;
    rd_error_code rc = rd_grading_code_task(g, &in, &task, &so, &per_client, &err);
    if (rc == RD_ERR_BUSY && per_client)
        return rd_reply_error_hdr(r, 429, "too_many_requests", err.message, "Retry-After", "5");
    if (rc == RD_ERR_BUSY)
        return rd_reply_error_hdr(r, 503, "queue_full", err.message, "Retry-After", "5");
    if (rc)
        return rd_reply_answer(r, rd_code_error_answer(RD_GRADE_STAGE_NONE, rc), &err);
    return rd_req_submit(r, &task, &so);
}

enum MHD_Result rd_route_code(rd_req *r, const char *rest)
{
    (void)rest;
    enum MHD_Result ret;
    if (rd_form_refused(r, &ret))
        return ret;
    code_form *f = r->state;
    rd_grading *g = rd_server_grading(r->srv);
    if (atomic_load(&r->srv->draining))
        return rd_reply_draining(r);
    if (!g)
        return rd_reply_starting(r);
    if (!f->source.len)
        return rd_reply_error(r, 400, "parse_error", NULL, "the form has no 'source' file (the student's .h or .cpp)");
    if (!f->assignment[0])
        return rd_reply_error(r, 400, "parse_error", NULL, "the form has no 'assignment'");
    char why[300];
    const char *refused = rd_grading_window_refusal(g, f->assignment, why, sizeof why);
    if (refused)
        return rd_reply_error(r, 403, refused, NULL, why);
    return submit(r, g, f);
}

enum MHD_Result rd_route_code_resumed(rd_req *r)
{
    rd_jq_info info;
    rd_jq_info_get(r->srv->jobs, r->job, &info);
    rd_grading_answer a = rd_grading_code_answer(rd_jq_task_arg(r->job));
    if (info.status == RD_JQ_DONE && a.json) {
        rd_metrics_code_grade(r->srv, a.pass ? RD_VERDICT_PASS : RD_VERDICT_FAIL);
        return rd_reply_json(r, a.status, a.json);
    }
    free(a.json);
    if (info.status == RD_JQ_FAILED) {
        rd_metrics_code_grade(r->srv, RD_VERDICT_ERROR);
        return rd_reply_answer(r, rd_code_error_answer(a.stage, info.error.code), &info.error);
    }
    return rd_reply_cancelled(r, &info, "grade");
}

static enum MHD_Result skeleton(rd_req *r, const char *material)
{
    char *text = NULL;
    size_t len = 0;
    rd_error err = {0};
    rd_error_code rc = rd_codegrade_skeleton(r->srv->opt.course_dir, material, &text, &len, &err);
    if (rc == RD_ERR_NOT_FOUND)
        return rd_reply_error(r, 404, "not_found", &err, NULL);
    if (rc)
        return rd_reply_error(r, 503, "unavailable", NULL, "the course's files cannot be read on this server");
    return rd_reply(r, 200, "text/x-c++hdr; charset=utf-8", text, len, 1);
}

static enum MHD_Result lobe(rd_req *r, const char *id)
{
    rd_grading *g = rd_server_grading(r->srv);
    if (!g)
        return rd_reply_starting(r);
    char *svg = NULL;
    rd_error err = {0};
    if (rd_grading_lobe(g, id, &svg, &err))
        return rd_reply_failed(r, &err);
    return rd_reply(r, 200, "image/svg+xml", svg, strlen(svg), 1);
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
