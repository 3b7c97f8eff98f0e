/* Size limits on scene input, shared by the CLI and the daemon. Each limit
 * has a safe default, a command-line flag (--limit-...), and errors that
 * name that flag. */
#ifndef RD_SCENE_LIMITS_H
#define RD_SCENE_LIMITS_H

#include <stddef.h>

#include "rayd/error.h"
#include "rayd/scene.h"

typedef struct {
    size_t max_bytes;   /* scene text */
    size_t max_pixels;  /* width × height */
    size_t max_samples; /* per pixel */
    size_t max_depth;   /* recursion */
    size_t max_objects; /* spheres, planes, triangles (after meshes are expanded) */
    size_t max_lights;
    size_t max_materials;
    size_t max_name;           /* bytes in a name or string value */
    size_t max_nesting;        /* JSON arrays and objects inside each other */
    size_t max_mesh_bytes;     /* one OBJ file */
    size_t max_texture_bytes;  /* one PNG file */
    size_t max_texture_pixels; /* one texture, decoded */
} rd_scene_limits;

/* One limit: its flag, its field and what it bounds, for help texts and
 * parsing flags generically. */
typedef struct {
    const char *flag; /* "--limit-pixels" */
    const char *old;  /* the deprecated spelling, "--max-pixels", or NULL */
    size_t offset;    /* into rd_scene_limits */
    const char *what;
} rd_limit_info;

/* The limits, in the order --help lists them; *count gets their number. */
const rd_limit_info *rd_limits_info(size_t *count);

/* The flag that sets the field at offset, for messages. */
const char *rd_limit_flag(size_t offset);

/* Safe defaults: 16 MiB of scene text, 4096×4096 pixels, 65536 samples,
 * depth 64, 1,000,000 objects, 1024 lights, 4096 materials, names of 256
 * bytes, JSON nested 16 deep, 256 MiB meshes, 64 MiB textures of at most
 * 8192×8192 pixels. */
rd_scene_limits rd_scene_limits_default(void);

/* Checks what the render section asks for (after any overrides) against
 * the limits: pixels, samples, depth. */
rd_error_code rd_scene_check_limits(const rd_scene *s, const rd_scene_limits *lim, const char *source, rd_error *err);

#endif
