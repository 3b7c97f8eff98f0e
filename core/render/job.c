#include "rayd/job.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "camera.h"
#include "rayd/clock.h"
#include "rayd/memory.h"
#include "trace.h"

/* Per-pixel state lives in separate arrays, each allocated only when the
 * render needs it: a fixed one-sample render keeps 28 bytes a pixel (its
 * mean and count), or none of its own when its caller takes only the 8-bit
 * image (direct), since the kernel clearing the fresh pages, not the
 * tracing, became the cost of a large image.
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
    double *mean; /* 3 a pixel: linear colour, all samples; unless direct */
    uint32_t *n;  /* samples a pixel; unless direct */
    /* Direct: a one-sample frame written as 8-bit values into the caller's
     * bytes (rd_job_options.rgb8), with the table of the gamma when one
     * pays (ours), and how many of each tile's pixels have their sample. */
    uint8_t *direct;
    rd_display_table *table8;
    uint32_t *tile_done;
    float *half;  /* 6 a pixel: linear means of the two half-sets; when estimating */
    uint32_t *nh; /* 2 a pixel: their counts; when estimating */
    float *stat;  /* 6 a pixel: display mean and Welford sum of squares; adaptive only */
    int tile, tiles_x, tiles_total;
    int progressive, adaptive;
    unsigned packets; /* RD_PACKETS_*; 0 without a BVH */
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

/* Whether the job writes its pixels' 8-bit values straight (struct rd_job):
 * its one sample a pixel is then the centre sample of a first pass. */
static int writes_direct(const rd_scene *s, const rd_job_options *opt)
{
    return opt && opt->rgb8 && !rd_progress_is_progressive(&opt->progress) && !opt->progress.adaptive &&
           s->render.samples <= 1 && opt->progress.max_samples <= 1;
}

size_t rd_job_estimate_bytes(const rd_scene *s, const rd_job_options *opt)
{
    size_t npix = (size_t)s->render.width * (size_t)s->render.height;
    int progressive = opt && rd_progress_is_progressive(&opt->progress), adaptive = opt && opt->progress.adaptive;
    size_t per_pixel = 3 * sizeof(double) + sizeof(uint32_t) + 3; /* mean, count, 8-bit output */
    if (writes_direct(s, opt))
        per_pixel = 3;
    else if (progressive || s->render.samples > 1)
        per_pixel += 6 * sizeof(float) + 2 * sizeof(uint32_t);
    if (adaptive)
        per_pixel += 6 * sizeof(float);
    size_t prims = s->object_count, normals = 3 * s->object_count; /* the world's unit normals */
    for (size_t i = 0; i < s->mesh_count; i++) {
        prims += s->meshes[i].nfaces;
        normals += s->meshes[i].nnormals;
    }
    return rd_scene_bytes(s) + prims * WORLD_BYTES_PER_PRIM + normals * sizeof(rd_vec3) + npix * per_pixel +
           sizeof(rd_job);
}

/* The per-pixel arrays the render needs. */
static rd_error_code alloc_frame(rd_job *j, const rd_job_options *opt, size_t npix)
{
    if (writes_direct(j->scene, opt)) {
        j->direct = opt->rgb8;
        j->table8 = rd_display_table_new(j->scene->render.gamma, npix * 3);
        j->tile_done = calloc((size_t)j->tiles_total, sizeof *j->tile_done);
        return j->tile_done ? RD_OK : RD_ERR_NOMEM;
    }
    /* One centre sample a pixel has nothing to estimate from. */
    int estimating = j->progressive || j->scene->render.samples > 1;
    /* Not calloc: its pages start as the shared zero page, and the first
     * read-then-write of a pixel then copies the page and flushes every
     * CPU's TLB, which serialised the threads. Each tile writes its own
     * pixels' starting values before its first pass instead. */
    j->mean = rd_big_malloc(npix * 3 * sizeof *j->mean);
    j->n = rd_big_malloc(npix * sizeof *j->n);
    if (estimating) {
        j->half = rd_big_malloc(npix * 6 * sizeof *j->half);
        j->nh = rd_big_malloc(npix * 2 * sizeof *j->nh);
    }
    if (j->adaptive)
        j->stat = rd_big_malloc(npix * 6 * sizeof *j->stat);
    if (!j->mean || !j->n || (estimating && (!j->half || !j->nh)) || (j->adaptive && !j->stat))
        return RD_ERR_NOMEM;
    return RD_OK;
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
    j->packets = opt && j->plan.world.use_bvh ? opt->packets & (RD_PACKETS_CAMERA | RD_PACKETS_SHADOW) : 0;
    size_t npix = (size_t)s->render.width * (size_t)s->render.height;
    j->tiles_x = (s->render.width + j->tile - 1) / j->tile;
    j->tiles_total = j->tiles_x * ((s->render.height + j->tile - 1) / j->tile);
    rc = alloc_frame(j, opt, npix);
    if (rc) {
        rd_job_free(j);
        return rd_error_set(err, rc, 0, 0, "out of memory for a %dx%d image", s->render.width, s->render.height);
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
    free(j->table8);
    free(j->tile_done);
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

/* Reads every pixel; done before the clock is read for the decision, so
 * that the budget counts the time the estimate takes (a pow a channel of
 * every pixel). Returns the curve point's samples. */
static double measure_pass(rd_job *j)
{
    j->spp += j->pass_samples;
    j->passes_done = j->pass + 1;
    j->error = rd_job_error_estimate(j);
    return j->adaptive ? rd_job_mean_samples(j) : j->spp;
}

static int decide_pass(rd_job *j, double elapsed_ms, double pass_ms, double samples)
{
    j->last_pass_ms = pass_ms;
    if (j->curve_len < RD_CURVE_MAX)
        j->curve[j->curve_len++] = (rd_curve_point){elapsed_ms, samples, j->error};
    int next = rd_progress_next(&j->progress, j->passes_done, j->spp, j->last_pass_ms, j->pass_samples, elapsed_ms,
                                j->error, &j->stopped_by);
    if (next > 0)
        begin_pass(j, j->passes_done, next);
    return next;
}

int rd_job_end_pass(rd_job *j)
{
    double pass_ms = rd_now_ms() - j->pass_t0;
    double samples = measure_pass(j);
    return decide_pass(j, rd_now_ms() - j->t0, pass_ms, samples);
}

int rd_job_end_pass_at(rd_job *j, double elapsed_ms, double pass_ms)
{
    double samples = measure_pass(j);
    return decide_pass(j, elapsed_ms, pass_ms, samples);
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
    if (j->direct)
        for (int t = 0; t < j->tiles_total; t++)
            sum += j->tile_done[t];
    else
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

/* One pixel's samples in this pass: how many, and the two half-sets'
 * patterns they are drawn from. */
typedef struct {
    int x, y, samples, centre;
    uint64_t index;
    uint32_t first, in_half[2], count[2], pattern_half[2];
    uint32_t *done; /* direct: the tile's pixels with their sample */
} pixel_run;

static uint32_t samples_of(const rd_job *j, uint64_t i) { return j->direct ? 0 : j->n[i]; }

static void pixel_begin(const rd_job *j, int x, int y, uint32_t *done, pixel_run *pr)
{
    const rd_scene *s = j->scene;
    memset(pr, 0, sizeof *pr);
    pr->x = x;
    pr->y = y;
    pr->done = done;
    pr->index = (uint64_t)y * (uint64_t)s->render.width + (uint64_t)x;
    int pass = j->pass, samples = j->pass_samples;
    /* Pass 0 keeps the pattern of a plain render; later passes draw new ones. */
    uint64_t pass_seed = s->render.seed + (uint64_t)pass * 0x9e3779b97f4a7c15ULL;
    pr->centre = pass == 0 && samples == 1 && !j->progressive;
    if (j->adaptive && pass > 0 && j->mean_weight > 0) {
        /* This pixel's share depends only on its own state and the mean taken
         * at the pass start: the same whatever thread renders it. Half the
         * pass goes to every pixel alike, so none whose first samples
         * happened to agree is starved; the other half follows the error.
         * The cap only stops a single pixel from stalling its tile. */
        double want = samples * (0.5 + 0.5 * weight(j, pr->index) / j->mean_weight);
        if (want > 64.0 * samples)
            want = 64.0 * samples;
        /* Every want below -1 gives no sample; stopping there keeps the cast
         * defined whatever mean a schedule from elsewhere brings
         * (rd_job_schedule_set takes it as given) against a w_i that
         * rounding made negative. */
        else if (!(want >= -1))
            want = -1;
        rd_rng pick = rd_rng_make(pass_seed ^ 0xadab7e5ULL, pr->index, j->n[pr->index]);
        samples = (int)want + (rd_rng_next(&pick) < want - floor(want));
        if (samples < 1)
            samples = j->n[pr->index] < 2 ? 1 : 0;
    }
    pr->samples = samples;
    /* Which half-set each of this pass's samples joins, and its index there.
     * A centre sample needs no pattern at all. */
    pr->first = samples_of(j, pr->index);
    if (!pr->centre) {
        /* Samples k = 0, 2, 4, ... join half first & 1: the larger half. */
        pr->count[pr->first & 1] = (uint32_t)(samples + 1) / 2;
        pr->count[(pr->first + 1) & 1] = (uint32_t)samples / 2;
        pr->pattern_half[0] = rd_pattern(pass_seed, pr->index);
        pr->pattern_half[1] = rd_pattern(pass_seed ^ 0x6a09e667f3bcc909ULL, pr->index);
    }
}

/* The camera ray of the pixel's next sample (k-th of the pass), and the
 * random numbers its tracing draws. */
static rd_ray pixel_ray(const rd_job *j, pixel_run *pr, int k, rd_rng *rng)
{
    int h = (int)((pr->first + (uint32_t)k) & 1);
    double px = 0.5, py = 0.5;
    if (!pr->centre)
        rd_cmj(pr->in_half[h]++, pr->count[h], pr->pattern_half[h], &px, &py);
    /* Only area lights draw random numbers during tracing. */
    *rng = (rd_rng){0};
    if (j->plan.stochastic)
        *rng = rd_rng_make(j->scene->render.seed, pr->index, (uint64_t)samples_of(j, pr->index));
    return rd_pinhole_ray(&j->cam, pr->x + px, pr->y + py);
}

/* Adds the k-th sample's colour to the pixel's means. */
static void pixel_add(rd_job *j, const pixel_run *pr, int k, rd_rgb col, rd_job_counts *c)
{
    uint64_t index = pr->index;
    int h = (int)((pr->first + (uint32_t)k) & 1);
    double cv[3] = {finite_or_zero(col.x, &c->nonfinite), finite_or_zero(col.y, &c->nonfinite),
                    finite_or_zero(col.z, &c->nonfinite)};
    if (j->direct) {
        /* The bytes of the mean pixel_add would keep (below). */
        double v[3] = {cv[0] + 0.0, cv[1] + 0.0, cv[2] + 0.0}, g = j->scene->render.gamma;
        uint8_t *out = &j->direct[3 * index];
        if (g == 1)
            for (int ch = 0; ch < 3; ch++)
                out[ch] = rd_display8_linear(v[ch]);
        else
            rd_display8_many(j->table8, g, v, 3, out);
        ++*pr->done;
        return;
    }
    double *mean = &j->mean[3 * index];
    uint32_t n = ++j->n[index];
    /* A centre sample is the pixel's first (its tile was just cleared):
     * 0 + (c - 0)/1 has the bits of c + 0.0, -0 made +0 alike. */
    if (pr->centre)
        for (int ch = 0; ch < 3; ch++)
            mean[ch] = cv[ch] + 0.0;
    else
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
        double g = j->scene->render.gamma;
        float *dmean = &j->stat[6 * index], *m2 = dmean + 3;
        for (int ch = 0; ch < 3; ch++) {
            double d = rd_display(cv[ch], g), delta = d - dmean[ch];
            dmean[ch] = (float)(dmean[ch] + delta / n);
            m2[ch] = (float)(m2[ch] + delta * (d - dmean[ch]));
        }
    }
}

static void render_pixel(rd_job *j, int x, int y, uint32_t *done, rd_job_counts *c, rd_ray_counts *rc)
{
    pixel_run pr;
    pixel_begin(j, x, y, done, &pr);
    for (int k = 0; k < pr.samples; k++) {
        if (rd_counts_tick(rc))
            return;
        rd_rng rng;
        rd_ray r = pixel_ray(j, &pr, k, &rng);
        c->camera++;
        pixel_add(j, &pr, k, rd_trace(&j->plan, r, 0, &rng, rc), c);
    }
}

/* The pixels [x0, x1) x [y0, y1) (at most RD_PACKET_MAX of them) traced
 * together: their k-th samples form a packet of camera rays from the eye,
 * which rd_trace_packet traces to the same colours as one by one. Each
 * pixel still gets its samples in order. */
enum { BLOCK = 4 };

static void render_block(rd_job *j, int x0, int y0, int x1, int y1, uint32_t *done, rd_job_counts *c, rd_ray_counts *rc)
{
    pixel_run pr[RD_PACKET_MAX];
    int n = 0, most = 0;
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++) {
            pixel_begin(j, x, y, done, &pr[n]);
            most = pr[n].samples > most ? pr[n].samples : most;
            n++;
        }
    for (int k = 0; k < most; k++) {
        rd_ray r[RD_PACKET_MAX];
        rd_rng rng[RD_PACKET_MAX];
        rd_rgb col[RD_PACKET_MAX];
        int who[RD_PACKET_MAX], m = 0;
        for (int i = 0; i < n; i++) {
            if (k >= pr[i].samples)
                continue;
            if (rd_counts_tick(rc))
                return;
            r[m] = pixel_ray(j, &pr[i], k, &rng[m]);
            who[m++] = i;
        }
        c->camera += (uint64_t)m;
        rd_trace_packet(&j->plan, r, m, j->packets, rng, rc, col);
        for (int i = 0; i < m; i++)
            pixel_add(j, &pr[who[i]], k, col[i], c);
    }
}

void rd_job_set_deadline(rd_job *j, double deadline_ms) { j->deadline_ms = deadline_ms; }

void rd_job_set_cancel(rd_job *j, const atomic_int *cancel) { j->cancel = cancel; }

typedef struct {
    int x0, y0, x1, y1; /* [x0, x1) x [y0, y1) */
} tile_rect;

static tile_rect rect_of(const rd_job *j, int t)
{
    const rd_scene *s = j->scene;
    tile_rect r = {(t % j->tiles_x) * j->tile, (t / j->tiles_x) * j->tile, 0, 0};
    r.x1 = r.x0 + j->tile < s->render.width ? r.x0 + j->tile : s->render.width;
    r.y1 = r.y0 + j->tile < s->render.height ? r.y0 + j->tile : s->render.height;
    return r;
}

int rd_job_render_tile(rd_job *j, int t, rd_job_counts *c)
{
    const rd_scene *s = j->scene;
    tile_rect r = rect_of(j, t);
    int x0 = r.x0, y0 = r.y0, x1 = r.x1, y1 = r.y1;
    uint32_t *done = j->direct ? &j->tile_done[t] : NULL;
    if (j->direct) {
        /* Black where a stop leaves pixels without their sample. */
        *done = 0;
        for (int y = y0; y < y1; y++)
            memset(&j->direct[3 * ((size_t)y * (size_t)s->render.width + (size_t)x0)], 0, 3 * (size_t)(x1 - x0));
    } else if (j->pass == 0)
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
    if (j->packets) {
        /* Neighbouring camera rays walk the same nodes: packets of
         * BLOCK x BLOCK pixels share the walk (world.h). */
        for (int y = y0; y < y1 && !rc.stopped; y += BLOCK)
            for (int x = x0; x < x1 && !rc.stopped; x += BLOCK)
                render_block(j, x, y, x + BLOCK < x1 ? x + BLOCK : x1, y + BLOCK < y1 ? y + BLOCK : y1, done, c, &rc);
    } else {
        for (int y = y0; y < y1 && !rc.stopped; y++)
            for (int x = x0; x < x1 && !rc.stopped; x++)
                render_pixel(j, x, y, done, c, &rc);
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
    if (j->direct) {
        if (out != j->direct)
            memcpy(out, j->direct, (size_t)j->scene->render.width * (size_t)j->scene->render.height * 3);
        return;
    }
    rd_image all = {j->scene->render.width, j->scene->render.height, j->mean};
    rd_image_to_rgb8(&all, j->scene->render.gamma, out);
}

void rd_job_tile_rgb8(const rd_job *j, int t, uint8_t *out)
{
    const rd_scene *s = j->scene;
    tile_rect r = rect_of(j, t);
    for (int y = r.y0; y < r.y1; y++) {
        size_t i = (size_t)y * (size_t)s->render.width + (size_t)r.x0;
        if (j->direct) {
            if (out != j->direct)
                memcpy(&out[3 * i], &j->direct[3 * i], 3 * (size_t)(r.x1 - r.x0));
            continue;
        }
        rd_image row = {r.x1 - r.x0, 1, &j->mean[3 * i]};
        rd_image_to_rgb8(&row, s->render.gamma, &out[3 * i]);
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

/* ---- a tile's state as bytes ---------------------------------------------------------------
 *
 * The arrays one after another, each over the tile's pixels in row order:
 * mean, n, then half and nh, then stat, as far as the job has them. */

typedef struct {
    unsigned char *base;
    size_t bytes; /* a pixel's */
} state_array;

static int state_arrays(const rd_job *j, state_array a[5])
{
    int k = 0;
    a[k++] = (state_array){(unsigned char *)j->mean, 3 * sizeof *j->mean};
    a[k++] = (state_array){(unsigned char *)j->n, sizeof *j->n};
    if (j->half) {
        a[k++] = (state_array){(unsigned char *)j->half, 6 * sizeof *j->half};
        a[k++] = (state_array){(unsigned char *)j->nh, 2 * sizeof *j->nh};
    }
    if (j->stat)
        a[k++] = (state_array){(unsigned char *)j->stat, 6 * sizeof *j->stat};
    return k;
}

static size_t tile_pixels(const rd_job *j, int t)
{
    tile_rect r = rect_of(j, t);
    return (size_t)(r.x1 - r.x0) * (size_t)(r.y1 - r.y0);
}

size_t rd_job_tile_state_bytes(const rd_job *j, int t)
{
    if (t < 0 || t >= j->tiles_total || !j->mean)
        return 0;
    state_array a[5];
    size_t per_pixel = 0;
    for (int i = 0, k = state_arrays(j, a); i < k; i++)
        per_pixel += a[i].bytes;
    return per_pixel * tile_pixels(j, t);
}

/* Between the job's arrays and a state: into `to` when given, else from `from`. */
static void copy_tile(const rd_job *j, int t, unsigned char *to, const unsigned char *from)
{
    state_array a[5];
    int k = state_arrays(j, a);
    tile_rect r = rect_of(j, t);
    size_t width = (size_t)j->scene->render.width;
    for (int i = 0; i < k; i++)
        for (int y = r.y0; y < r.y1; y++) {
            unsigned char *px = a[i].base + ((size_t)y * width + (size_t)r.x0) * a[i].bytes;
            size_t row = (size_t)(r.x1 - r.x0) * a[i].bytes;
            if (to) {
                memcpy(to, px, row);
                to += row;
            } else {
                memcpy(px, from, row);
                from += row;
            }
        }
}

void rd_job_tile_state_save(const rd_job *j, int t, void *out)
{
    if (rd_job_tile_state_bytes(j, t) > 0)
        copy_tile(j, t, out, NULL);
}

/* The passes' samples add up to at most the schedule's cap; before
 * rd_job_first_pass a pass has the scene's. */
static int samples_cap(const rd_job *j)
{
    int samples = j->scene->render.samples;
    return j->progress.max_samples > samples ? j->progress.max_samples : samples;
}

/* The most samples a pixel can hold: an adaptive pass gives a pixel at most
 * 64 times its samples (render_pixel). At most 2^31, so that a pass more
 * cannot wrap n. */
static uint32_t most_samples(const rd_job *j)
{
    uint64_t most = (uint64_t)samples_cap(j) * (j->adaptive ? 64 : 1);
    return most < (1u << 31) ? (uint32_t)most : 1u << 31;
}

/* One pixel of a state, read where it lies (the bytes need not be aligned),
 * the arrays in state_arrays' order. */
typedef struct {
    double mean[3];
    uint32_t n;
    float half[6];
    uint32_t nh[2];
    float stat[6];
} pixel_state;

static void read_pixel(const rd_job *j, const unsigned char *in, size_t npix, size_t i, pixel_state *p)
{
    memcpy(p->mean, in + i * sizeof p->mean, sizeof p->mean);
    in += npix * sizeof p->mean;
    memcpy(&p->n, in + i * sizeof p->n, sizeof p->n);
    in += npix * sizeof p->n;
    if (j->half) {
        memcpy(p->half, in + i * sizeof p->half, sizeof p->half);
        in += npix * sizeof p->half;
        memcpy(p->nh, in + i * sizeof p->nh, sizeof p->nh);
        in += npix * sizeof p->nh;
    }
    if (j->stat)
        memcpy(p->stat, in + i * sizeof p->stat, sizeof p->stat);
}

/* What no render writes, or NULL. Linear colours may be negative (a scene
 * may ask for a negative background or light); display values are clamped
 * to [0, 1]; samples alternate between the halves, the first to half 0; the
 * sum of squared deviations of n values in [0, 1] is at most n/4, and
 * rounding moves it (below 0 too) by a few ulps a sample: n leaves room. */
static const char *pixel_fault(const rd_job *j, const pixel_state *p)
{
    if (p->n > most_samples(j))
        return "more samples than the render takes";
    for (int ch = 0; ch < 3; ch++)
        if (!isfinite(p->mean[ch]))
            return "a non-finite mean";
    if (j->half) {
        if (p->nh[0] != p->n - p->n / 2 || p->nh[1] != p->n / 2)
            return "half-set counts that do not split its samples";
        for (int c = 0; c < 6; c++)
            if (!isfinite(p->half[c]))
                return "a non-finite half-set mean";
    }
    if (j->stat)
        for (int ch = 0; ch < 3; ch++) {
            if (!(p->stat[ch] >= 0 && p->stat[ch] <= 1))
                return "a display mean outside [0, 1] (or not a number)";
            if (!(fabs(p->stat[3 + ch]) <= p->n))
                return "a sum of squared deviations beyond its samples (or not a number)";
        }
    return NULL;
}

rd_error_code rd_job_tile_state_load(rd_job *j, int t, const void *in, size_t len, rd_error *err)
{
    if (t < 0 || t >= j->tiles_total)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "tile state: no tile %d (the job has %d)", t, j->tiles_total);
    if (!j->mean)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "tile state: the job %s",
                            j->direct ? "keeps only 8-bit pixels" : "'s image was taken");
    size_t want = rd_job_tile_state_bytes(j, t);
    if (len != want)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "tile %d: a state of %zu bytes, not %zu", t, len, want);
    tile_rect r = rect_of(j, t);
    size_t npix = tile_pixels(j, t), w = (size_t)(r.x1 - r.x0);
    /* All checked before any is copied: a rejected state leaves the tile as it was. */
    for (size_t i = 0; i < npix; i++) {
        pixel_state p;
        read_pixel(j, in, npix, i, &p);
        const char *fault = pixel_fault(j, &p);
        if (fault)
            return rd_error_set(err, RD_ERR_INVALID, 0, 0, "tile %d: pixel (%d, %d) has %s", t, r.x0 + (int)(i % w),
                                r.y0 + (int)(i / w), fault);
    }
    copy_tile(j, t, NULL, in);
    return RD_OK;
}

/* ---- the schedule ------------------------------------------------------------------------------ */

void rd_job_schedule_get(const rd_job *j, rd_job_schedule *out)
{
    memset(out, 0, sizeof *out);
    out->pass = j->pass;
    out->pass_samples = j->pass_samples;
    out->mean_weight = j->mean_weight;
    out->spp = j->spp;
    out->passes_done = j->passes_done;
    out->error = j->error;
    out->last_pass_ms = j->last_pass_ms;
    out->stopped_by = j->stopped_by;
    memcpy(out->curve, j->curve, sizeof out->curve);
    out->curve_len = j->curve_len;
}

static int finite_nonneg(double x) { return isfinite(x) && x >= 0; }

/* rd_job_end_pass ends pass p with passes_done = p + 1 and begins pass
 * p + 1 only when the schedule goes on, with no stop reason; every pass
 * has a sample at least, and they add up to at most the cap. */
static rd_error_code check_passes(const rd_job *j, const rd_job_schedule *sc, rd_error *err)
{
    int cap = samples_cap(j);
    long long ahead = (long long)sc->passes_done - sc->pass;
    if (sc->pass < 0 || (ahead != 0 && ahead != 1))
        return rd_error_set(err, RD_ERR_INVALID, 0, 0,
                            "schedule: pass %d with %d passes done (a pass >= 0 in progress, or the last one ended)",
                            sc->pass, sc->passes_done);
    if (sc->pass_samples < 1 || sc->pass_samples > cap || sc->spp < sc->passes_done || sc->spp > cap)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0,
                            "schedule: %d samples a pixel in this pass and %d in the %d passes done, with a cap of %d",
                            sc->pass_samples, sc->spp, sc->passes_done, cap);
    if ((int)sc->stopped_by < RD_STOP_NONE || (int)sc->stopped_by > RD_STOP_CANCELLED ||
        (sc->stopped_by == RD_STOP_NONE) != (ahead == 0))
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "schedule: stop reason %d with %s", (int)sc->stopped_by,
                            ahead == 0 ? "a pass in progress" : "the render ended");
    return RD_OK;
}

static rd_error_code check_figures(const rd_job *j, const rd_job_schedule *sc, rd_error *err)
{
    /* begin_pass takes a mean only for adaptive passes after the first. */
    int weighted = j->adaptive && sc->pass > 0;
    if (!isfinite(sc->mean_weight) || (!weighted && sc->mean_weight != 0))
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "schedule: mean weight %g for pass %d of %s render",
                            sc->mean_weight, sc->pass, j->adaptive ? "an adaptive" : "a uniform");
    if (!finite_nonneg(sc->error) || !finite_nonneg(sc->last_pass_ms))
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "schedule: error %g, last pass %g ms", sc->error,
                            sc->last_pass_ms);
    int points = sc->passes_done < RD_CURVE_MAX ? sc->passes_done : RD_CURVE_MAX;
    if (sc->curve_len != points)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0,
                            "schedule: %d curve points for %d passes done (one each, %d at most)", sc->curve_len,
                            sc->passes_done, RD_CURVE_MAX);
    for (int i = 0; i < sc->curve_len; i++) {
        const rd_curve_point *c = &sc->curve[i];
        if (!finite_nonneg(c->ms) || !finite_nonneg(c->samples) || !finite_nonneg(c->error))
            return rd_error_set(err, RD_ERR_INVALID, 0, 0, "schedule: curve point %d at %g ms, %g samples, error %g", i,
                                c->ms, c->samples, c->error);
    }
    return RD_OK;
}

rd_error_code rd_job_schedule_set(rd_job *j, const rd_job_schedule *sc, rd_error *err)
{
    /* Its pixels hold 8-bit values, which no later pass could add to. */
    if (j->direct && sc->pass != 0)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "schedule: pass %d of a job that keeps only 8-bit pixels",
                            sc->pass);
    rd_error_code rc = check_passes(j, sc, err);
    if (!rc)
        rc = check_figures(j, sc, err);
    if (rc)
        return rc;
    j->pass = sc->pass;
    j->pass_samples = sc->pass_samples;
    /* Not recomputed: this job's pixels of tiles rendered elsewhere may be
     * stale, and every process must weigh pass p's pixels alike. */
    j->mean_weight = sc->mean_weight;
    j->spp = sc->spp;
    j->passes_done = sc->passes_done;
    j->error = sc->error;
    j->last_pass_ms = sc->last_pass_ms;
    j->stopped_by = sc->stopped_by;
    memset(j->curve, 0, sizeof j->curve);
    memcpy(j->curve, sc->curve, (size_t)sc->curve_len * sizeof *sc->curve);
    j->curve_len = sc->curve_len;
    /* rd_job_end_pass on this job times the pass from here. */
    j->pass_t0 = rd_now_ms();
    return RD_OK;
}
