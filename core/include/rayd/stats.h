/* What a render reports: how long it took, how many rays, how far it still
 * is from converged, and the error-against-time curve. Filled by rd_render
 * (render.h) and, for renders it schedules itself, by the daemon from the
 * job (job.h). */
#ifndef RD_STATS_H
#define RD_STATS_H

#include <stddef.h>
#include <stdint.h>

#include "rayd/progress.h"

typedef struct {
    double wall_ms;
    uint64_t camera_rays, shadow_rays, secondary_rays;
    double rays_per_second; /* all three kinds over wall time */
    int samples;            /* per pixel (rounded mean, when adaptive) */
    double mean_samples;    /* exact mean per pixel */
    /* Root-mean-square standard error of the pixel means, over pixels and
     * channels, in output units (after clamp and gamma, 1 = 255): predicts
     * the RMSE of this image against a converged one. 0 with one sample. */
    double error_estimate;
    uint64_t nonfinite; /* samples that were NaN or infinite (and replaced); 0 */
    int threads;
    double prepare_ms;   /* building the plan: coordinates, lights, BVH */
    double bvh_build_ms; /* of which the BVH (0 when the scene needs none) */
    size_t bvh_nodes;
    size_t world_bytes;        /* memory of the prepared surfaces and the BVH */
    size_t primitives;         /* spheres, planes and triangles traced */
    rd_stop_reason stopped_by; /* which rule ended the render */
    int passes;
    rd_curve_point curve[RD_CURVE_MAX]; /* error against time, one point per pass */
    int curve_len;
} rd_render_stats;

#endif
