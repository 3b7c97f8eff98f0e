#include "rayd/render.h"

#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "rayd/clock.h"
#include "rayd/job.h"
#include "trace.h"

typedef struct {
    rd_job *job;
    const rd_render_options *opt;
    atomic_int next, done;
    int tiles_done_before;      /* for progress across passes */
    int tiles_all;
} shared;

/* Each worker's counters on cache lines of their own: they change on every
 * ray, and sharing a line between threads serialises them. */
typedef struct {
    _Alignas(128) shared *sh;
    rd_job_counts counts;
    int cancelled;
    pthread_t tid;
} worker;

static void *work(void *arg)
{
    worker *w = arg;
    shared *sh = w->sh;
    int total = rd_job_tile_count(sh->job);
    for (;;) {
        if (sh->opt->cancel && atomic_load(sh->opt->cancel)) {
            w->cancelled = 1;
            break;
        }
        int t = atomic_fetch_add(&sh->next, 1);
        if (t >= total)
            break;
        if (!rd_job_render_tile(sh->job, t, &w->counts)) {
            w->cancelled = 1;
            break;
        }
        int done = atomic_fetch_add(&sh->done, 1) + 1;
        if (sh->opt->progress)
            sh->opt->progress(sh->opt->user, sh->tiles_done_before + done, sh->tiles_all);
    }
    return NULL;
}

/* One pass over every tile with `threads` threads (the caller is one). */
static int run_pass(shared *sh, worker *ws, int threads)
{
    atomic_store(&sh->next, 0);
    atomic_store(&sh->done, 0);
    int started = 0;
    for (int i = 0; i < threads; i++) {
        ws[i].sh = sh;
        if (i == 0)
            continue;
        if (pthread_create(&ws[i].tid, NULL, work, &ws[i]) != 0)
            break;
        started = i;
    }
    work(&ws[0]);
    for (int i = 1; i <= started; i++)
        pthread_join(ws[i].tid, NULL);
    return started + 1;
}

rd_error_code rd_render(const rd_scene *s, const rd_render_options *opt_in, rd_image *out,
                        rd_render_stats *stats, rd_error *err)
{
    double t0 = rd_now_ms();
    rd_render_options opt = {0};
    if (opt_in)
        opt = *opt_in;
    memset(out, 0, sizeof *out);
    memset(stats, 0, sizeof *stats);
    int threads = opt.threads < 1 ? 1 : opt.threads;
    rd_progress_settings ps = {s->render.samples, opt.time_budget_ms, opt.target_error, opt.adaptive};
    rd_job_options jo = {opt.tile, rd_progress_is_progressive(&ps), opt.adaptive};

    rd_job *job;
    rd_error_code rc = rd_job_create(s, &jo, &job, err);
    if (rc)
        return rc;
    rd_job_plan_stats(job, stats);
    rd_job_set_cancel(job, opt.cancel);
    worker *ws = aligned_alloc(128, ((size_t)threads * sizeof(worker) + 127) / 128 * 128);
    if (ws)
        memset(ws, 0, (size_t)threads * sizeof *ws);
    if (!ws) {
        rd_job_free(job);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    }
    shared sh;
    memset(&sh, 0, sizeof sh);
    sh.job = job;
    sh.opt = &opt;
    sh.tiles_all = rd_job_tile_count(job);

    int spp = 0, last_spp = 0, cancelled = 0, used = 1;
    double last_ms = 0, error = 0;
    rd_stop_reason why = RD_STOP_NONE;
    for (int pass = 0;; pass++) {
        int n = rd_progress_next(&ps, pass, spp, last_ms, last_spp, rd_now_ms() - t0, error, &why);
        if (n == 0)
            break;
        double p0 = rd_now_ms();
        rd_job_begin_pass(job, pass, n);
        used = run_pass(&sh, ws, threads);
        for (int i = 0; i < threads; i++)
            cancelled |= ws[i].cancelled;
        if (cancelled) {
            why = RD_STOP_CANCELLED;
            break;
        }
        sh.tiles_done_before += sh.tiles_all;
        spp += n;
        last_spp = n;
        last_ms = rd_now_ms() - p0;
        stats->passes = pass + 1;
        /* A fixed render needs the estimate once, at the end. */
        if (rd_progress_is_progressive(&ps) || pass == 0)
            error = rd_job_error_estimate(job);
        if (stats->curve_len < RD_CURVE_MAX) {
            rd_curve_point *cp = &stats->curve[stats->curve_len++];
            cp->ms = rd_now_ms() - t0;
            cp->samples = ps.adaptive ? rd_job_mean_samples(job) : spp;
            cp->error = error;
        }
    }
    for (int i = 0; i < threads; i++) {
        stats->camera_rays += ws[i].counts.camera;
        stats->shadow_rays += ws[i].counts.shadow;
        stats->secondary_rays += ws[i].counts.secondary;
        stats->nonfinite += ws[i].counts.nonfinite;
    }
    free(ws);
    if (cancelled) {
        rd_job_free(job);
        return rd_error_set(err, RD_ERR_CANCELLED, 0, 0, "render cancelled");
    }
    stats->error_estimate = error;
    stats->mean_samples = rd_job_mean_samples(job);
    rd_job_take_image(job, out);
    rd_job_free(job);
    stats->stopped_by = why;
    stats->samples = (int)floor(stats->mean_samples + 0.5);
    stats->threads = used;
    stats->wall_ms = rd_now_ms() - t0;
    uint64_t rays = stats->camera_rays + stats->shadow_rays + stats->secondary_rays;
    stats->rays_per_second = stats->wall_ms > 0 ? rays / (stats->wall_ms / 1e3) : 0;
    return RD_OK;
}
