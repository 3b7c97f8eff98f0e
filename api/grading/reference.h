/* Reference images for grading: rendered once per scene and renderer,
 * cached on disk under a key that hashes the scene as the renderer sees it
 * (its canonical cfg text, its mesh and texture data) and the renderer's
 * own source. */
#ifndef RD_REFERENCE_H
#define RD_REFERENCE_H

#include <stdint.h>

#include "rayd/error.h"
#include "rayd/scene.h"

/* The renderer's identity: a hash of core/ fixed at build time. */
const char *rd_renderer_id(void);

/* 16 hex digits naming the reference of a loaded scene (assets included). */
rd_error_code rd_reference_key(const rd_scene *s, char key[17], rd_error *err);

/* Renders s (or reads cache_dir/KEY.png when present; cache_dir NULL means
 * no cache) into 8-bit RGB, *rgb malloc'ed. *from_cache says which. */
rd_error_code rd_reference_get(const rd_scene *s, const char *cache_dir, int threads, uint8_t **rgb, int *width,
                               int *height, int *from_cache, rd_error *err);

#endif
