#include "rayd/memory.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

enum { HUGE_MIN = 4 << 20 };

/* Huge pages under the whole pages of [p, p + bytes), asked for before the
 * block is first written: pages already touched stay as they are. */
static void hint_huge(void *p, size_t bytes)
{
#ifdef MADV_HUGEPAGE
    if (!p || bytes < HUGE_MIN)
        return;
    long ps = sysconf(_SC_PAGESIZE);
    uintptr_t page = ps > 0 ? (uintptr_t)ps : 4096;
    uintptr_t a = ((uintptr_t)p + page - 1) & ~(page - 1), b = ((uintptr_t)p + bytes) & ~(page - 1);
    /* Only advice: a kernel without transparent huge pages says EINVAL,
     * and the block works the same either way. */
    if (b > a)
        (void)madvise((void *)a, b - a, MADV_HUGEPAGE);
#else
    (void)p;
    (void)bytes;
#endif
}

void *rd_big_malloc(size_t bytes)
{
    void *p = malloc(bytes);
    hint_huge(p, bytes);
    return p;
}

int rd_grow_array(void **arr, size_t *cap, size_t need, size_t size, size_t first)
{
    if (need <= *cap)
        return 1;
    size_t nc = *cap ? *cap : (first ? first : 1);
    while (nc < need) {
        if (nc > SIZE_MAX / 2)
            return 0;
        nc *= 2;
    }
    if (size && nc > SIZE_MAX / size)
        return 0;
    void *p;
    if (nc * size < HUGE_MIN) {
        p = realloc(*arr, nc * size);
    } else {
        /* A new block hinted before the copy writes it: realloc would copy
         * into pages faulted 4 KiB at a time (it moves a block only by
         * copying, except where it can remap). */
        p = rd_big_malloc(nc * size);
        if (p && *arr) {
            memcpy(p, *arr, *cap * size);
            free(*arr);
        }
    }
    if (!p)
        return 0;
    *arr = p;
    *cap = nc;
    return 1;
}
