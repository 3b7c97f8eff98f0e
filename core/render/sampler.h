/* Deterministic sample generation: every value depends only on the scene
 * seed and on where it is used (pixel, sample index, light), never on
 * threads or tile order. */
#ifndef RD_SAMPLER_H
#define RD_SAMPLER_H

#include <stdint.h>

/* A small counter-based generator (SplitMix64 steps). */
typedef struct {
    uint64_t s;
} rd_rng;

/* Generator for one use, keyed by up to three integers. */
rd_rng rd_rng_make(uint64_t seed, uint64_t a, uint64_t b);

/* Uniform in [0, 1), 53 random bits. */
double rd_rng_next(rd_rng *r);

/* Sample s of n in the unit square, correlated multi-jittered (Kensler,
 * "Correlated Multi-Jittered Sampling", Pixar TM 13-01, 2013) on an m×k
 * grid with m·k = n exactly: stratified in both axes for any n, every
 * stratum filled, so the mean of any n samples is unbiased. Pattern p
 * chooses the permutation. */
void rd_cmj(uint32_t s, uint32_t n, uint32_t p, double *x, double *y);

/* A 32-bit pattern number from a seed and a pixel index. */
uint32_t rd_pattern(uint64_t seed, uint64_t pixel);

#endif
