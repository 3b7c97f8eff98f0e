/* Whitted-style recursive tracing of one ray (shading.md, trace()). */
#ifndef RD_TRACE_H
#define RD_TRACE_H

#include <stdint.h>

#include "light.h"
#include "sampler.h"
#include "world.h"

/* What a render needs, decided once per scene. Ownership: rd_plan_build
 * allocates, rd_plan_free releases; the scene must outlive the plan. */
typedef struct {
    const rd_scene *scene;
    rd_world world;
    rd_light_prep *lights;
    size_t nlights;
    int recursive;      /* some used material sends secondary rays */
    int stochastic;     /* area lights draw random numbers per hit */
} rd_plan;

typedef struct {
    uint64_t camera, shadow, secondary;
    /* Optional deadline (monotonic ms, 0 = none), looked at every 4096
     * secondary rays: a glass ray tree is binary and max_depth may be 64,
     * so one camera ray can otherwise run for hours. Once passed, `stopped`
     * is set and tracing returns black at once. */
    double deadline_ms;
    uint64_t next_check;
    int stopped;
} rd_ray_counts;

/* Monotonic milliseconds, the clock of deadline_ms. */
double rd_now_ms(void);

rd_error_code rd_plan_build(rd_plan *p, const rd_scene *s, rd_error *err);
void rd_plan_free(rd_plan *p);

/* Radiance along r (unit direction), recursing while depth < max_depth.
 * rng supplies area-light jitter; counts gets the shadow and secondary rays. */
rd_rgb rd_trace(const rd_plan *p, rd_ray r, int depth, rd_rng *rng, rd_ray_counts *counts);

#endif
