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
    int tiles_done_before; /* for progress across passes */
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

static void notify_pass(const rd_render_options *opt, const rd_job *job, int pass, int samples)
{
    if (!opt->pass)
        return;
    rd_render_stats st;
    if (pass > 0)
        rd_job_stats(job, &st);
    opt->pass(opt->user, pass, samples, pass > 0 ? &st.curve[st.curve_len - 1] : NULL);
}

/* The passes of a job on the option's threads, its statistics, and its
 * image: into *img (unless NULL) or as 8-bit values into rgb8. */
static rd_error_code run(const rd_scene *s, const rd_render_options *opt_in, rd_image *img, uint8_t *rgb8,
                         rd_render_stats *stats, rd_error *err)
{
    double t0 = rd_now_ms();
    rd_render_options opt = {0};
    if (opt_in)
        opt = *opt_in;
    memset(stats, 0, sizeof *stats);
    int threads = opt.threads < 1 ? 1 : opt.threads;
    rd_job_options jo = {opt.tile,
                         {s->render.samples, opt.time_budget_ms, opt.target_error, opt.adaptive},
                         opt.threads,
                         opt.packets,
                         rgb8};
    rd_job *job;
    rd_error_code rc = rd_job_create(s, &jo, &job, err);
    if (rc)
        return rc;
    rd_job_set_cancel(job, opt.cancel);
    worker *ws = aligned_alloc(128, ((size_t)threads * sizeof(worker) + 127) / 128 * 128);
    if (!ws) {
        rd_job_free(job);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    }
    memset(ws, 0, (size_t)threads * sizeof *ws);
    shared sh;
    memset(&sh, 0, sizeof sh);
    sh.job = job;
    sh.opt = &opt;
    sh.tiles_all = rd_job_tile_count(job);
    int cancelled = 0, used = 1, pass = 0;
    for (int n = rd_job_first_pass(job); n > 0; n = rd_job_end_pass(job)) {
        notify_pass(&opt, job, pass++, n);
        used = run_pass(&sh, ws, threads);
        for (int i = 0; i < threads; i++)
            cancelled |= ws[i].cancelled;
        if (cancelled)
            break;
        sh.tiles_done_before += sh.tiles_all;
    }
    rd_job_counts all = {0, 0, 0, 0};
    for (int i = 0; i < threads; i++) {
        all.camera += ws[i].counts.camera;
        all.shadow += ws[i].counts.shadow;
        all.secondary += ws[i].counts.secondary;
        all.nonfinite += ws[i].counts.nonfinite;
    }
    free(ws);
    if (!cancelled)
        notify_pass(&opt, job, pass, 0);
    if (cancelled) {
        rd_job_free(job);
        return rd_error_set(err, RD_ERR_CANCELLED, 0, 0, "render cancelled");
    }
    rd_job_stats(job, stats);
    if (img)
        rd_job_take_image(job, img);
    else
        rd_job_rgb8(job, rgb8);
    rd_job_free(job);
    stats->threads = used;
    rd_stats_add_counts(stats, &all, rd_now_ms() - t0);
    return RD_OK;
}

rd_error_code rd_render(const rd_scene *s, const rd_render_options *opt, rd_image *out, rd_render_stats *stats,
                        rd_error *err)
{
    memset(out, 0, sizeof *out);
    return run(s, opt, out, NULL, stats, err);
}

rd_error_code rd_render_rgb8(const rd_scene *s, const rd_render_options *opt, uint8_t *out, rd_render_stats *stats,
                             rd_error *err)
{
    return run(s, opt, NULL, out, stats, err);
}
