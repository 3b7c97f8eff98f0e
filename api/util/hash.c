#include "hash.h"

#include <sys/random.h>
#include <time.h>

uint64_t rd_fnv1a(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; i++) {
        h ^= p[i];
        h *= 0x100000001b3ULL;
    }
    return h;
}

uint64_t rd_mix64(uint64_t z)
{
    z += 0x9e3779b97f4a7c15ULL;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

uint64_t rd_random_key(void)
{
    uint64_t key;
    if (getrandom(&key, sizeof key, 0) == (ssize_t)sizeof key)
        return key;
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return rd_mix64((uint64_t)ts.tv_sec * 1000000000ULL + (uint64_t)ts.tv_nsec);
}
