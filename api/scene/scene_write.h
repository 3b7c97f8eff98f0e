/* Writing an rd_scene back out as cfg or JSON text, through the key table:
 * every key that differs from its default, plus every required key, in
 * table order. Reading the text back gives the same rd_scene, so
 * converting twice gives the same text. */
#ifndef RD_SCENE_WRITE_H
#define RD_SCENE_WRITE_H

#include <stddef.h>

#include "rayd/error.h"
#include "rayd/scene.h"

/* On success *out is a malloc'ed NUL-terminated text (the caller frees it).
 * Fails when a name cannot be spelled in cfg (it holds a '"' or a line end). */
rd_error_code rd_scene_write_cfg(const rd_scene *s, char **out, rd_error *err);
rd_error_code rd_scene_write_json(const rd_scene *s, char **out, rd_error *err);

/* The scene as rayd renders it, for programs that read scenes without being
 * rayd (bench/cfg2pov.py): they then need neither the format's defaults nor
 * an OBJ reader of their own. */
typedef struct {
    /* Every key that applies, defaults included. Still a scene: reading it
     * back gives the same rd_scene. */
    int every_key;
    /* Each mesh object whose mesh is loaded (s->meshes, by the asset
     * loader) also gets "loaded": {"positions": [[x, y, z], ...],
     * "normals": [[x, y, z], ...], "faces": [[v0, v1, v2, n0, n1, n2], ...]},
     * in world coordinates (moved by translate, scale and rotate), polygons
     * fanned, indices from 0, a normal index -1 where the OBJ gave none;
     * texture coordinates are left out. The scene readers refuse this
     * member: such text is for other programs, not for reading back. */
    int loaded_meshes;
} rd_scene_write_options;

/* rd_scene_write_json with options (NULL: none, as rd_scene_write_json). */
rd_error_code rd_scene_write_json_with(const rd_scene *s, const rd_scene_write_options *opt, char **out, rd_error *err);

#endif
