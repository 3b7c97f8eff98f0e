/* Rendering a scene into an image, with statistics. The core's entry point.
 *
 * Ownership: rd_render allocates out->rgb; the caller frees it with
 * rd_image_free. The scene is only read, and may be shared by renders. */
#ifndef RD_RENDER_H
#define RD_RENDER_H

#include <stdatomic.h>
#include <stdint.h>

#include "error.h"
#include "progress.h"
#include "scene.h"

typedef struct {
    int threads;                /* worker threads; < 1 means 1 */
    int tile;                   /* tile edge in pixels; < 1 means 16 */
    const atomic_int *cancel;   /* optional: non-zero stops the render within milliseconds */
    /* Optional; called by a worker after each tile, possibly concurrently. */
    void (*progress)(void *user, int tiles_done, int tiles_total);
    void *user;
    /* Progressive rendering (progress.h): either makes the render run
     * passes until the scene's samples, the budget or the target error,
     * whichever comes first. */
    double time_budget_ms;      /* <= 0: none */
    double target_error;        /* <= 0: none */
    int adaptive;               /* later passes spend samples where the error is */
} rd_render_options;

typedef struct {
    double wall_ms;
    uint64_t camera_rays, shadow_rays, secondary_rays;
    double rays_per_second;     /* all three kinds over wall time */
    int samples;                /* per pixel (rounded mean, when adaptive) */
    double mean_samples;        /* exact mean per pixel */
    /* Root-mean-square standard error of the pixel means, over pixels and
     * channels, in output units (after clamp and gamma, 1 = 255): predicts
     * the RMSE of this image against a converged one. 0 with one sample. */
    double error_estimate;
    uint64_t nonfinite;         /* samples that were NaN or infinite (and replaced); 0 */
    int threads;
    double prepare_ms;          /* building the plan: coordinates, lights, BVH */
    double bvh_build_ms;        /* of which the BVH (0 when the scene needs none) */
    size_t bvh_nodes;
    size_t world_bytes;         /* memory of the prepared surfaces and the BVH */
    size_t primitives;          /* spheres, planes and triangles traced */
    rd_stop_reason stopped_by;  /* which rule ended the render */
    int passes;
    rd_curve_point curve[RD_CURVE_MAX]; /* error against time, one point per pass */
    int curve_len;
} rd_render_stats;

typedef struct {
    int width, height;
    double *rgb;                /* linear colour, row-major, 3 per pixel, top row first */
} rd_image;

/* Renders s as its render section says. On RD_ERR_CANCELLED the image is
 * freed. Any error leaves *out empty. */
rd_error_code rd_render(const rd_scene *s, const rd_render_options *opt, rd_image *out,
                        rd_render_stats *stats, rd_error *err);

void rd_image_free(rd_image *img);

/* Display value of one channel: clamp to [0,1], then ^(1/gamma). */
double rd_display(double c, double gamma);

/* 8-bit RGB, 3 bytes per pixel: floor(display·255 + 0.5). out holds
 * width·height·3 bytes. */
void rd_image_to_rgb8(const rd_image *img, double gamma, uint8_t *out);

#endif
