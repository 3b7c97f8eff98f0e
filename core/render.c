#include "render.h"

#include <float.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "camera.h"
#include "trace.h"

typedef struct {
    const rd_plan *plan;
    const rd_pinhole *cam;
    const rd_render_options *opt;
    rd_image *img;
    double *var;            /* per pixel: sum over channels of var/n of the display value */
    int tile, tiles_x, tiles_total;
    atomic_int next, done;
    int cancelled;          /* read only after join */
} job;

typedef struct {
    job *j;
    rd_ray_counts counts;
    uint64_t nonfinite;
    int cancelled;
    pthread_t tid;
} worker;

double rd_display(double c, double gamma)
{
    c = rd_clamp01(c);
    return gamma == 1 ? c : pow(c, 1.0 / gamma);
}

static double finite_or_zero(double x, uint64_t *bad)
{
    if (isfinite(x))
        return x;
    (*bad)++;
    return isnan(x) ? 0 : (x > 0 ? DBL_MAX : -DBL_MAX);
}

static void render_pixel(worker *w, int x, int y)
{
    job *j = w->j;
    const rd_scene *s = j->plan->scene;
    int n = s->render.samples < 1 ? 1 : s->render.samples;
    uint64_t pixel = (uint64_t)y * (uint64_t)s->render.width + (uint64_t)x;
    uint32_t pattern = rd_pattern(s->render.seed, pixel);
    double g = s->render.gamma;
    double mean[3] = {0, 0, 0}, m2[3] = {0, 0, 0}, dmean[3] = {0, 0, 0};
    for (int k = 0; k < n; k++) {
        double px = 0.5, py = 0.5;
        if (n > 1)
            rd_cmj((uint32_t)k, (uint32_t)n, pattern, &px, &py);
        rd_ray r = rd_pinhole_ray(j->cam, x + px, y + py);
        rd_rng rng = rd_rng_make(s->render.seed, pixel, (uint64_t)k);
        w->counts.camera++;
        rd_rgb c = rd_trace(j->plan, r, 0, &rng, &w->counts);
        double cv[3] = {finite_or_zero(c.x, &w->nonfinite), finite_or_zero(c.y, &w->nonfinite),
                        finite_or_zero(c.z, &w->nonfinite)};
        /* Welford: a running mean of the colour, and of the display value
         * with its sum of squared deviations, for the error estimate. */
        for (int ch = 0; ch < 3; ch++) {
            mean[ch] += (cv[ch] - mean[ch]) / (k + 1);
            double d = rd_display(cv[ch], g);
            double delta = d - dmean[ch];
            dmean[ch] += delta / (k + 1);
            m2[ch] += delta * (d - dmean[ch]);
        }
    }
    double *out = &j->img->rgb[pixel * 3];
    out[0] = mean[0];
    out[1] = mean[1];
    out[2] = mean[2];
    j->var[pixel] = n > 1 ? (m2[0] + m2[1] + m2[2]) / ((double)(n - 1) * n) : 0;
}

static void *work(void *arg)
{
    worker *w = arg;
    job *j = w->j;
    const rd_scene *s = j->plan->scene;
    for (;;) {
        if (j->opt->cancel && atomic_load(j->opt->cancel)) {
            w->cancelled = 1;
            break;
        }
        int t = atomic_fetch_add(&j->next, 1);
        if (t >= j->tiles_total)
            break;
        int x0 = (t % j->tiles_x) * j->tile, y0 = (t / j->tiles_x) * j->tile;
        int x1 = x0 + j->tile < s->render.width ? x0 + j->tile : s->render.width;
        int y1 = y0 + j->tile < s->render.height ? y0 + j->tile : s->render.height;
        for (int y = y0; y < y1; y++)
            for (int x = x0; x < x1; x++)
                render_pixel(w, x, y);
        int done = atomic_fetch_add(&j->done, 1) + 1;
        if (j->opt->progress)
            j->opt->progress(j->opt->user, done, j->tiles_total);
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
    int tile = opt.tile < 1 ? 16 : opt.tile;

    rd_pinhole cam;
    rd_error_code rc = rd_pinhole_make(&cam, &s->camera, s->render.width, s->render.height, err);
    if (rc)
        return rc;
    rd_plan plan;
    rc = rd_plan_build(&plan, s, err);
    if (rc)
        return rc;
    stats->prepare_ms = now_ms() - t0;
    stats->bvh_build_ms = plan.world.build_ms;
    stats->bvh_nodes = plan.world.bvh.nnodes;
    stats->world_bytes = rd_world_bytes(&plan.world);
    stats->primitives = plan.world.nspheres + plan.world.nplanes + plan.world.ntris;

    size_t npix = (size_t)s->render.width * (size_t)s->render.height;
    out->width = s->render.width;
    out->height = s->render.height;
    out->rgb = malloc(npix * 3 * sizeof(double));
    double *var = malloc(npix * sizeof(double));
    worker *ws = calloc((size_t)threads, sizeof *ws);
    if (!out->rgb || !var || !ws) {
        free(var);
        free(ws);
        rd_image_free(out);
        rd_plan_free(&plan);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory for a %dx%d image",
                            s->render.width, s->render.height);
    }

    job j;
    memset(&j, 0, sizeof j);
    j.plan = &plan;
    j.cam = &cam;
    j.opt = &opt;
    j.img = out;
    j.var = var;
    j.tile = tile;
    j.tiles_x = (s->render.width + tile - 1) / tile;
    j.tiles_total = j.tiles_x * ((s->render.height + tile - 1) / tile);
    atomic_init(&j.next, 0);
    atomic_init(&j.done, 0);

    int started = 0;
    for (int i = 0; i < threads; i++) {
        ws[i].j = &j;
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
        stats->nonfinite += ws[i].nonfinite;
        cancelled |= ws[i].cancelled;
    }
    free(ws);
    rd_plan_free(&plan);
    if (cancelled && atomic_load(&j.done) < j.tiles_total) {
        free(var);
        rd_image_free(out);
        return rd_error_set(err, RD_ERR_CANCELLED, 0, 0, "render cancelled");
    }
    /* Summed in pixel order, so the estimate does not depend on threads. */
    double sum = 0;
    for (size_t i = 0; i < npix; i++)
        sum += var[i];
    free(var);
    stats->error_estimate = sqrt(sum / (3.0 * (double)npix));
    stats->samples = s->render.samples < 1 ? 1 : s->render.samples;
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
