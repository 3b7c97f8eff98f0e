/* GET /v1/jobs/{id}'s answer (daemon/jobs/job_status.h), for a job in
 * memory and a stored job alike: which keys each status gives, and that
 * its figures are rd_stats_json's. tests/integration/openapi_test.py
 * checks real answers against docs/openapi.json and store_test.py compares
 * the two kinds of job; this covers every status, including those no test
 * can hold a real job in. */
#include <criterion/criterion.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "job_status.h"
#include "json_text.h"

static rd_job_status status_of(rd_jq_status s)
{
    rd_job_status v;
    memset(&v, 0, sizeof v);
    v.id = "0123456789abcdef0123456789abcdef";
    v.status = s;
    v.progress = s == RD_JQ_DONE ? 1 : 0.5;
    v.elapsed_ms = 12.5;
    v.queued_ms = 0.25;
    v.width = 64;
    v.height = 48;
    v.stats.samples = 4;
    v.stats.error_estimate = 0.01;
    v.stats.passes = 2;
    v.stats.camera_rays = 3072;
    v.stats.rays_per_second = 1e6;
    v.stats.primitives = 4;
    v.stats.threads = 2;        /* a process's figure: never in a status */
    v.stats.mean_samples = 3.5; /* likewise */
    v.stats.stopped_by = RD_STOP_SAMPLES;
    v.stats.curve_len = 2;
    v.stats.curve[0] = (rd_curve_point){5, 2, 0.02};
    v.stats.curve[1] = (rd_curve_point){12, 4, 0.01};
    if (s == RD_JQ_FAILED) {
        v.error_code = "invalid_scene";
        v.error_message = "degenerate triangle";
    }
    return v;
}

/* The status's keys in order, comma-separated, "stats{...}" for its
 * costs. */
static void keys_of(rd_jq_status s, char *out, size_t cap)
{
    rd_job_status v = status_of(s);
    char *text = rd_job_status_json(&v);
    cr_assert(text);
    cJSON *o = cJSON_Parse(text);
    cr_assert(o, "not JSON: %s", text);
    size_t len = 0;
    const cJSON *it;
    cJSON_ArrayForEach(it, o)
    {
        len += (size_t)snprintf(out + len, cap - len, "%s%s", len ? "," : "", it->string);
        if (strcmp(it->string, "stats") == 0) {
            const cJSON *c;
            cJSON_ArrayForEach(c, it)
            {
                len += (size_t)snprintf(out + len, cap - len, "%s%s", c == it->child ? "{" : ",", c->string);
            }
            len += (size_t)snprintf(out + len, cap - len, "}");
        }
    }
    cJSON_Delete(o);
    free(text);
}

#define BASE "id,status,progress,elapsed_ms,queued_ms,width,height,samples,error_estimate,passes"
#define COSTS "stats{camera_rays,shadow_rays,secondary_rays,rays_per_second,prepare_ms,primitives}"

Test(job_status, keys_by_status)
{
    static const struct {
        rd_jq_status s;
        const char *keys;
    } want[] = {
        {RD_JQ_QUEUED, BASE ",curve"},
        {RD_JQ_RUNNING, BASE ",curve," COSTS},
        {RD_JQ_DONE, BASE ",stopped_by,curve," COSTS},
        {RD_JQ_FAILED, BASE ",curve,error"},
        {RD_JQ_CANCELLED, BASE ",curve"},
    };
    for (size_t i = 0; i < sizeof want / sizeof want[0]; i++) {
        char keys[1024];
        keys_of(want[i].s, keys, sizeof keys);
        cr_assert_str_eq(keys, want[i].keys, "status %s", rd_jq_status_name(want[i].s));
    }
}

Test(job_status, the_figures_are_rd_stats_json_s)
{
    rd_job_status v = status_of(RD_JQ_DONE);
    char *text = rd_job_status_json(&v);
    cJSON *o = cJSON_Parse(text);
    /* What rd_stats_json writes for a finished job, item for item. */
    cJSON *want = cJSON_CreateObject();
    cr_assert_eq(rd_stats_json(want, &v.stats, RD_STATS_STOPPED | RD_STATS_COSTS | RD_STATS_NESTED), 0);
    const cJSON *it;
    cJSON_ArrayForEach(it, want)
    {
        const cJSON *got = cJSON_GetObjectItemCaseSensitive(o, it->string);
        cr_assert(got && cJSON_Compare(got, it, 1), "'%s' is not rd_stats_json's: %s", it->string, text);
    }
    cr_assert_str_eq(cJSON_GetObjectItemCaseSensitive(o, "status")->valuestring, "done");
    cr_assert_eq(cJSON_GetObjectItemCaseSensitive(o, "elapsed_ms")->valuedouble, 12.5);
    cJSON_Delete(want);
    cJSON_Delete(o);
    free(text);
    v = status_of(RD_JQ_FAILED);
    text = rd_job_status_json(&v);
    o = cJSON_Parse(text);
    const cJSON *e = cJSON_GetObjectItemCaseSensitive(o, "error");
    cr_assert_str_eq(cJSON_GetObjectItemCaseSensitive(e, "code")->valuestring, "invalid_scene");
    cr_assert_str_eq(cJSON_GetObjectItemCaseSensitive(e, "message")->valuestring, "degenerate triangle");
    cJSON_Delete(o);
    free(text);
}
