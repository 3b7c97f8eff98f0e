/* The cfg scene format of scene-format.md. */
#ifndef RD_CFG_PARSE_H
#define RD_CFG_PARSE_H

#include <stddef.h>

#include "rayd/error.h"
#include "rayd/scene.h"
#include "scene_limits.h"

/* Parses len bytes of cfg text into s (which must be rd_scene_init'ed and
 * is left partly filled on error: free it either way). source names the
 * input in messages, e.g. "phong.cfg" or "<upload>". Every error carries
 * the 1-based line and character column. lim may be NULL for defaults. */
rd_error_code rd_cfg_parse(const char *text, size_t len, const char *source, const rd_scene_limits *lim, rd_scene *s,
                           rd_error *err);

#endif
