/* Where a scene's mesh and texture files come from: the scene's own folder
 * (never outside it), or files uploaded with the scene. */
#ifndef RD_ASSET_SOURCE_H
#define RD_ASSET_SOURCE_H

#include <stddef.h>

#include "rayd/error.h"

typedef struct rd_asset_source {
    /* Reads asset `name` (as written in the scene) into a malloc'ed buffer
     * the caller frees; refuses more than max_bytes (RD_ERR_LIMIT naming
     * flag) and any name that would leave the source (RD_ERR_INVALID). */
    rd_error_code (*read)(const struct rd_asset_source *src, const char *name, size_t max_bytes, const char *flag,
                          unsigned char **data, size_t *len, rd_error *err);
    const char *dir; /* folder source: the scene's folder */
    void *user;      /* other sources */
    int threads;     /* that may parse one mesh (rd_obj_parse_threads); < 1: 1 */
} rd_asset_source;

/* A source reading files below dir; dir must outlive the source. */
rd_asset_source rd_asset_folder(const char *dir);

/* Resolves dir/name, following links, into real_file (PATH_MAX bytes);
 * RD_ERR_INVALID when the result lies outside dir's real path, RD_ERR_IO
 * when it does not exist. Every route that serves a file by name uses it. */
rd_error_code rd_path_inside(const char *dir, const char *name, char *real_file, rd_error *err);

/* 1 when name is a relative path without "..", "." or empty components,
 * without backslashes or NUL: one that cannot climb out of its folder. */
int rd_asset_name_ok(const char *name);

#endif
