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

#endif
