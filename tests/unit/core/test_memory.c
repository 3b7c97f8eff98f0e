/* Large arrays (rayd/memory.h): growth keeps what was written, refuses
 * sizes that overflow, and a large block gets huge pages where the kernel
 * offers them. */
#include <criterion/criterion.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rayd/memory.h"

Test(memory, grow_doubles_from_first_and_keeps_contents)
{
    uint32_t *v = NULL;
    size_t cap = 0;
    cr_assert(rd_grow_array((void **)&v, &cap, 1, sizeof *v, 8));
    cr_assert_eq(cap, 8);
    cr_assert(rd_grow_array((void **)&v, &cap, 8, sizeof *v, 8));
    cr_assert_eq(cap, 8, "no growth while it fits");
    /* Past 4 MiB the block is copied into a new one: 3 million entries. */
    size_t n = 3u << 20;
    for (size_t i = 0; i < n; i++) {
        cr_assert(rd_grow_array((void **)&v, &cap, i + 1, sizeof *v, 8));
        v[i] = (uint32_t)(i * 2654435761u);
    }
    cr_assert_eq(cap, 4u << 20, "doubled from 8 to the first power of two over %zu", n);
    for (size_t i = 0; i < n; i++)
        if (v[i] != (uint32_t)(i * 2654435761u))
            cr_assert_fail("entry %zu lost in growth", i);
    free(v);
}

Test(memory, grow_refuses_overflow_and_keeps_the_array)
{
    double *v = NULL;
    size_t cap = 0;
    cr_assert(rd_grow_array((void **)&v, &cap, 3, sizeof *v, 4));
    v[0] = 1.5;
    cr_assert_not(rd_grow_array((void **)&v, &cap, SIZE_MAX / 4, sizeof *v, 4));
    cr_assert_not(rd_grow_array((void **)&v, &cap, SIZE_MAX, 1, 4));
    cr_assert_eq(cap, 4);
    cr_assert_eq(v[0], 1.5);
    free(v);
}

/* The kernel's setting, as /sys shows it: "always [madvise] never". */
static int thp_mode(char *mode, size_t n)
{
    FILE *f = fopen("/sys/kernel/mm/transparent_hugepage/enabled", "r");
    char line[128] = "";
    if (!f)
        return 0;
    int ok = fgets(line, sizeof line, f) != NULL;
    fclose(f);
    char *a = strchr(line, '['), *b = a ? strchr(a, ']') : NULL;
    if (!ok || !b || (size_t)(b - a) >= n)
        return 0;
    memcpy(mode, a + 1, (size_t)(b - a - 1));
    mode[b - a - 1] = 0;
    return 1;
}

/* Huge pages of the mapping that holds p, from /proc/self/smaps. */
static long huge_kb_at(const void *p)
{
    FILE *f = fopen("/proc/self/smaps", "r");
    cr_assert(f);
    char line[512];
    int inside = 0;
    long kb = -1;
    while (fgets(line, sizeof line, f)) {
        unsigned long lo, hi;
        if (sscanf(line, "%lx-%lx ", &lo, &hi) == 2 && strchr(line, '-') < strchr(line, ' '))
            inside = (uintptr_t)p >= lo && (uintptr_t)p < hi;
        else if (inside && sscanf(line, "AnonHugePages: %ld kB", &kb) == 1)
            break;
    }
    fclose(f);
    return kb;
}

Test(memory, a_large_block_gets_huge_pages_where_the_kernel_has_them)
{
    char mode[32];
    size_t n = 32u << 20;
    char *p = rd_big_malloc(n);
    cr_assert(p);
    memset(p, 1, n);
    if (thp_mode(mode, sizeof mode) && strcmp(mode, "never") != 0) {
        long kb = huge_kb_at(p + n / 2);
        cr_assert_gt(kb, 0, "transparent huge pages are '%s' here, yet the 32 MiB block has none (%ld kB)", mode, kb);
    } else {
        cr_log_info("transparent huge pages are off here: only the block's contents are checked");
    }
    for (size_t i = 0; i < n; i += 4096)
        cr_assert_eq(p[i], 1);
    free(p);
}
