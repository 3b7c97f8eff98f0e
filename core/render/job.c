#include "rayd/job.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "camera.h"
#include "rayd/clock.h"
#include "trace.h"

/* Per-pixel state lives in separate arrays, each allocated only when the
 * render needs it: a fixed one-sample render keeps 28 bytes a pixel (its
 * mean and count), since touching more memory than that made the first
 * write to each page, not the tracing, the cost of a large image.
 *
 * Samples alternate between two independent half-sets (by the pixel's
 * running count); each half is stratified on its own. The two half-means
 * differ only by noise, so their squared difference measures the variance
 * of the mean without bias, even though stratified samples make a pixel's
 * own sample variance overstate it (two-buffer estimation, as in Rousselle,
 * Knaus & Zwicker, "Adaptive Rendering with Non-Local Means Filtering",
 * SIGGRAPH Asia 2012). */
struct rd_job {
    const rd_scene *scene;
    rd_pinhole cam;
    rd_plan plan;
    double *mean; /* 3 a pixel: linear colour, all samples; always */
    uint32_t *n;  /* samples a pixel; always */
    float *half;  /* 6 a pixel: linear means of the two half-sets; when estimating */
    uint32_t *nh; /* 2 a pixel: their counts; when estimating */
    float *stat;  /* 6 a pixel: display mean and Welford sum of squares; adaptive only */
    int tile, tiles_x, tiles_total;
    int progressive, adaptive;
    int pass, pass_samples;
    double mean_weight; /* adaptive: mean of w_i at the pass start */
    double deadline_ms;
    const atomic_int *cancel;
    double plan_ms;
    /* The schedule of passes and what they measured (progress.h). */
    rd_progress_settings progress;
    double t0, pass_t0, last_pass_ms;
    int spp, passes_done;
    double error;
    rd_stop_reason stopped_by;
    rd_curve_point curve[RD_CURVE_MAX];
    int curve_len;
};

/* World bytes a primitive costs at most: its record (a triangle's is the
 * largest), two BVH nodes, its leaf index, and the double bounds and
 * centroid the builder holds while it works. */
enum { WORLD_BYTES_PER_PRIM = 512 };

size_t rd_job_estimate_bytes(const rd_scene *s, const rd_job_options *opt)
{
    size_t npix = (size_t)s->render.width * (size_t)s->render.height;
    int progressive = opt && rd_progress_is_progressive(&opt->progress), adaptive = opt && opt->progress.adaptive;
    size_t per_pixel = 3 * sizeof(double) + sizeof(uint32_t) + 3; /* mean, count, 8-bit output */
    if (progressive || s->render.samples > 1)
        per_pixel += 6 * sizeof(float) + 2 * sizeof(uint32_t);
    if (adaptive)
        per_pixel += 6 * sizeof(float);
    size_t prims = s->object_count;
    for (size_t i = 0; i < s->mesh_count; i++)
        prims += s->meshes[i].nfaces;
    return rd_scene_bytes(s) + prims * WORLD_BYTES_PER_PRIM + npix * per_pixel + sizeof(rd_job);
}

rd_error_code rd_job_create(const rd_scene *s, const rd_job_options *opt, rd_job **out, rd_error *err)
{
    *out = NULL;
    double t0 = rd_now_ms();
    rd_job *j = calloc(1, sizeof *j);
    if (!j)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    j->scene = s;
    j->t0 = t0;
    j->tile = opt && opt->tile >= 1 ? opt->tile : RD_JOB_TILE;
    if (opt)
        j->progress = opt->progress;
    if (j->progress.max_samples < 1)
        j->progress.max_samples = s->render.samples < 1 ? 1 : s->render.samples;
    j->progressive = rd_progress_is_progressive(&j->progress);
    j->adaptive = j->progress.adaptive;
    j->pass_samples = s->render.samples < 1 ? 1 : s->render.samples;
    rd_error_code rc = rd_pinhole_make(&j->cam, &s->camera, s->render.width, s->render.height, err);
    if (rc) {
        free(j);
        return rc;
    }
    rc = rd_plan_build_threads(&j->plan, s, opt ? opt->build_threads : 1, err);
    if (rc) {
        free(j);
        return rc;
    }
    size_t npix = (size_t)s->render.width * (size_t)s->render.height;
    j->tiles_x = (s->render.width + j->tile - 1) / j->tile;
    j->tiles_total = j->tiles_x * ((s->render.height + j->tile - 1) / j->tile);
    /* One centre sample a pixel has nothing to estimate from. */
    int estimating = j->progressive || s->render.samples > 1;
    /* Not calloc: its pages start as the shared zero page, and the first
     * read-then-write of a pixel then copies the page and flushes every
     * CPU's TLB, which serialised the threads. Each tile writes its own
     * pixels' starting values before its first pass instead. */
    j->mean = malloc(npix * 3 * sizeof *j->mean);
    j->n = malloc(npix * sizeof *j->n);
    if (estimating) {
        j->half = malloc(npix * 6 * sizeof *j->half);
        j->nh = malloc(npix * 2 * sizeof *j->nh);
    }
    if (j->adaptive)
        j->stat = malloc(npix * 6 * sizeof *j->stat);
    if (!j->mean || !j->n || (estimating && (!j->half || !j->nh)) || (j->adaptive && !j->stat)) {
        rd_job_free(j);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory for a %dx%d image", s->render.width,
                            s->render.height);
    }
    j->plan_ms = rd_now_ms() - t0;
    *out = j;
    return RD_OK;
}

void rd_job_free(rd_job *j)
{
    if (!j)
        return;
    rd_plan_free(&j->plan);
    free(j->mean);
    free(j->n);
    free(j->half);
    free(j->nh);
    free(j->stat);
    free(j);
}

int rd_job_tile_count(const rd_job *j) { return j->tiles_total; }
int rd_job_width(const rd_job *j) { return j->scene->render.width; }
int rd_job_height(const rd_job *j) { return j->scene->render.height; }

/* s²/n² of pixel i: how much one more sample lowers its variance of the
 * mean. Adaptive renders only. */
static double weight(const rd_job *j, size_t i)
{
    uint32_t n = j->n[i];
    if (n < 2)
        return 0;
    const float *m2 = &j->stat[6 * i + 3];
    double var = ((double)m2[0] + m2[1] + m2[2]) / (n - 1);
    return var / ((double)n * n);
}

/* Reads every pixel (adaptive): no tile may be rendering. */
static void begin_pass(rd_job *j, int pass, int samples)
{
    j->pass_t0 = rd_now_ms();
    j->pass = pass;
    j->pass_samples = samples < 1 ? 1 : samples;
    j->mean_weight = 0;
    if (j->adaptive && pass > 0) {
        size_t npix = (size_t)j->scene->render.width * (size_t)j->scene->render.height;
        double sum = 0;
        for (size_t i = 0; i < npix; i++)
            sum += weight(j, i);
        j->mean_weight = sum / (double)npix;
    }
}

int rd_job_first_pass(rd_job *j)
{
    rd_stop_reason why;
    int n = rd_progress_next(&j->progress, 0, 0, 0, 0, 0, 0, &why);
    begin_pass(j, 0, n);
    return j->pass_samples;
}

int rd_job_end_pass(rd_job *j)
{
    j->last_pass_ms = rd_now_ms() - j->pass_t0;
    j->spp += j->pass_samples;
    j->passes_done = j->pass + 1;
    j->error = rd_job_error_estimate(j);
    if (j->curve_len < RD_CURVE_MAX) {
        rd_curve_point *cp = &j->curve[j->curve_len++];
        cp->ms = rd_now_ms() - j->t0;
        cp->samples = j->adaptive ? rd_job_mean_samples(j) : j->spp;
        cp->error = j->error;
    }
    int next = rd_progress_next(&j->progress, j->passes_done, j->spp, j->last_pass_ms, j->pass_samples,
                                rd_now_ms() - j->t0, j->error, &j->stopped_by);
    if (next > 0)
        begin_pass(j, j->passes_done, next);
    return next;
}

int rd_job_pass_samples(const rd_job *j) { return j->pass_samples; }

int rd_job_samples_done(const rd_job *j) { return j->spp; }

void rd_job_stats(const rd_job *j, rd_render_stats *st)
{
    rd_job_plan_stats(j, st);
    st->passes = j->passes_done;
    st->curve_len = j->curve_len;
    memcpy(st->curve, j->curve, sizeof j->curve);
    st->error_estimate = j->error;
    st->stopped_by = j->stopped_by;
    /* Pixels are set up by their tile's first pass: before one has ended
     * there is nothing to count. */
    st->mean_samples = j->passes_done > 0 ? rd_job_mean_samples(j) : 0;
    st->samples = (int)floor(st->mean_samples + 0.5);
}

void rd_stats_add_counts(rd_render_stats *st, const rd_job_counts *c, double wall_ms)
{
    st->camera_rays = c->camera;
    st->shadow_rays = c->shadow;
    st->secondary_rays = c->secondary;
    st->nonfinite = c->nonfinite;
    st->wall_ms = wall_ms;
    uint64_t rays = c->camera + c->shadow + c->secondary;
    st->rays_per_second = wall_ms > 0 ? rays / (wall_ms / 1e3) : 0;
}

double rd_job_mean_samples(const rd_job *j)
{
    size_t npix = (size_t)j->scene->render.width * (size_t)j->scene->render.height;
    double sum = 0;
    for (size_t i = 0; i < npix; i++)
        sum += j->n[i];
    return sum / (double)npix;
}

static double finite_or_zero(double x, uint64_t *bad)
{
    if (isfinite(x))
        return x;
    (*bad)++;
    return isnan(x) ? 0 : (x > 0 ? DBL_MAX : -DBL_MAX);
}

static void render_pixel(rd_job *j, int x, int y, rd_job_counts *c, rd_ray_counts *rc)
{
    const rd_scene *s = j->scene;
    uint64_t index = (uint64_t)y * (uint64_t)s->render.width + (uint64_t)x;
    int pass = j->pass, samples = j->pass_samples;
    /* Pass 0 keeps the pattern of a plain render; later passes draw new ones. */
    uint64_t pass_seed = s->render.seed + (uint64_t)pass * 0x9e3779b97f4a7c15ULL;
    double g = s->render.gamma;
    int centre = pass == 0 && samples == 1 && !j->progressive;
    if (j->adaptive && pass > 0 && j->mean_weight > 0) {
        /* This pixel's share depends only on its own state and the mean taken
         * at the pass start: the same whatever thread renders it. Half the
         * pass goes to every pixel alike, so none whose first samples
         * happened to agree is starved; the other half follows the error.
         * The cap only stops a single pixel from stalling its tile. */
        double want = samples * (0.5 + 0.5 * weight(j, index) / j->mean_weight);
        if (want > 64.0 * samples)
            want = 64.0 * samples;
        rd_rng pick = rd_rng_make(pass_seed ^ 0xadab7e5ULL, index, j->n[index]);
        samples = (int)want + (rd_rng_next(&pick) < want - floor(want));
        if (samples < 1)
            samples = j->n[index] < 2 ? 1 : 0;
    }
    /* Which half-set each of this pass's samples joins, and its index there.
     * A centre sample needs no pattern at all. */
    uint32_t first = j->n[index];
    double *mean = &j->mean[3 * index];
    uint32_t in_half[2] = {0, 0}, count[2] = {0, 0};
    uint32_t pattern_half[2] = {0, 0};
    if (!centre) {
        for (int k = 0; k < samples; k++)
            count[(first + (uint32_t)k) & 1]++;
        pattern_half[0] = rd_pattern(pass_seed, index);
        pattern_half[1] = rd_pattern(pass_seed ^ 0x6a09e667f3bcc909ULL, index);
    }
    for (int k = 0; k < samples; k++) {
        if (rd_counts_tick(rc))
            return;
        int h = (int)((first + (uint32_t)k) & 1);
        double px = 0.5, py = 0.5;
        if (!centre)
            rd_cmj(in_half[h]++, count[h], pattern_half[h], &px, &py);
        rd_ray r = rd_pinhole_ray(&j->cam, x + px, y + py);
        /* Only area lights draw random numbers during tracing. */
        rd_rng rng = {0};
        if (j->plan.stochastic)
            rng = rd_rng_make(s->render.seed, index, (uint64_t)j->n[index]);
        c->camera++;
        rd_rgb col = rd_trace(&j->plan, r, 0, &rng, rc);
        double cv[3] = {finite_or_zero(col.x, &c->nonfinite), finite_or_zero(col.y, &c->nonfinite),
                        finite_or_zero(col.z, &c->nonfinite)};
        uint32_t n = ++j->n[index];
        for (int ch = 0; ch < 3; ch++)
            mean[ch] += (cv[ch] - mean[ch]) / n;
        if (j->half) {
            uint32_t nh = ++j->nh[2 * index + h];
            float *hm = &j->half[6 * index + 3 * h];
            for (int ch = 0; ch < 3; ch++)
                hm[ch] = (float)(hm[ch] + (cv[ch] - hm[ch]) / nh);
        }
        /* The spread of display values only steers adaptive passes. */
        if (j->stat) {
            float *dmean = &j->stat[6 * index], *m2 = dmean + 3;
            for (int ch = 0; ch < 3; ch++) {
                double d = rd_display(cv[ch], g), delta = d - dmean[ch];
                dmean[ch] = (float)(dmean[ch] + delta / n);
                m2[ch] = (float)(m2[ch] + delta * (d - dmean[ch]));
            }
        }
    }
}

void rd_job_set_deadline(rd_job *j, double deadline_ms) { j->deadline_ms = deadline_ms; }

void rd_job_set_cancel(rd_job *j, const atomic_int *cancel) { j->cancel = cancel; }

int rd_job_render_tile(rd_job *j, int t, rd_job_counts *c)
{
    const rd_scene *s = j->scene;
    int x0 = (t % j->tiles_x) * j->tile, y0 = (t / j->tiles_x) * j->tile;
    int x1 = x0 + j->tile < s->render.width ? x0 + j->tile : s->render.width;
    int y1 = y0 + j->tile < s->render.height ? y0 + j->tile : s->render.height;
    if (j->pass == 0)
        for (int y = y0; y < y1; y++) {
            size_t i = (size_t)y * (size_t)s->render.width + (size_t)x0, w = (size_t)(x1 - x0);
            memset(&j->mean[3 * i], 0, 3 * w * sizeof *j->mean);
            memset(&j->n[i], 0, w * sizeof *j->n);
            if (j->half) {
                memset(&j->half[6 * i], 0, 6 * w * sizeof *j->half);
                memset(&j->nh[2 * i], 0, 2 * w * sizeof *j->nh);
            }
            if (j->stat)
                memset(&j->stat[6 * i], 0, 6 * w * sizeof *j->stat);
        }
    rd_ray_counts rc;
    rd_counts_init(&rc, j->deadline_ms, j->cancel);
    for (int y = y0; y < y1 && !rc.stopped; y++) {
        for (int x = x0; x < x1 && !rc.stopped; x++)
            render_pixel(j, x, y, c, &rc);
    }
    c->shadow += rc.shadow;
    c->secondary += rc.secondary;
    return !rc.stopped;
}

void rd_job_take_image(rd_job *j, rd_image *out)
{
    out->width = j->scene->render.width;
    out->height = j->scene->render.height;
    out->rgb = j->mean;
    j->mean = NULL;
}

void rd_job_rgb8(const rd_job *j, uint8_t *out)
{
    size_t npix = (size_t)j->scene->render.width * (size_t)j->scene->render.height;
    double g = j->scene->render.gamma;
    for (size_t i = 0; i < npix; i++)
        for (int ch = 0; ch < 3; ch++)
            out[3 * i + ch] = rd_display8(j->mean[3 * i + ch], g);
}

void rd_job_tile_rgb8(const rd_job *j, int t, uint8_t *out)
{
    const rd_scene *s = j->scene;
    int x0 = (t % j->tiles_x) * j->tile, y0 = (t / j->tiles_x) * j->tile;
    int x1 = x0 + j->tile < s->render.width ? x0 + j->tile : s->render.width;
    int y1 = y0 + j->tile < s->render.height ? y0 + j->tile : s->render.height;
    double g = s->render.gamma;
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++) {
            size_t i = (size_t)y * (size_t)s->render.width + (size_t)x;
            for (int ch = 0; ch < 3; ch++)
                out[3 * i + ch] = rd_display8(j->mean[3 * i + ch], g);
        }
}

double rd_job_error_estimate(const rd_job *j)
{
    size_t npix = (size_t)j->scene->render.width * (size_t)j->scene->render.height;
    double sum = 0;
    if (!j->half)
        return 0;
    double g = j->scene->render.gamma;
    for (size_t i = 0; i < npix; i++) {
        double a = j->nh[2 * i], b = j->nh[2 * i + 1];
        if (a < 1 || b < 1)
            continue;
        /* E[(mA - mB)^2] = s^2 (1/a + 1/b) and Var(mean) = s^2/(a + b). */
        double k = a * b / ((a + b) * (a + b));
        /* The image shows display(mean), so compare the halves as displayed. */
        const float *ha = &j->half[6 * i], *hb = ha + 3;
        for (int ch = 0; ch < 3; ch++) {
            double d = rd_display(ha[ch], g) - rd_display(hb[ch], g);
            sum += d * d * k;
        }
    }
    return sqrt(sum / (3.0 * (double)npix));
}

void rd_job_plan_stats(const rd_job *j, rd_render_stats *st)
{
    st->prepare_ms = j->plan_ms;
    st->bvh_build_ms = j->plan.world.build_ms;
    st->bvh_nodes = j->plan.world.bvh4.nnodes;
    st->world_bytes = rd_world_bytes(&j->plan.world);
    st->primitives = j->plan.world.nspheres + j->plan.world.nplanes + j->plan.world.ntris;
}
