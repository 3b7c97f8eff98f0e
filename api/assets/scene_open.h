/* Opening a scene for rendering, the one way every caller does it (the
 * render and converge commands, POST /v1/render and /v1/jobs, grading):
 *   1. read the file (refused over lim->max_bytes before reading) or take
 *      the text;
 *   2. parse it (format from the file's extension, else sniffed);
 *   3. apply the overrides of its render section;
 *   4. check the limits of what the render asks for (pixels, samples, depth);
 *   5. load the meshes and textures the render uses, resolving names inside
 *      one folder (never outside it).
 * Limits are always checked: a caller that wants none passes NULL for the
 * defaults of rd_scene_limits_default, never "unlimited". */
#ifndef RD_SCENE_OPEN_H
#define RD_SCENE_OPEN_H

#include <stddef.h>

#include "rayd/error.h"
#include "rayd/scene.h"
#include "scene_limits.h"
#include "scene_load.h"
#include "scene_overrides.h"
#include "warnings.h"

typedef struct {
    const char *path; /* a file to read, or NULL for text/len: */
    const char *text;
    size_t len;
    const char *source;     /* the name in messages; NULL: the path (or "<text>") */
    rd_scene_format format; /* RD_FMT_AUTO: by path's extension, else sniffed */
    const char *assets_dir; /* NULL: path's folder ("." for text) */
    int threads;            /* that may parse a big mesh; < 1: 1 (the same scene either way) */
} rd_scene_source;

/* Fills s (rd_scene_init'ed by the caller, who frees it either way). ov,
 * lim and w may be NULL (no overrides, the default limits, no warnings).
 * Errors read "SOURCE:LINE:COL: ..." where the scene text has a place. */
rd_error_code rd_scene_open(const rd_scene_source *src, const rd_scene_overrides *ov, const rd_scene_limits *lim,
                            rd_scene *s, rd_warnings *w, rd_error *err);

#endif
