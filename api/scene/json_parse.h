/* The JSON scene format of scene-format.md, read with cJSON. */
#ifndef RD_JSON_PARSE_H
#define RD_JSON_PARSE_H

#include <stddef.h>

#include "rayd/error.h"
#include "rayd/scene.h"
#include "scene_limits.h"

/* Parses len bytes of JSON into s (rd_scene_init'ed; free it either way).
 * Syntax errors carry line and column; errors in content name the JSON path
 * ("objects[3].radius"). Fills s through the same key table as cfg, so a
 * scene written in both formats gives the same rd_scene. */
rd_error_code rd_json_parse(const char *text, size_t len, const char *source, const rd_scene_limits *lim, rd_scene *s,
                            rd_error *err);

#endif
