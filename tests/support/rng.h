/* The seeded generator of the randomized tests: SplitMix64 (Steele, Lea &
 * Flood, "Fast splittable pseudorandom number generators", OOPSLA 2014),
 * 53-bit doubles. A test's draws depend only on its seed, not on the core's
 * sampler (core/render/sampler.h), so changing the renderer's sampling
 * never changes the cases a test generates.
 *
 * The helpers draw their coordinates in the order x, y, z. In C the order in
 * which function arguments are evaluated is unspecified, so two draws in
 * one argument list may come in either order: write them as separate
 * statements where the order matters. */
#ifndef RD_TEST_RNG_H
#define RD_TEST_RNG_H

#include <stdint.h>

#include "rayd/vec3.h"

typedef struct {
    uint64_t s;
} test_rng;

static inline uint64_t rng_u64(test_rng *g)
{
    uint64_t z = (g->s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

/* Uniform in [0, 1). */
static inline double rng_uniform(test_rng *g) { return (double)(rng_u64(g) >> 11) * 0x1.0p-53; }

/* Uniform in [lo, hi). */
static inline double rng_range(test_rng *g, double lo, double hi) { return lo + (hi - lo) * rng_uniform(g); }

/* Uniform in 0 .. n-1 (n > 0; the modulo bias is below n/2^64). */
static inline int rng_int(test_rng *g, int n) { return (int)(rng_u64(g) % (uint64_t)n); }

/* Uniform in the cube [lo, hi)³. */
static inline rd_vec3 rng_point(test_rng *g, double lo, double hi)
{
    double x = rng_range(g, lo, hi);
    double y = rng_range(g, lo, hi);
    double z = rng_range(g, lo, hi);
    return v3(x, y, z);
}

/* A unit vector, uniform on the sphere (rejection from the cube). */
static inline rd_vec3 rng_unit(test_rng *g)
{
    for (;;) {
        rd_vec3 v = rng_point(g, -1, 1);
        double l2 = v3_dot(v, v);
        if (l2 > 1e-4 && l2 <= 1)
            return v3_normalize(v);
    }
}

#endif
