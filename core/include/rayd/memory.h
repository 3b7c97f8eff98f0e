/* Large arrays: a mesh's vertices and faces, a world's triangles, a BVH's
 * records and nodes, a file read whole. Each is written once, page by
 * page, right after it is allocated, and with 4 KiB pages that first touch
 * is one page fault per 4 KiB: loading and building a million triangles
 * spent a quarter of its time in the kernel. Transparent huge pages (Linux,
 * "madvise" mode, Debian's default) take 512 times fewer faults; these
 * functions ask for them on blocks of 4 MiB or more.
 *
 * Ownership: what rd_big_malloc returns, and what rd_grow_array grows, is
 * released with free(), like any malloc'ed block. Errors: as malloc (NULL);
 * the request for huge pages never fails, it is only advice the kernel may
 * ignore. */
#ifndef RD_MEMORY_H
#define RD_MEMORY_H

#include <stddef.h>

/* malloc, with huge pages asked for when bytes is 4 MiB or more (before
 * anything is written: pages already touched would stay as they are). */
void *rd_big_malloc(size_t bytes);

/* Room for at least `need` elements of `size` bytes in *arr, whose
 * capacity is *cap elements: doubled from `first` (or from *cap) until it
 * fits. 1 on success; 0 on overflow or out of memory, with *arr and *cap
 * as they were. */
int rd_grow_array(void **arr, size_t *cap, size_t need, size_t size, size_t first);

#endif
