#include "sampler.h"

#include <math.h>

static uint64_t mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

rd_rng rd_rng_make(uint64_t seed, uint64_t a, uint64_t b)
{
    rd_rng r;
    r.s = mix64(mix64(mix64(seed + 0x9e3779b97f4a7c15ULL) ^ a) + b);
    return r;
}

double rd_rng_next(rd_rng *r)
{
    r->s += 0x9e3779b97f4a7c15ULL;
    return (double)(mix64(r->s) >> 11) * 0x1.0p-53;
}

uint32_t rd_pattern(uint64_t seed, uint64_t pixel)
{
    return (uint32_t)(mix64(mix64(seed ^ 0x5851f42d4c957f2dULL) + pixel) >> 32);
}

/* Kensler's hashed permutation of [0, l): a bijection for each p. */
static uint32_t permute(uint32_t i, uint32_t l, uint32_t p)
{
    uint32_t w = l - 1;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    do {
        i ^= p;
        i *= 0xe170893dU;
        i ^= p >> 16;
        i ^= (i & w) >> 4;
        i ^= p >> 8;
        i *= 0x0929eb3fU;
        i ^= p >> 23;
        i ^= (i & w) >> 1;
        i *= 1U | p >> 27;
        i *= 0x6935fa69U;
        i ^= (i & w) >> 11;
        i *= 0x74dcb303U;
        i ^= (i & w) >> 2;
        i *= 0x9e501cc3U;
        i ^= (i & w) >> 2;
        i *= 0xc860a3dfU;
        i &= w;
        i ^= i >> 5;
    } while (i >= l);
    return (i + p) % l;
}

static double randfloat(uint32_t i, uint32_t p)
{
    i ^= p;
    i ^= i >> 17;
    i ^= i >> 10;
    i *= 0xb36534e5U;
    i ^= i >> 12;
    i ^= i >> 21;
    i *= 0x93fc4795U;
    i ^= 0xdf6e307fU;
    i ^= i >> 17;
    i *= 1U | p >> 18;
    return i * (1.0 / 4294967296.0);
}

void rd_cmj(uint32_t s, uint32_t n, uint32_t p, double *x, double *y)
{
    /* An m×k grid with m·k = n exactly (m the largest divisor of n up to
     * √n): a grid with a partly filled last row would leave part of the
     * pixel under-sampled and bias the mean. Prime n gives a 1×n grid,
     * still stratified in both axes (n-rooks). */
    if (n == 0)
        n = 1;
    uint32_t m = (uint32_t)sqrt((double)n);
    while (m > 1 && n % m != 0)
        m--;
    if (m == 0)
        m = 1;
    uint32_t k = n / m;
    s = permute(s, n, p * 0x51633e2dU);
    uint32_t sx = permute(s % m, m, p * 0x68bc21ebU);
    uint32_t sy = permute(s / m, k, p * 0x02e5be93U);
    double jx = randfloat(s, p * 0x967a889bU);
    double jy = randfloat(s, p * 0x368cc8b7U);
    *x = ((s % m) + (sy + jx) / k) / m;
    *y = ((s / m) + (sx + jy) / m) / k;
}
