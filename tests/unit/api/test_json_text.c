/* A render's statistics as JSON (api/util/json_text.h): one vocabulary for
 * `rayd render --stats-format json` (flat), the job status and the job
 * store's statistics text (the costs under "stats"), one curve shape, and
 * a reader that takes back what the writer wrote and nothing else. */
#include <criterion/criterion.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "json_text.h"

/* What rayd render asks for, and what a finished job's status does. */
#define CLI_PARTS (RD_STATS_STOPPED | RD_STATS_COSTS | RD_STATS_PROCESS)
#define JOB_PARTS (RD_STATS_STOPPED | RD_STATS_COSTS | RD_STATS_NESTED)

/* Every figure a value of its own, none 0, so that a figure read into
 * another's place or not read at all shows. */
static rd_render_stats sample_stats(void)
{
    rd_render_stats st;
    memset(&st, 0, sizeof st);
    st.wall_ms = 1234.5;
    st.camera_rays = 3072;
    st.shadow_rays = 123456789012345ull; /* 15 digits: cJSON prints 15 when they come within an ulp */
    st.secondary_rays = 17;
    st.rays_per_second = 2.5e6;
    st.samples = 8;
    st.mean_samples = 7.75;
    st.error_estimate = 0.0123456789012345;
    st.nonfinite = 3;
    st.threads = 2;
    st.prepare_ms = 4.25;
    st.bvh_build_ms = 1.5;
    st.bvh_nodes = 99;
    st.world_bytes = 4096;
    st.primitives = 5;
    st.stopped_by = RD_STOP_TIME_BUDGET;
    st.passes = 3;
    st.curve_len = 3;
    st.curve[0] = (rd_curve_point){10.5, 2, 0.05};
    st.curve[1] = (rd_curve_point){20.25, 4, 0.03};
    st.curve[2] = (rd_curve_point){40.125, 7.75, 0.0123456789012345};
    return st;
}

static cJSON *written(const rd_render_stats *st, unsigned parts)
{
    cJSON *o = cJSON_CreateObject();
    cr_assert_eq(rd_stats_json(o, st, parts), 0);
    return o;
}

/* The keys of o, sorted, comma-separated; with lift, those of its "stats"
 * object in its place. */
static void keys_of(const cJSON *o, int lift, char *out, size_t cap)
{
    const char *names[64];
    int n = 0;
    const cJSON *it;
    cJSON_ArrayForEach(it, o)
    {
        if (lift && strcmp(it->string, "stats") == 0) {
            const cJSON *c;
            cJSON_ArrayForEach(c, it) names[n++] = c->string;
        } else {
            names[n++] = it->string;
        }
    }
    for (int i = 1; i < n; i++)
        for (int j = i; j > 0 && strcmp(names[j - 1], names[j]) > 0; j--) {
            const char *t = names[j];
            names[j] = names[j - 1];
            names[j - 1] = t;
        }
    size_t len = 0;
    out[0] = 0;
    for (int i = 0; i < n; i++)
        len += (size_t)snprintf(out + len, cap - len, "%s%s", i ? "," : "", names[i]);
}

Test(json_text, the_cli_object_has_the_http_names)
{
    rd_render_stats st = sample_stats();
    cJSON *o = written(&st, CLI_PARTS);
    char keys[1024];
    keys_of(o, 0, keys, sizeof keys);
    cr_assert_str_eq(keys,
                     "bvh_build_ms,bvh_nodes,camera_rays,curve,error_estimate,mean_samples,nonfinite,passes,"
                     "prepare_ms,primitives,rays_per_second,samples,secondary_rays,shadow_rays,stopped_by,threads,"
                     "time_ms,world_bytes");
    cr_assert_eq(cJSON_GetObjectItemCaseSensitive(o, "rays_per_second")->valuedouble, 2.5e6);
    cr_assert_eq(cJSON_GetObjectItemCaseSensitive(o, "time_ms")->valuedouble, 1234.5);
    cr_assert_str_eq(cJSON_GetObjectItemCaseSensitive(o, "stopped_by")->valuestring, "time_budget");
    cJSON_Delete(o);
}

Test(json_text, a_job_status_has_the_costs_under_stats)
{
    rd_render_stats st = sample_stats();
    cJSON *o = written(&st, JOB_PARTS);
    char keys[1024];
    keys_of(o, 0, keys, sizeof keys);
    cr_assert_str_eq(keys, "curve,error_estimate,passes,samples,stats,stopped_by");
    keys_of(cJSON_GetObjectItemCaseSensitive(o, "stats"), 0, keys, sizeof keys);
    cr_assert_str_eq(keys, "camera_rays,prepare_ms,primitives,rays_per_second,secondary_rays,shadow_rays");
    cJSON_Delete(o);
}

/* The point of one writer: every figure a job status gives, the CLI gives
 * under the same name with the same value, and nesting is the only
 * difference between the two layouts. */
Test(json_text, nesting_is_the_only_difference)
{
    rd_render_stats st = sample_stats();
    cJSON *flat = written(&st, RD_STATS_STOPPED | RD_STATS_COSTS);
    cJSON *job = written(&st, JOB_PARTS);
    cJSON *cli = written(&st, CLI_PARTS);
    char a[1024], b[1024];
    keys_of(flat, 0, a, sizeof a);
    keys_of(job, 1, b, sizeof b);
    cr_assert_str_eq(a, b);
    const cJSON *costs = cJSON_GetObjectItemCaseSensitive(job, "stats");
    const cJSON *it;
    cJSON_ArrayForEach(it, job)
    {
        const cJSON *group = strcmp(it->string, "stats") == 0 ? it : NULL;
        const cJSON *c;
        for (c = group ? group->child : it; c; c = group ? c->next : NULL) {
            const cJSON *mine = cJSON_GetObjectItemCaseSensitive(cli, c->string);
            cr_assert(mine, "the CLI has no '%s'", c->string);
            cr_assert(cJSON_Compare(mine, c, 1), "'%s' differs between the CLI and a job status", c->string);
        }
    }
    cr_assert(costs && cJSON_GetArraySize(costs) == 6);
    cJSON_Delete(flat);
    cJSON_Delete(job);
    cJSON_Delete(cli);
}

Test(json_text, the_curve_is_points_of_ms_samples_error)
{
    rd_render_stats st = sample_stats();
    unsigned layouts[] = {CLI_PARTS, JOB_PARTS, 0};
    for (int l = 0; l < 3; l++) {
        cJSON *o = written(&st, layouts[l]);
        const cJSON *curve = cJSON_GetObjectItemCaseSensitive(o, "curve");
        cr_assert(cJSON_IsArray(curve) && cJSON_GetArraySize(curve) == 3, "layout %u", layouts[l]);
        for (int i = 0; i < 3; i++) {
            const cJSON *pt = cJSON_GetArrayItem(curve, i);
            cr_assert(cJSON_IsArray(pt) && cJSON_GetArraySize(pt) == 3, "point %d is not [ms, samples, error]", i);
            cr_assert_eq(cJSON_GetArrayItem(pt, 0)->valuedouble, st.curve[i].ms);
            cr_assert_eq(cJSON_GetArrayItem(pt, 1)->valuedouble, st.curve[i].samples);
            cr_assert_eq(cJSON_GetArrayItem(pt, 2)->valuedouble, st.curve[i].error);
        }
        cJSON_Delete(o);
    }
}

Test(json_text, parts_choose_what_is_written)
{
    rd_render_stats st = sample_stats();
    char keys[1024];
    cJSON *o = written(&st, 0);
    keys_of(o, 0, keys, sizeof keys);
    cr_assert_str_eq(keys, "curve,error_estimate,passes,samples", "a queued job's figures");
    cJSON_Delete(o);
    o = written(&st, RD_STATS_COSTS | RD_STATS_NESTED);
    keys_of(o, 0, keys, sizeof keys);
    cr_assert_str_eq(keys, "curve,error_estimate,passes,samples,stats", "a running job's: no stopped_by");
    cJSON_Delete(o);
    o = written(&st, RD_STATS_PROCESS);
    keys_of(o, 0, keys, sizeof keys);
    cr_assert_str_eq(keys, "curve,error_estimate,mean_samples,passes,samples", "no costs, so no process costs");
    cJSON_Delete(o);
}

/* Written, printed as text, parsed and read back: every figure of the
 * parts (values that 15 significant digits give back: cJSON 1.7.15 prints
 * no more when they come within about an ulp), the others 0. */
static void round_trip(unsigned parts)
{
    rd_render_stats st = sample_stats();
    char *text = rd_json_print(written(&st, parts));
    cr_assert(text);
    cJSON *o = cJSON_Parse(text);
    rd_render_stats back;
    memset(&back, 0x5a, sizeof back);
    rd_stats_read(o, &back, parts);
    int costs = (parts & RD_STATS_COSTS) != 0, process = (parts & RD_STATS_PROCESS) != 0;
    cr_assert_eq(back.samples, st.samples);
    cr_assert_eq(back.error_estimate, st.error_estimate);
    cr_assert_eq(back.passes, st.passes);
    cr_assert_eq(back.stopped_by, parts & RD_STATS_STOPPED ? st.stopped_by : RD_STOP_NONE);
    cr_assert_eq(back.camera_rays, costs ? st.camera_rays : 0);
    cr_assert_eq(back.shadow_rays, costs ? st.shadow_rays : 0, "read back as %llu",
                 (unsigned long long)back.shadow_rays);
    cr_assert_eq(back.secondary_rays, costs ? st.secondary_rays : 0);
    cr_assert_eq(back.rays_per_second, costs ? st.rays_per_second : 0);
    cr_assert_eq(back.prepare_ms, costs ? st.prepare_ms : 0);
    cr_assert_eq(back.primitives, costs ? st.primitives : 0);
    cr_assert_eq(back.mean_samples, process ? st.mean_samples : 0);
    cr_assert_eq(back.threads, costs && process ? st.threads : 0);
    cr_assert_eq(back.wall_ms, costs && process ? st.wall_ms : 0);
    cr_assert_eq(back.nonfinite, costs && process ? st.nonfinite : 0);
    cr_assert_eq(back.bvh_build_ms, costs && process ? st.bvh_build_ms : 0);
    cr_assert_eq(back.bvh_nodes, costs && process ? st.bvh_nodes : 0);
    cr_assert_eq(back.world_bytes, costs && process ? st.world_bytes : 0);
    cr_assert_eq(back.curve_len, st.curve_len);
    for (int i = 0; i < st.curve_len; i++)
        cr_assert(back.curve[i].ms == st.curve[i].ms && back.curve[i].samples == st.curve[i].samples &&
                      back.curve[i].error == st.curve[i].error,
                  "curve point %d", i);
    cJSON_Delete(o);
    free(text);
}

Test(json_text, read_back_as_written)
{
    round_trip(CLI_PARTS);
    round_trip(JOB_PARTS);
    round_trip(RD_STATS_COSTS | RD_STATS_NESTED);
    round_trip(0);
}

static rd_render_stats read_text(const char *text, unsigned parts)
{
    cJSON *o = cJSON_Parse(text);
    cr_assert(o, "the test's text does not parse: %s", text);
    rd_render_stats st;
    rd_stats_read(o, &st, parts);
    cJSON_Delete(o);
    return st;
}

/* The store's texts are read as hostile as any input: a figure that is not
 * one reads 0, and the figures beside it are still read. */
Test(json_text, what_is_not_a_figure_reads_0)
{
    rd_render_stats st = read_text("{\"samples\": \"8\", \"error_estimate\": -0.5, \"passes\": 2.5,"
                                   " \"stopped_by\": \"bored\", \"curve\": [[1, 2, 3]],"
                                   " \"stats\": {\"camera_rays\": 1e300, \"shadow_rays\": 9007199254740994,"
                                   " \"secondary_rays\": -1, \"rays_per_second\": null, \"prepare_ms\": 1e308,"
                                   " \"primitives\": 7}}",
                                   JOB_PARTS);
    cr_assert_eq(st.samples, 0, "a string");
    cr_assert_eq(st.error_estimate, 0, "negative");
    cr_assert_eq(st.passes, 0, "not whole");
    cr_assert_eq(st.stopped_by, RD_STOP_NONE, "not a reason");
    cr_assert_eq(st.camera_rays, 0, "beyond what a double counts");
    cr_assert_eq(st.shadow_rays, 0, "beyond 2^53");
    cr_assert_eq(st.secondary_rays, 0, "negative");
    cr_assert_eq(st.rays_per_second, 0, "null");
    cr_assert_eq(st.prepare_ms, 1e308, "large, but a time");
    cr_assert_eq(st.primitives, 7, "beside the others");
    cr_assert_eq(st.curve_len, 1);
    st = read_text("{\"samples\": 3000000000, \"stats\": [1, 2], \"curve\": 5}", JOB_PARTS);
    cr_assert_eq(st.samples, 0, "beyond an int");
    cr_assert_eq(st.camera_rays, 0, "stats not an object");
    cr_assert_eq(st.curve_len, 0, "not an array");
    /* The costs are where parts says: beside the others in a flat object. */
    st = read_text("{\"camera_rays\": 5, \"stats\": {\"camera_rays\": 6}}", RD_STATS_COSTS);
    cr_assert_eq(st.camera_rays, 5);
    st = read_text("{\"camera_rays\": 5, \"stats\": {\"camera_rays\": 6}}", RD_STATS_COSTS | RD_STATS_NESTED);
    cr_assert_eq(st.camera_rays, 6);
    rd_stats_read(NULL, &st, JOB_PARTS);
    cr_assert_eq(st.samples + st.passes + st.curve_len, 0, "no text: nothing");
}

Test(json_text, only_the_curve_shape_reads_as_a_curve)
{
    rd_curve_point c[RD_CURVE_MAX];
    int n = 7;
    static const char *const refused[] = {
        "[{\"ms\": 1, \"samples\": 2, \"error\": 3}]", /* the points rayd render wrote before */
        "[[1, 2]]",
        "[[1, 2, 3, 4]]",
        "[[1, \"2\", 3]]",
        "[[1, 2, 3], 4]",
        "{\"0\": [1, 2, 3]}",
    };
    for (size_t i = 0; i < sizeof refused / sizeof refused[0]; i++) {
        cJSON *a = cJSON_Parse(refused[i]);
        cr_assert_eq(rd_json_curve_read(a, c, &n), -1, "%s was read", refused[i]);
        cr_assert_eq(n, 0);
        cJSON_Delete(a);
    }
    char text[RD_CURVE_MAX * 16 + 16] = "[";
    for (int i = 0; i <= RD_CURVE_MAX; i++)
        strcat(text, i ? ",[1,2,3]" : "[1,2,3]");
    strcat(text, "]");
    cJSON *a = cJSON_Parse(text);
    cr_assert_eq(rd_json_curve_read(a, c, &n), -1, "more points than RD_CURVE_MAX");
    cJSON_Delete(a);
    a = cJSON_Parse("[]");
    cr_assert_eq(rd_json_curve_read(a, c, &n), 0);
    cr_assert_eq(n, 0);
    cJSON_Delete(a);
}
