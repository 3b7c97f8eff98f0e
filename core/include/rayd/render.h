/* Rendering a scene into an image, with statistics. The core's entry point.
 *
 * Ownership: rd_render allocates out->rgb; the caller frees it with
 * rd_image_free. rd_render_rgb8 writes into the caller's bytes. The scene
 * is only read, and may be shared by renders. */
#ifndef RD_RENDER_H
#define RD_RENDER_H

#include <stdatomic.h>
#include <stdint.h>

#include "rayd/error.h"
#include "rayd/image.h"
#include "rayd/progress.h"
#include "rayd/scene.h"
#include "rayd/stats.h"

typedef struct {
    int threads;              /* worker threads; < 1 means 1 */
    int tile;                 /* tile edge in pixels; < 1 means RD_JOB_TILE (job.h) */
    const atomic_int *cancel; /* optional: non-zero stops the render within milliseconds */
    /* Optional; called by a worker after each tile, possibly concurrently. */
    void (*progress)(void *user, int tiles_done, int tiles_total);
    /* Optional; called by the calling thread before each pass with its
     * number (0 first) and samples per pixel, and once after the last with
     * samples 0; ended is the curve point of the pass just ended (NULL
     * before the first). Not called after a cancel. */
    void (*pass)(void *user, int pass, int samples, const rd_curve_point *ended);
    void *user; /* given to progress and pass */
    /* Progressive rendering (progress.h): either makes the render run
     * passes until the scene's samples, the budget or the target error,
     * whichever comes first. */
    double time_budget_ms; /* <= 0: none */
    double target_error;   /* <= 0: none */
    int adaptive;          /* later passes spend samples where the error is */
    unsigned packets;      /* rd_job_options.packets (job.h) */
} rd_render_options;

/* Renders s as its render section says. On RD_ERR_CANCELLED the image is
 * freed. Any error leaves *out empty. */
rd_error_code rd_render(const rd_scene *s, const rd_render_options *opt, rd_image *out, rd_render_stats *stats,
                        rd_error *err);

/* rd_render's image as 8-bit RGB (rd_image_to_rgb8's bytes with the scene's
 * gamma) into out, the caller's width·height·3 bytes, and no linear image:
 * a render of one sample that is not progressive writes them as it goes
 * (rd_job_options.rgb8), 3 bytes a pixel instead of 31. On an error out
 * holds no image. */
rd_error_code rd_render_rgb8(const rd_scene *s, const rd_render_options *opt, uint8_t *out, rd_render_stats *stats,
                             rd_error *err);

#endif
