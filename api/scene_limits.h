/* Size limits on scene input, shared by the CLI and the daemon. */
#ifndef RD_SCENE_LIMITS_H
#define RD_SCENE_LIMITS_H

#include <stddef.h>

typedef struct {
    size_t max_bytes;       /* scene text */
    size_t max_objects;     /* spheres, planes, triangles */
    size_t max_lights;
    size_t max_materials;
    size_t max_name;        /* bytes in a name or string value */
} rd_scene_limits;

/* Safe defaults: 16 MiB of text, 1,000,000 objects, 1024 lights,
 * 4096 materials, names of 256 bytes. */
rd_scene_limits rd_scene_limits_default(void);

#endif
