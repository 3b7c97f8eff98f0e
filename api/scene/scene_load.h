/* Reading a scene from text or a file, in either format. */
#ifndef RD_SCENE_LOAD_H
#define RD_SCENE_LOAD_H

#include <stddef.h>

#include "rayd/error.h"
#include "rayd/scene.h"
#include "scene_limits.h"

/* RD_FMT_AUTO sniffs: the first non-space byte (after a UTF-8 BOM) '{'
 * means JSON, anything else cfg. */
typedef enum { RD_FMT_AUTO, RD_FMT_CFG, RD_FMT_JSON } rd_scene_format;

/* The format RD_FMT_AUTO reads text as (never RD_FMT_AUTO). */
rd_scene_format rd_scene_sniff(const char *text, size_t len);

/* Parses text into s (rd_scene_init'ed by the caller, who frees it either
 * way). source names the input in messages. */
rd_error_code rd_scene_parse(const char *text, size_t len, rd_scene_format fmt, const char *source,
                             const rd_scene_limits *lim, rd_scene *s, rd_error *err);

/* Reads and parses a file: .json is JSON, .cfg is cfg, anything else is
 * sniffed. A file over lim->max_bytes is refused before it is read. */
rd_error_code rd_scene_load_file(const char *path, const rd_scene_limits *lim, rd_scene *s, rd_error *err);

/* The same, naming the file `name` in messages ("phong.cfg:3:1: ..."), so
 * that an answer over HTTP shows no server path. */
rd_error_code rd_scene_load_file_named(const char *path, const char *name, const rd_scene_limits *lim, rd_scene *s,
                                       rd_error *err);

#endif
