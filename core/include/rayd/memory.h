/* Large arrays: a mesh's vertices and faces, a world's triangles, a BVH's
 * records and nodes, a file read whole. Each is written once, page by
 * page, right after it is allocated, and with 4 KiB pages that first touch
 * is one page fault per 4 KiB: loading and building a million triangles
 * spent a quarter of its time in the kernel. Transparent huge pages (Linux,
 * "madvise" mode, Debian's default) take 512 times fewer faults; these
 * functions ask for them on blocks of 4 MiB or more.
 *
 * Ownership: what rd_big_malloc and rd_big_realloc return is released with
 * free(), like any malloc'ed block. Errors: as malloc and realloc (NULL,
 * and for realloc the old block kept); the hint itself never fails, it is
 * only advice the kernel may ignore. */
#ifndef RD_MEMORY_H
#define RD_MEMORY_H

#include <stddef.h>

/* Asks for huge pages under the whole pages of [p, p + bytes); nothing
 * below 4 MiB or where the system has no such advice. Call it before the
 * block is first written: pages already touched stay as they are. */
void rd_mem_hint_huge(void *p, size_t bytes);

/* malloc and realloc, with the hint on the new block (for realloc, on the
 * part beyond what the old block held is what gains). */
void *rd_big_malloc(size_t bytes);
void *rd_big_realloc(void *p, size_t bytes);

/* Room for at least `need` elements of `size` bytes in *arr, whose
 * capacity is *cap elements: doubled from `first` (or from *cap) until it
 * fits. 1 on success; 0 on overflow or out of memory, with *arr and *cap
 * as they were. */
int rd_grow_array(void **arr, size_t *cap, size_t need, size_t size, size_t first);

#endif
