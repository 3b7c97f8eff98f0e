/* Whitted-style recursive tracing of one ray (shading.md, trace()). */
#ifndef RD_TRACE_H
#define RD_TRACE_H

#include <stdatomic.h>
#include <stdint.h>

#include "light.h"
#include "rayd/job.h"
#include "sampler.h"
#include "world.h"

/* What a render needs, decided once per scene. Ownership: rd_plan_build
 * allocates, rd_plan_free releases; the scene must outlive the plan. */
typedef struct {
    const rd_scene *scene;
    rd_world world;
    rd_light_prep *lights;
    size_t nlights;
    int recursive;  /* some used material sends secondary rays */
    int stochastic; /* area lights draw random numbers per hit */
} rd_plan;

#define RD_OCCLUDER_LIGHTS 16

typedef struct {
    uint64_t camera, shadow, secondary;
    /* Stopping in bounded time. A glass ray tree is binary and max_depth
     * may be 64, and an area light may send thousands of shadow rays a hit,
     * so one camera ray can otherwise run for hours. Every unit of work (a
     * camera sample, a light sample, a secondary ray) counts down
     * until_check; at zero the deadline (monotonic ms, 0 = none) and the
     * cancel flag (NULL = none) are looked at, and the interval adapts so
     * that looks come about once a millisecond whatever a unit costs. Once
     * either fires, `stopped` is set and tracing returns black at once.
     * Set up with rd_counts_init; the looks never change what is traced. */
    double deadline_ms;
    const atomic_int *cancel;
    int64_t until_check, check_every;
    double last_check_ms;
    int stopped;
    /* The last occluder of each of the first RD_OCCLUDER_LIGHTS lights'
     * shadow rays (rd_world_any_hint), per thread like the rest. */
    uint32_t occluder[RD_OCCLUDER_LIGHTS];
} rd_ray_counts;

/* Zero counts that stop at deadline_ms (0 = never) or once *cancel is
 * non-zero (cancel may be NULL). */
void rd_counts_init(rd_ray_counts *c, double deadline_ms, const atomic_int *cancel);

/* The slow half of rd_counts_tick: returns c->stopped after a look. */
int rd_counts_check(rd_ray_counts *c);

/* One unit of work done; 1 when the render must stop. */
static inline int rd_counts_tick(rd_ray_counts *c) { return --c->until_check > 0 ? 0 : rd_counts_check(c); }

rd_error_code rd_plan_build(rd_plan *p, const rd_scene *s, rd_error *err);

/* The same with the BVH built on up to `threads` threads. */
rd_error_code rd_plan_build_threads(rd_plan *p, const rd_scene *s, int threads, rd_error *err);
void rd_plan_free(rd_plan *p);

/* Radiance along r (unit direction), recursing while depth < max_depth.
 * rng supplies area-light jitter; counts gets the shadow and secondary rays. */
rd_rgb rd_trace(const rd_plan *p, rd_ray r, int depth, rd_rng *rng, rd_ray_counts *counts);

/* rd_trace(p, r[i], 0, &rng[i], counts) for n camera rays (n at most
 * RD_PACKET_MAX), into out[i]: the same colours and counts to the bit,
 * with what `how` names (RD_PACKETS_*, rayd/job.h) traced as packets
 * (world.h) and the rest ray by ray. */
void rd_trace_packet(const rd_plan *p, const rd_ray *r, int n, unsigned how, rd_rng *rng, rd_ray_counts *counts,
                     rd_rgb *out);

#endif
