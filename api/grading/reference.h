/* Reference images for grading: a key per scene and renderer, and one
 * cache of references (memory and disk) that `rayd grade` and the daemon
 * share the rules of.
 *
 * The key hashes the scene as the renderer sees it (its canonical cfg text,
 * its mesh and texture data) and the renderer's own source, so a changed
 * scene or renderer never meets an old reference. */
#ifndef RD_REFERENCE_H
#define RD_REFERENCE_H

#include <stddef.h>
#include <stdint.h>

#include "rayd/error.h"
#include "rayd/scene.h"

/* The renderer's identity: a hash of core/ fixed at build time. */
const char *rd_renderer_id(void);

/* 16 hex digits naming the reference of a loaded scene (assets included). */
rd_error_code rd_reference_key(const rd_scene *s, char key[17], rd_error *err);

/* References by key: up to max_bytes of them in memory (the least recently
 * used go first), and, when dir is not NULL, every one as dir/KEY.png. A
 * file that cannot be read, is not a PNG or has the wrong size counts as
 * missing; a failure to write one only costs a render next time. All
 * functions may be called from several threads at once. */
typedef struct rd_ref_cache rd_ref_cache;

/* on_bytes, when not NULL, hears of every change in the memory the cache
 * holds (called with the cache's lock held: it must not call back). dir
 * must outlive the cache. NULL when out of memory. */
rd_ref_cache *rd_ref_cache_new(size_t max_bytes, const char *dir, void (*on_bytes)(void *user, long long delta),
                               void *user);

/* Frees every reference, without telling on_bytes; NULL is a no-op. */
void rd_ref_cache_free(rd_ref_cache *c);

/* A malloc'ed copy (the caller frees it) of key's reference of w x h
 * pixels, 8-bit RGB; from memory, else from disk (and then kept in memory).
 * NULL when there is none. */
uint8_t *rd_ref_cache_get(rd_ref_cache *c, const char *key, int w, int h);

/* Keeps a copy of rgb (w x h, 8-bit RGB) under key, and writes it to disk. */
void rd_ref_cache_put(rd_ref_cache *c, const char *key, const uint8_t *rgb, int w, int h);

/* Changes the memory cap, dropping the least recently used past it. */
void rd_ref_cache_set_max_bytes(rd_ref_cache *c, size_t max_bytes);

/* The memory the references hold now. */
size_t rd_ref_cache_bytes(rd_ref_cache *c);

#endif
