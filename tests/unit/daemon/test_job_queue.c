/* The job queue (daemon/jobs/job_queue.h) without HTTP: eviction, the memory
 * budget, bounded cancellation, internal work. Properties only; nothing
 * here depends on how fast the machine is, only bounds that hold with
 * orders of magnitude to spare. */
#include <criterion/criterion.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "job_queue.h"
#include "rayd/clock.h"
#include "rayd/job.h"
#include "scene_load.h"

static const char small_scene[] = "[render]\nwidth = 8\nheight = 8\n"
                                  "[light]\ntype = point\nposition = 0 5 5\ncolor = 1 1 1\n"
                                  "[material m]\ntype = diffuse\nkd = 0.5 0.5 0.5\n"
                                  "[sphere]\ncenter = 0 0 0\nradius = 1\nmaterial = m\n";

/* One pixel takes minutes: 65536 samples under a 64x64-sample area light. */
static const char runaway_scene[] = "[render]\nwidth = 4\nheight = 1\nsamples = 65536\n"
                                    "[camera]\neye = 0 2 6\ntarget = 0 0.5 0\n"
                                    "[light]\ntype = area\ncorner = -1 6 -1\nedge1 = 2 0 0\nedge2 = 0 0 2\n"
                                    "samples = 64\ncolor = 1 1 1\n"
                                    "[material m]\ntype = diffuse\nkd = 0.7 0.7 0.7\n"
                                    "[sphere]\ncenter = 0 0.8 0\nradius = 0.8\nmaterial = m\n"
                                    "[plane]\npoint = 0 0 0\nnormal = 0 1 0\nmaterial = m\n";

static rd_jq_options options(void)
{
    rd_jq_options o;
    memset(&o, 0, sizeof o);
    o.workers = 2;
    o.queue_length = 64;
    o.result_memory = 64u << 20;
    o.result_ttl_ms = 600e3;
    o.kept_max = 4096;
    o.png = rd_png_options_default();
    return o;
}

static rd_jq_job *submit(rd_jq *q, const char *text, const char *query_w, rd_error_code want)
{
    rd_scene s;
    rd_scene_init(&s);
    rd_error err = {0};
    cr_assert_eq(rd_scene_parse(text, strlen(text), RD_FMT_CFG, "<t>", NULL, &s, &err), RD_OK, "%s", err.message);
    if (query_w) {
        s.render.width = atoi(query_w);
        s.render.height = s.render.width;
    }
    rd_jq_job *j = NULL;
    rd_jq_submit_options so = {.watch_fd = -1};
    cr_assert_eq(rd_jq_submit_scene(q, &s, &so, &j, &err), want, "%s", err.message);
    return j;
}

static rd_jq_status status_of(rd_jq *q, rd_jq_job *j)
{
    rd_jq_info in;
    rd_jq_info_get(q, j, &in);
    return in.status;
}

/* How long a wait for a job's status may take: orders of magnitude more
 * than any wait here needs. (second_job_waits_for_memory once failed in
 * loaded runs: its younger job had started first and the older waited
 * behind a runaway; an_older_job_in_preparation_keeps_its_place holds
 * that order.) */
#define WAIT_MS 10000.0

/* Polls until the job reaches st or timeout_ms passes; the time it took. */
static double wait_status(rd_jq *q, rd_jq_job *j, rd_jq_status st, double timeout_ms)
{
    double t0 = rd_now_ms();
    while (status_of(q, j) != st && rd_now_ms() - t0 < timeout_ms) {
        struct timespec ts = {0, 1000000};
        nanosleep(&ts, NULL);
    }
    if (status_of(q, j) != st) {
        /* What the queue was doing, for a failure that does not reproduce. */
        rd_jq_metrics m;
        rd_jq_metrics_get(q, &m);
        cr_assert_fail("status %s, not %s, after %.0f ms; the queue: %zu running, %zu waiting for memory, %zu bytes "
                       "reserved",
                       rd_jq_status_name(status_of(q, j)), rd_jq_status_name(st), timeout_ms, (size_t)m.running,
                       (size_t)m.waiting_memory, (size_t)m.memory_reserved);
    }
    return rd_now_ms() - t0;
}

Test(job_queue, eviction_drops_the_oldest_finished)
{
    rd_jq_options o = options();
    o.kept_max = 3;
    rd_error err;
    rd_jq *q = rd_jq_start(&o, &err);
    cr_assert_not_null(q);
    char ids[6][RD_CAP_MAX];
    for (int i = 0; i < 6; i++) {
        rd_jq_job *j = submit(q, small_scene, NULL, RD_OK);
        wait_status(q, j, RD_JQ_DONE, WAIT_MS);
        rd_jq_info in;
        rd_jq_info_get(q, j, &in);
        memcpy(ids[i], in.id, sizeof ids[i]);
        rd_jq_job_unref(j);
    }
    for (int i = 0; i < 6; i++) {
        rd_jq_job *f = rd_jq_find(q, ids[i]);
        if (i < 3)
            cr_assert_null(f, "job %d of 6 kept past --max-jobs-kept 3", i);
        else
            cr_assert_not_null(f, "job %d of 6, among the newest 3, was dropped", i);
        if (f)
            rd_jq_job_unref(f);
    }
    rd_jq_metrics m;
    rd_jq_metrics_get(q, &m);
    cr_assert_eq(m.jobs_kept, 3);
    rd_jq_free(q);
}

/* /metrics' render and queue-wait histograms reach the job timeout (with
 * none, an hour), and count every job the queue started. */
Test(job_queue, histograms_cover_the_job_timeout)
{
    static const double timeouts[] = {0, 5000, 120000, 600000, 86400e3};
    for (size_t i = 0; i < sizeof timeouts / sizeof timeouts[0]; i++) {
        rd_jq_options o = options();
        o.job_timeout_ms = timeouts[i];
        rd_error err;
        rd_jq *q = rd_jq_start(&o, &err);
        cr_assert_not_null(q);
        for (int k = 0; k < 2; k++) {
            rd_jq_job *j = submit(q, small_scene, NULL, RD_OK);
            wait_status(q, j, RD_JQ_DONE, WAIT_MS);
            rd_jq_job_unref(j);
        }
        rd_jq_metrics m;
        rd_jq_metrics_get(q, &m);
        double cover = timeouts[i] > 0 ? timeouts[i] / 1e3 : 3600;
        const rd_hist *h[] = {&m.render_seconds, &m.queue_wait_seconds};
        for (int k = 0; k < 2; k++) {
            cr_assert_geq(h[k]->le[h[k]->n - 1], cover, "timeout %g ms: histogram %d ends at %g s", timeouts[i], k,
                          h[k]->le[h[k]->n - 1]);
            cr_assert_eq(h[k]->le[0], 0.005);
            cr_assert_eq(h[k]->total, 2, "histogram %d counted %llu jobs of 2", k, (unsigned long long)h[k]->total);
            cr_assert_geq(h[k]->sum, 0);
        }
        rd_jq_free(q);
    }
}

/* Past the id table's first 64 slots and its growth: the newest kept_max
 * stay findable by id, the older ones and ids that are not ours are not. */
Test(job_queue, many_jobs_keep_exactly_the_newest)
{
    enum { N = 300, KEEP = 100 };
    rd_jq_options o = options();
    o.kept_max = KEEP;
    rd_error err;
    rd_jq *q = rd_jq_start(&o, &err);
    cr_assert_not_null(q);
    static char ids[N][RD_CAP_MAX];
    for (int i = 0; i < N; i++) {
        rd_jq_job *j = submit(q, small_scene, NULL, RD_OK);
        wait_status(q, j, RD_JQ_DONE, WAIT_MS);
        rd_jq_info in;
        rd_jq_info_get(q, j, &in);
        memcpy(ids[i], in.id, sizeof ids[i]);
        rd_jq_job_unref(j);
    }
    for (int i = 0; i < N; i++) {
        rd_jq_job *f = rd_jq_find(q, ids[i]);
        cr_assert_eq(f != NULL, i >= N - KEEP, "job %d of %d: %s", i, N, f ? "kept" : "dropped");
        if (f)
            rd_jq_job_unref(f);
    }
    char other[40];
    snprintf(other, sizeof other, "%sx", ids[N - 1]);
    cr_assert_null(rd_jq_find(q, other), "an id with a character more was found");
    cr_assert_null(rd_jq_find(q, ids[N - 1] + 1), "an id with a character less was found");
    cr_assert_null(rd_jq_find(q, ""), "the empty id was found");
    rd_jq_metrics m;
    rd_jq_metrics_get(q, &m);
    cr_assert_eq(m.jobs_kept, KEEP);
    rd_jq_free(q);
}

/* Over the result memory the oldest images go first, and their jobs stay
 * readable with a status that says so. */
Test(job_queue, result_memory_drops_the_oldest_images)
{
    rd_jq_options o = options();
    rd_error err;
    rd_jq *q = rd_jq_start(&o, &err);
    cr_assert_not_null(q);
    rd_jq_job *first = submit(q, small_scene, NULL, RD_OK);
    wait_status(q, first, RD_JQ_DONE, WAIT_MS);
    unsigned char *png;
    size_t len;
    cr_assert_eq(rd_jq_png(q, first, 0, &png, &len, &err), RD_OK, "%s", err.message);
    free(png);
    rd_jq_free(q);

    /* Room for two images of that size, not three. */
    o.result_memory = len * 5 / 2;
    q = rd_jq_start(&o, &err);
    cr_assert_not_null(q);
    rd_jq_job *jobs[5];
    for (int i = 0; i < 5; i++) {
        jobs[i] = submit(q, small_scene, NULL, RD_OK);
        wait_status(q, jobs[i], RD_JQ_DONE, WAIT_MS);
    }
    for (int i = 0; i < 5; i++) {
        rd_error_code rc = rd_jq_png(q, jobs[i], 0, &png, &len, &err);
        cr_assert_eq(rc == RD_OK, i >= 3, "image %d of 5: %s", i, rc == RD_OK ? "kept" : err.message);
        if (rc == RD_OK)
            free(png);
        else
            cr_assert(strstr(err.message, "--result-memory"), "%s", err.message);
        cr_assert_eq(status_of(q, jobs[i]), RD_JQ_DONE);
        rd_jq_job_unref(jobs[i]);
    }
    rd_jq_free(q);
}

/* Fair share: with one render thread busy on a job of 256 tiles, a job of
 * one tile is given the next tile once it is prepared, so the big job moves
 * on by about one tile meanwhile, not by all it has left. Preparing runs on
 * its own thread, whose delay on a loaded machine is not measured: only the
 * big job's tiles between the small one being prepared and its end. */
Test(job_queue, a_small_job_overtakes_a_big_one)
{
    rd_jq_options o = options();
    o.workers = 1;
    rd_error err;
    rd_jq *q = rd_jq_start(&o, &err);
    cr_assert_not_null(q);
    static const char big_scene[] = "[render]\nwidth = 256\nheight = 256\nsamples = 64\n"
                                    "[light]\ntype = point\nposition = 0 5 5\ncolor = 1 1 1\n"
                                    "[material m]\ntype = diffuse\nkd = 0.5 0.5 0.5\n"
                                    "[sphere]\ncenter = 0 0 0\nradius = 1\nmaterial = m\n";
    rd_jq_job *big = submit(q, big_scene, NULL, RD_OK);
    wait_status(q, big, RD_JQ_RUNNING, WAIT_MS);
    rd_jq_job *small = submit(q, small_scene, NULL, RD_OK);
    rd_jq_info in, bin;
    for (rd_jq_info_get(q, small, &in); !in.prepared; rd_jq_info_get(q, small, &in)) {
        struct timespec ts = {0, 200000};
        nanosleep(&ts, NULL);
    }
    rd_jq_info_get(q, big, &bin);
    double p0 = bin.progress;
    wait_status(q, small, RD_JQ_DONE, 60000);
    rd_jq_info_get(q, big, &bin);
    cr_assert_eq(bin.status, RD_JQ_RUNNING, "the big job ended before the small one");
    double tiles = (bin.progress - p0) * 256;
    cr_assert_leq(tiles, 16, "the big job rendered %.0f tiles while the small one waited", tiles);
    rd_jq_cancel(q, big);
    rd_jq_job_unref(big);
    rd_jq_job_unref(small);
    rd_jq_free(q);
}

/* A finished job is readable for --result-ttl, then gone. */
Test(job_queue, finished_jobs_expire_after_their_ttl)
{
    rd_jq_options o = options();
    o.result_ttl_ms = 2000;
    rd_error err;
    rd_jq *q = rd_jq_start(&o, &err);
    cr_assert_not_null(q);
    rd_jq_job *j = submit(q, small_scene, NULL, RD_OK);
    wait_status(q, j, RD_JQ_DONE, WAIT_MS);
    rd_jq_info in;
    rd_jq_info_get(q, j, &in);
    rd_jq_job_unref(j);
    rd_jq_job *f = rd_jq_find(q, in.id);
    cr_assert_not_null(f, "gone at once");
    rd_jq_job_unref(f);
    struct timespec ts = {2, 200000000};
    nanosleep(&ts, NULL);
    cr_assert_null(rd_jq_find(q, in.id), "still there after its TTL");
    rd_jq_metrics m;
    rd_jq_metrics_get(q, &m);
    cr_assert_eq(m.jobs_kept, 0);
    rd_jq_free(q);
}

Test(job_queue, job_over_the_budget_fails_naming_the_flag)
{
    rd_jq_options o = options();
    o.memory_budget = 1u << 20;
    rd_error err;
    rd_jq *q = rd_jq_start(&o, &err);
    rd_jq_job *j = submit(q, small_scene, "1024", RD_OK);
    wait_status(q, j, RD_JQ_FAILED, WAIT_MS);
    rd_jq_info in;
    rd_jq_info_get(q, j, &in);
    cr_assert_eq(in.error.code, RD_ERR_LIMIT);
    cr_assert(strstr(in.error.message, "--memory-budget"), "%s", in.error.message);
    rd_jq_job_unref(j);
    rd_jq_free(q);
}

/* A budget with room for one and a half 512x512 runaway renders. */
static rd_jq_options options_for_one_and_a_half(void)
{
    rd_jq_options o = options();
    rd_error err;
    rd_scene s;
    rd_scene_init(&s);
    cr_assert_eq(rd_scene_parse(runaway_scene, strlen(runaway_scene), RD_FMT_CFG, "<t>", NULL, &s, &err), RD_OK);
    s.render.width = s.render.height = 512;
    rd_job_options jo = {RD_JOB_TILE, {0}, 1, 0, NULL};
    size_t need = rd_job_estimate_bytes(&s, &jo);
    rd_scene_free(&s);
    o.memory_budget = need + need / 2;
    return o;
}

Test(job_queue, second_job_waits_for_memory)
{
    rd_jq_options o = options_for_one_and_a_half();
    rd_error err;
    rd_jq *q = rd_jq_start(&o, &err);
    rd_jq_job *a = submit(q, runaway_scene, "512", RD_OK);
    rd_jq_job *b = submit(q, runaway_scene, "512", RD_OK);
    wait_status(q, a, RD_JQ_RUNNING, WAIT_MS);
    rd_jq_metrics m;
    for (int i = 0; i < 2000; i++) {
        rd_jq_metrics_get(q, &m);
        if (m.waiting_memory == 1)
            break;
        struct timespec ts = {0, 1000000};
        nanosleep(&ts, NULL);
    }
    cr_assert_eq(m.waiting_memory, 1, "the second job did not wait for memory");
    cr_assert_eq(m.running, 1);
    cr_assert_eq(status_of(q, b), RD_JQ_QUEUED);
    cr_assert_leq(m.memory_reserved, o.memory_budget);
    rd_jq_cancel(q, a);
    wait_status(q, b, RD_JQ_RUNNING, WAIT_MS);
    rd_jq_cancel(q, b);
    wait_status(q, b, RD_JQ_CANCELLED, WAIT_MS);
    rd_jq_job_unref(a);
    rd_jq_job_unref(b);
    rd_jq_free(q);
}

/* A runaway 512x512 scene, prepared slowly: its preparation is still
 * running when a younger job's has ended (shared/review's queue-order
 * reproducer, without a debugger). */
static rd_error_code slow_runaway(void *arg, rd_scene *scene, int *render, rd_error *err)
{
    (void)arg, (void)render;
    struct timespec ts = {0, 100 * 1000000L};
    nanosleep(&ts, NULL);
    rd_error_code rc = rd_scene_parse(runaway_scene, strlen(runaway_scene), RD_FMT_CFG, "<t>", NULL, scene, err);
    scene->render.width = scene->render.height = 512;
    return rc;
}

/* Jobs start in the order they were submitted when memory is short: the
 * older one, though its preparation ends last, runs; the younger waits. */
Test(job_queue, an_older_job_in_preparation_keeps_its_place)
{
    rd_jq_options o = options_for_one_and_a_half();
    rd_error err;
    rd_jq *q = rd_jq_start(&o, &err);
    rd_jq_task slow = {slow_runaway, NULL, NULL, NULL, 0, NULL};
    rd_jq_submit_options so = {.watch_fd = -1};
    rd_jq_job *a = NULL;
    cr_assert_eq(rd_jq_submit(q, &slow, &so, &a, &err), RD_OK, "%s", err.message);
    rd_jq_job *b = submit(q, runaway_scene, "512", RD_OK);
    wait_status(q, a, RD_JQ_RUNNING, WAIT_MS);
    cr_assert_eq(status_of(q, b), RD_JQ_QUEUED, "the younger job started ahead of the older one");
    rd_jq_cancel(q, a);
    wait_status(q, b, RD_JQ_RUNNING, WAIT_MS);
    rd_jq_cancel(q, b);
    wait_status(q, b, RD_JQ_CANCELLED, WAIT_MS);
    rd_jq_job_unref(a);
    rd_jq_job_unref(b);
    rd_jq_free(q);
}

/* Both threads inside one pixel each: cancel still ends them at once. */
Test(job_queue, cancel_stops_a_runaway_render_inside_a_pixel)
{
    rd_jq_options o = options();
    rd_error err;
    rd_jq *q = rd_jq_start(&o, &err);
    rd_jq_job *a = submit(q, runaway_scene, NULL, RD_OK);
    rd_jq_job *b = submit(q, runaway_scene, NULL, RD_OK);
    wait_status(q, a, RD_JQ_RUNNING, WAIT_MS);
    wait_status(q, b, RD_JQ_RUNNING, WAIT_MS);
    struct timespec settle = {0, 50 * 1000000L};
    nanosleep(&settle, NULL);
    cr_assert_eq(rd_jq_cancel(q, a), 1);
    double ms = wait_status(q, a, RD_JQ_CANCELLED, 5000);
    cr_log_info("cancelled within %.1f ms", ms);
    cr_assert_eq(status_of(q, b), RD_JQ_RUNNING, "cancelling one job stopped the other");
    rd_jq_info info;
    rd_jq_info_get(q, a, &info);
    cr_assert(info.requested, "a cancel on request says so (its client answers 409, not 503)");
    cr_assert(rd_cap_valid(info.id, 0), "a job's id is a capability: %s", info.id);
    rd_jq_cancel_all(q);
    wait_status(q, b, RD_JQ_CANCELLED, 5000);
    rd_jq_info_get(q, b, &info);
    cr_assert_not(info.requested, "a stop's cancel is not a request's (its client answers 503)");
    rd_jq_job_unref(a);
    rd_jq_job_unref(b);
    /* Stopping the queue joins both threads. */
    double t0 = rd_now_ms();
    rd_jq_free(q);
    cr_assert_lt(rd_now_ms() - t0, 5000, "rd_jq_stop waited for a runaway render");
}

Test(job_queue, timeout_fails_with_its_own_code)
{
    rd_jq_options o = options();
    o.job_timeout_ms = 200;
    rd_error err;
    rd_jq *q = rd_jq_start(&o, &err);
    rd_jq_job *j = submit(q, runaway_scene, NULL, RD_OK);
    wait_status(q, j, RD_JQ_FAILED, WAIT_MS);
    rd_jq_info in;
    rd_jq_info_get(q, j, &in);
    cr_assert_eq(in.error.code, RD_ERR_TIMEOUT);
    cr_assert_geq(in.elapsed_ms, 200);
    cr_assert(strstr(in.error.message, "--job-timeout-ms"), "%s", in.error.message);
    rd_jq_job_unref(j);
    rd_jq_free(q);
}

Test(job_queue, full_queue_is_busy)
{
    rd_jq_options o = options();
    o.queue_length = 2;
    o.workers = 1;
    rd_error err;
    rd_jq *q = rd_jq_start(&o, &err);
    rd_jq_job *a = submit(q, runaway_scene, NULL, RD_OK);
    rd_jq_job *b = submit(q, runaway_scene, NULL, RD_OK);
    submit(q, small_scene, NULL, RD_ERR_BUSY);
    rd_jq_cancel(q, a);
    rd_jq_cancel(q, b);
    rd_jq_job_unref(a);
    rd_jq_job_unref(b);
    rd_jq_free(q);
}

static rd_error_code no_render(void *arg, rd_scene *s, int *render, rd_error *err)
{
    (void)s, (void)err;
    atomic_int *ran = arg;
    atomic_store(ran, 1);
    *render = 0;
    return RD_OK;
}

Test(job_queue, internal_work_is_neither_listed_nor_counted)
{
    rd_jq_options o = options();
    rd_error err;
    rd_jq *q = rd_jq_start(&o, &err);
    static atomic_int ran;
    rd_jq_task t = {no_render, NULL, NULL, &ran, 0, NULL};
    rd_jq_submit_options so = {.watch_fd = -1, .internal = 1};
    rd_jq_job *j;
    cr_assert_eq(rd_jq_submit(q, &t, &so, &j, &err), RD_OK);
    wait_status(q, j, RD_JQ_DONE, WAIT_MS);
    cr_assert(atomic_load(&ran));
    rd_jq_info in;
    rd_jq_info_get(q, j, &in);
    rd_jq_job *f = rd_jq_find(q, in.id);
    cr_assert_null(f, "internal work can be found by id");
    rd_jq_metrics m;
    rd_jq_metrics_get(q, &m);
    cr_assert_eq(m.done, 0);
    cr_assert_eq(m.jobs_kept, 0);
    rd_jq_job_unref(j);
    rd_jq_free(q);
}

static rd_error_code bad_scene(void *arg, rd_scene *s, int *render, rd_error *err)
{
    (void)arg, (void)s, (void)render;
    return rd_error_set(err, RD_ERR_SYNTAX, 1, 1, "<t>:1:1: not a scene");
}

/* Reading a scene never waits for a tile: both render threads are inside
 * one pixel each, and a bad scene still fails at once. */
Test(job_queue, preparing_does_not_wait_for_busy_render_threads)
{
    rd_jq_options o = options();
    rd_error err;
    rd_jq *q = rd_jq_start(&o, &err);
    rd_jq_job *a = submit(q, runaway_scene, NULL, RD_OK);
    rd_jq_job *b = submit(q, runaway_scene, NULL, RD_OK);
    wait_status(q, a, RD_JQ_RUNNING, WAIT_MS);
    wait_status(q, b, RD_JQ_RUNNING, WAIT_MS);
    rd_jq_task t = {bad_scene, NULL, NULL, NULL, 0, NULL};
    rd_jq_submit_options so = {.watch_fd = -1};
    rd_jq_job *c;
    cr_assert_eq(rd_jq_submit(q, &t, &so, &c, &err), RD_OK);
    double ms = wait_status(q, c, RD_JQ_FAILED, 5000);
    cr_log_info("a bad scene failed %.1f ms after submission, render threads busy", ms);
    rd_jq_info in;
    rd_jq_info_get(q, c, &in);
    cr_assert_eq(in.error.code, RD_ERR_SYNTAX);
    cr_assert_eq(status_of(q, a), RD_JQ_RUNNING);
    rd_jq_job_unref(a);
    rd_jq_job_unref(b);
    rd_jq_job_unref(c);
    rd_jq_free(q);
}

/* A preparation that holds memory (a code grade's sandbox): it counts how
 * many run at once and stays until released. */
typedef struct {
    atomic_int running, most, release;
} held_prep;

static rd_error_code hold_memory(void *arg, rd_scene *s, int *render, rd_error *err)
{
    (void)s, (void)err;
    held_prep *h = arg;
    int now = atomic_fetch_add(&h->running, 1) + 1;
    for (int m = atomic_load(&h->most); now > m && !atomic_compare_exchange_weak(&h->most, &m, now);)
        ;
    while (!atomic_load(&h->release)) {
        struct timespec ts = {0, 1000000};
        nanosleep(&ts, NULL);
    }
    atomic_fetch_sub(&h->running, 1);
    *render = 0;
    return RD_OK;
}

/* Preparations reserving 60% of the budget each run one at a time (and a
 * free thread does not start the second), one over the budget is refused
 * at submission, and the reservation is given back. */
Test(job_queue, preparations_wait_for_their_memory)
{
    rd_jq_options o = options();
    o.workers = 3;
    o.memory_budget = 100u << 20;
    rd_error err;
    rd_jq *q = rd_jq_start(&o, &err);
    static held_prep h;
    rd_jq_task t = {hold_memory, NULL, NULL, &h, 0, NULL};
    rd_jq_submit_options so = {.watch_fd = -1, .internal = 1, .prepare_bytes = 60u << 20};
    rd_jq_job *a, *b, *c;
    cr_assert_eq(rd_jq_submit(q, &t, &so, &a, &err), RD_OK);
    cr_assert_eq(rd_jq_submit(q, &t, &so, &b, &err), RD_OK);
    so.prepare_bytes = 101u << 20;
    cr_assert_eq(rd_jq_submit(q, &t, &so, &c, &err), RD_ERR_LIMIT);
    cr_assert_not_null(strstr(err.message, "--memory-budget"), "%s", err.message);
    double t0 = rd_now_ms();
    while (atomic_load(&h.running) == 0 && rd_now_ms() - t0 < WAIT_MS) {
        struct timespec ts = {0, 1000000};
        nanosleep(&ts, NULL);
    }
    struct timespec settle = {0, 200000000}; /* time for a wrong second start */
    nanosleep(&settle, NULL);
    cr_assert_eq(atomic_load(&h.most), 1, "%d preparations of 60%% of the budget ran at once", atomic_load(&h.most));
    atomic_store(&h.release, 1);
    wait_status(q, a, RD_JQ_DONE, WAIT_MS);
    wait_status(q, b, RD_JQ_DONE, WAIT_MS);
    cr_assert_eq(atomic_load(&h.most), 1);
    rd_jq_metrics m;
    rd_jq_metrics_get(q, &m);
    cr_assert_eq(m.memory_reserved, 0, "%zu bytes still reserved", (size_t)m.memory_reserved);
    rd_jq_job_unref(a);
    rd_jq_job_unref(b);
    rd_jq_free(q);
}

/* A source that always has work: each unit takes about a millisecond and
 * notes what the queue told it. */
typedef struct {
    atomic_int units, stops, max_inside, inside;
    atomic_int bad_worker;
    atomic_llong last_room;
    int workers;
} busy_source;

static int busy_run(void *arg, int worker, size_t room)
{
    busy_source *b = arg;
    if (worker < 0 || worker >= b->workers)
        atomic_store(&b->bad_worker, 1);
    int in = atomic_fetch_add(&b->inside, 1) + 1;
    if (in > atomic_load(&b->max_inside))
        atomic_store(&b->max_inside, in);
    atomic_store(&b->last_room, room == SIZE_MAX ? -1 : (long long)room);
    struct timespec ts = {0, 1000000};
    nanosleep(&ts, NULL);
    atomic_fetch_sub(&b->inside, 1);
    atomic_fetch_add(&b->units, 1);
    return 0;
}

static void busy_stop(void *arg)
{
    busy_source *b = arg;
    atomic_fetch_add(&b->stops, 1);
}

/* One render thread: a job of the queue's own finishes while the source
 * always has work, and the source goes on getting units meanwhile (the
 * fair share alternates them); the source never runs on more threads than
 * there are, and is told to stop once. */
Test(job_queue, a_source_shares_the_render_threads)
{
    rd_jq_options o = options();
    o.workers = 1;
    rd_error err = {0};
    rd_jq *q = rd_jq_start(&o, &err);
    cr_assert(q, "%s", err.message);
    busy_source b = {.workers = 1};
    rd_jq_source src = {busy_run, busy_stop, &b};
    rd_jq_set_source(q, &src);
    /* 64x64 pixels: 16 tiles of 16x16 (RD_JOB_TILE), each far under a second. */
    rd_jq_job *j = submit(q, small_scene, "64", RD_OK);
    double t0 = rd_now_ms();
    while (status_of(q, j) != RD_JQ_RUNNING && status_of(q, j) != RD_JQ_DONE && rd_now_ms() - t0 < WAIT_MS)
        nanosleep(&(struct timespec){0, 100000}, NULL);
    int at_start = atomic_load(&b.units);
    cr_assert_lt(wait_status(q, j, RD_JQ_DONE, WAIT_MS), WAIT_MS, "the queue's job starved beside the source");
    int during = atomic_load(&b.units) - at_start;
    rd_jq_info in;
    rd_jq_info_get(q, j, &in);
    cr_assert_eq(in.status, RD_JQ_DONE);
    cr_assert_geq(during, 4, "the source got %d units while a 16-tile job ran: starved", during);
    cr_assert_eq(atomic_load(&b.max_inside), 1, "the source ran on %d threads at once with one render thread",
                 atomic_load(&b.max_inside));
    cr_assert_eq(atomic_load(&b.bad_worker), 0, "a worker index out of range");
    rd_jq_job_unref(j);
    rd_jq_stop(q);
    cr_assert_eq(atomic_load(&b.stops), 1);
    int after_stop = atomic_load(&b.units);
    nanosleep(&(struct timespec){0, 20000000}, NULL);
    cr_assert_eq(atomic_load(&b.units), after_stop, "the source ran after rd_jq_stop returned");
    rd_jq_free(q);
}

/* Under a budget the source is handed the room the queue's one rule
 * leaves: everything while nothing else runs, and no more than the budget
 * minus what a running job holds while one does (two threads: one inside
 * the runaway's only tile, one for the source). */
Test(job_queue, a_source_gets_the_room_the_budget_leaves)
{
    rd_jq_options o = options();
    o.workers = 2;
    o.memory_budget = 256u << 20;
    rd_error err = {0};
    rd_jq *q = rd_jq_start(&o, &err);
    cr_assert(q, "%s", err.message);
    busy_source b = {.workers = 2};
    rd_jq_source src = {busy_run, NULL, &b};
    rd_jq_set_source(q, &src);
    double t0 = rd_now_ms();
    while (atomic_load(&b.units) < 3 && rd_now_ms() - t0 < WAIT_MS)
        nanosleep(&(struct timespec){0, 100000}, NULL);
    cr_assert_eq(atomic_load(&b.last_room), -1, "with nothing running the source may take anything");
    rd_jq_job *j = submit(q, runaway_scene, NULL, RD_OK);
    t0 = rd_now_ms();
    while (status_of(q, j) != RD_JQ_RUNNING && rd_now_ms() - t0 < WAIT_MS)
        nanosleep(&(struct timespec){0, 100000}, NULL);
    int seen = atomic_load(&b.units);
    while (atomic_load(&b.units) < seen + 3 && rd_now_ms() - t0 < WAIT_MS)
        nanosleep(&(struct timespec){0, 100000}, NULL);
    rd_jq_metrics m;
    rd_jq_metrics_get(q, &m);
    long long room = atomic_load(&b.last_room);
    cr_assert_eq(m.running, 1);
    cr_assert(room >= 0 && (size_t)room <= o.memory_budget - m.memory_reserved,
              "room %lld beside a running job holding %zu of %zu", room, m.memory_reserved, o.memory_budget);
    rd_jq_cancel(q, j);
    rd_jq_job_unref(j);
    rd_jq_free(q);
}
