#include "job.h"

#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "camera.h"
#include "trace.h"

typedef struct {
    double mean[3];     /* linear colour */
    float dmean[3];     /* display value, for the error estimate */
    float m2[3];
    uint32_t n;
} pixel;

struct rd_job {
    const rd_scene *scene;
    rd_pinhole cam;
    rd_plan plan;
    pixel *px;
    int tile, tiles_x, tiles_total;
    uint32_t *tile_samples;
    double plan_ms;
};

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

rd_error_code rd_job_create(const rd_scene *s, int tile, rd_job **out, rd_error *err)
{
    *out = NULL;
    double t0 = now_ms();
    rd_job *j = calloc(1, sizeof *j);
    if (!j)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    j->scene = s;
    j->tile = tile < 1 ? 16 : tile;
    rd_error_code rc = rd_pinhole_make(&j->cam, &s->camera, s->render.width, s->render.height, err);
    if (rc) {
        free(j);
        return rc;
    }
    rc = rd_plan_build(&j->plan, s, err);
    if (rc) {
        free(j);
        return rc;
    }
    size_t npix = (size_t)s->render.width * (size_t)s->render.height;
    j->tiles_x = (s->render.width + j->tile - 1) / j->tile;
    j->tiles_total = j->tiles_x * ((s->render.height + j->tile - 1) / j->tile);
    j->px = calloc(npix, sizeof *j->px);
    j->tile_samples = calloc((size_t)j->tiles_total, sizeof *j->tile_samples);
    if (!j->px || !j->tile_samples) {
        rd_job_free(j);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory for a %dx%d image", s->render.width,
                            s->render.height);
    }
    j->plan_ms = now_ms() - t0;
    *out = j;
    return RD_OK;
}

void rd_job_free(rd_job *j)
{
    if (!j)
        return;
    rd_plan_free(&j->plan);
    free(j->px);
    free(j->tile_samples);
    free(j);
}

int rd_job_tile_count(const rd_job *j) { return j->tiles_total; }
int rd_job_width(const rd_job *j) { return j->scene->render.width; }
int rd_job_height(const rd_job *j) { return j->scene->render.height; }
const rd_scene *rd_job_scene(const rd_job *j) { return j->scene; }
uint32_t rd_job_tile_samples(const rd_job *j, int t) { return j->tile_samples[t]; }

static double finite_or_zero(double x, uint64_t *bad)
{
    if (isfinite(x))
        return x;
    (*bad)++;
    return isnan(x) ? 0 : (x > 0 ? DBL_MAX : -DBL_MAX);
}

static void render_pixel(rd_job *j, int x, int y, int pass, int samples, rd_job_counts *c,
                         rd_ray_counts *rc)
{
    const rd_scene *s = j->scene;
    uint64_t index = (uint64_t)y * (uint64_t)s->render.width + (uint64_t)x;
    pixel *p = &j->px[index];
    /* Pass 0 keeps the pattern of a plain render; later passes draw new ones. */
    uint32_t pattern = rd_pattern(s->render.seed + (uint64_t)pass * 0x9e3779b97f4a7c15ULL, index);
    double g = s->render.gamma;
    int centre = pass == 0 && samples == 1;
    for (int k = 0; k < samples; k++) {
        double px = 0.5, py = 0.5;
        if (!centre)
            rd_cmj((uint32_t)k, (uint32_t)samples, pattern, &px, &py);
        rd_ray r = rd_pinhole_ray(&j->cam, x + px, y + py);
        rd_rng rng = rd_rng_make(s->render.seed, index, (uint64_t)p->n);
        c->camera++;
        rd_rgb col = rd_trace(&j->plan, r, 0, &rng, rc);
        double cv[3] = {finite_or_zero(col.x, &c->nonfinite), finite_or_zero(col.y, &c->nonfinite),
                        finite_or_zero(col.z, &c->nonfinite)};
        uint32_t n = ++p->n;
        for (int ch = 0; ch < 3; ch++) {
            p->mean[ch] += (cv[ch] - p->mean[ch]) / n;
            double d = rd_display(cv[ch], g);
            double delta = d - p->dmean[ch];
            p->dmean[ch] = (float)(p->dmean[ch] + delta / n);
            p->m2[ch] = (float)(p->m2[ch] + delta * (d - p->dmean[ch]));
        }
    }
}

void rd_job_render_tile(rd_job *j, int t, int pass, int samples, rd_job_counts *c)
{
    const rd_scene *s = j->scene;
    int x0 = (t % j->tiles_x) * j->tile, y0 = (t / j->tiles_x) * j->tile;
    int x1 = x0 + j->tile < s->render.width ? x0 + j->tile : s->render.width;
    int y1 = y0 + j->tile < s->render.height ? y0 + j->tile : s->render.height;
    rd_ray_counts rc = {0, 0, 0};
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++)
            render_pixel(j, x, y, pass, samples < 1 ? 1 : samples, c, &rc);
    c->shadow += rc.shadow;
    c->secondary += rc.secondary;
    j->tile_samples[t] += (uint32_t)(samples < 1 ? 1 : samples);
}

rd_error_code rd_job_image(const rd_job *j, rd_image *out, rd_error *err)
{
    size_t npix = (size_t)j->scene->render.width * (size_t)j->scene->render.height;
    out->width = j->scene->render.width;
    out->height = j->scene->render.height;
    out->rgb = malloc(npix * 3 * sizeof(double));
    if (!out->rgb) {
        out->width = out->height = 0;
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory for the image");
    }
    for (size_t i = 0; i < npix; i++)
        memcpy(&out->rgb[3 * i], j->px[i].mean, 3 * sizeof(double));
    return RD_OK;
}

void rd_job_rgb8(const rd_job *j, uint8_t *out)
{
    size_t npix = (size_t)j->scene->render.width * (size_t)j->scene->render.height;
    double g = j->scene->render.gamma;
    for (size_t i = 0; i < npix; i++)
        for (int ch = 0; ch < 3; ch++)
            out[3 * i + ch] = (uint8_t)floor(rd_display(j->px[i].mean[ch], g) * 255.0 + 0.5);
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
                out[3 * i + ch] = (uint8_t)floor(rd_display(j->px[i].mean[ch], g) * 255.0 + 0.5);
        }
}

double rd_job_error_estimate(const rd_job *j)
{
    size_t npix = (size_t)j->scene->render.width * (size_t)j->scene->render.height;
    double sum = 0;
    for (size_t i = 0; i < npix; i++) {
        const pixel *p = &j->px[i];
        if (p->n > 1)
            sum += ((double)p->m2[0] + p->m2[1] + p->m2[2]) / ((double)(p->n - 1) * p->n);
    }
    return sqrt(sum / (3.0 * (double)npix));
}

void rd_job_plan_stats(const rd_job *j, rd_render_stats *st)
{
    st->prepare_ms = j->plan_ms;
    st->bvh_build_ms = j->plan.world.build_ms;
    st->bvh_nodes = j->plan.world.bvh.nnodes;
    st->world_bytes = rd_world_bytes(&j->plan.world);
    st->primitives = j->plan.world.nspheres + j->plan.world.nplanes + j->plan.world.ntris;
}
