#include "render.h"

#include <float.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "job.h"

typedef struct {
    rd_job *job;
    int samples;
    const rd_render_options *opt;
    atomic_int next, done;
} shared;

typedef struct {
    shared *sh;
    rd_job_counts counts;
    int cancelled;
    pthread_t tid;
} worker;

double rd_display(double c, double gamma)
{
    c = rd_clamp01(c);
    return gamma == 1 ? c : pow(c, 1.0 / gamma);
}

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
        rd_job_render_tile(sh->job, t, 0, sh->samples, &w->counts);
        int done = atomic_fetch_add(&sh->done, 1) + 1;
        if (sh->opt->progress)
            sh->opt->progress(sh->opt->user, done, total);
    }
    return NULL;
}

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

void rd_image_free(rd_image *img)
{
    free(img->rgb);
    img->rgb = NULL;
    img->width = img->height = 0;
}

rd_error_code rd_render(const rd_scene *s, const rd_render_options *opt_in, rd_image *out,
                        rd_render_stats *stats, rd_error *err)
{
    double t0 = now_ms();
    rd_render_options opt = {0};
    if (opt_in)
        opt = *opt_in;
    memset(out, 0, sizeof *out);
    memset(stats, 0, sizeof *stats);
    int threads = opt.threads < 1 ? 1 : opt.threads;

    rd_job *job;
    rd_error_code rc = rd_job_create(s, opt.tile, &job, err);
    if (rc)
        return rc;
    rd_job_plan_stats(job, stats);
    worker *ws = calloc((size_t)threads, sizeof *ws);
    if (!ws) {
        rd_job_free(job);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    }
    shared sh;
    sh.job = job;
    sh.samples = s->render.samples < 1 ? 1 : s->render.samples;
    sh.opt = &opt;
    atomic_init(&sh.next, 0);
    atomic_init(&sh.done, 0);

    int started = 0;
    for (int i = 0; i < threads; i++) {
        ws[i].sh = &sh;
        if (i == 0)
            continue; /* the caller's thread is worker 0 */
        if (pthread_create(&ws[i].tid, NULL, work, &ws[i]) != 0)
            break;
        started = i;
    }
    work(&ws[0]);
    for (int i = 1; i <= started; i++)
        pthread_join(ws[i].tid, NULL);

    int cancelled = 0;
    for (int i = 0; i < threads; i++) {
        stats->camera_rays += ws[i].counts.camera;
        stats->shadow_rays += ws[i].counts.shadow;
        stats->secondary_rays += ws[i].counts.secondary;
        stats->nonfinite += ws[i].counts.nonfinite;
        cancelled |= ws[i].cancelled;
    }
    free(ws);
    if (cancelled && atomic_load(&sh.done) < rd_job_tile_count(job)) {
        rd_job_free(job);
        return rd_error_set(err, RD_ERR_CANCELLED, 0, 0, "render cancelled");
    }
    rc = rd_job_image(job, out, err);
    stats->error_estimate = rd_job_error_estimate(job);
    rd_job_free(job);
    if (rc)
        return rc;
    stats->samples = sh.samples;
    stats->threads = started + 1;
    stats->wall_ms = now_ms() - t0;
    uint64_t rays = stats->camera_rays + stats->shadow_rays + stats->secondary_rays;
    stats->rays_per_second = stats->wall_ms > 0 ? rays / (stats->wall_ms / 1e3) : 0;
    return RD_OK;
}

void rd_image_to_rgb8(const rd_image *img, double gamma, uint8_t *out)
{
    size_t n = (size_t)img->width * (size_t)img->height * 3;
    for (size_t i = 0; i < n; i++)
        out[i] = (uint8_t)floor(rd_display(img->rgb[i], gamma) * 255.0 + 0.5);
}
