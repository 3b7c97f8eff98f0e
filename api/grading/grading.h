/* Grading one student image (grading.md): the one pipeline behind
 * `rayd grade` and POST /v1/grade.
 *
 *   rd_grade_prepare        the assignment (or the given scene) opened with
 *                           limits and assets; the student's PNG sniffed, its
 *                           size checked from its header, decoded; the
 *                           reference's key, and the reference itself when
 *                           the cache has it;
 *   (the caller renders)    when o->reference is NULL: rd_grade_run with
 *                           rd_render, the daemon on its render queue; the
 *                           result goes to rd_grade_set_reference, which
 *                           also caches it;
 *   rd_grade_finish         compares and fills the result.
 *
 * An error leaves o->stage naming the step that failed; daemon/errors/
 * turns (stage, code) into the answer, so both front ends answer an input
 * alike. Ownership: o's buffers are malloc'ed by these functions and freed
 * by rd_grade_output_free, which the caller calls once whatever happened. */
#ifndef RD_GRADING_H
#define RD_GRADING_H

#include <cJSON.h>
#include <stddef.h>
#include <stdint.h>

#include "assignment.h"
#include "grade.h"
#include "rayd/error.h"
#include "rayd/scene.h"
#include "reference.h"
#include "scene_limits.h"
#include "scene_overrides.h"

/* The largest student PNG file `rayd grade` reads (the daemon's bound is
 * --max-body-bytes). */
#define RD_GRADE_MAX_PNG_BYTES ((size_t)1 << 30)

typedef enum {
    RD_GRADE_STAGE_NONE,       /* no error */
    RD_GRADE_STAGE_ASSIGNMENT, /* the assignment: its name, .grade file or scene */
    RD_GRADE_STAGE_SCENE,      /* the scene given instead */
    RD_GRADE_STAGE_IMAGE,      /* the student's PNG */
    RD_GRADE_STAGE_REFERENCE   /* obtaining the reference */
} rd_grade_stage;

typedef struct {
    const char *assignments_dir;
    const char *assets_dir; /* where a given scene's files resolve (NULL: a scene file's folder) */
    rd_scene_limits limits;
    rd_ref_cache *cache; /* NULL: every grade renders its reference */
} rd_grader;

/* What is graded: the assignment named, or else a scene given as a file or
 * as text; and the PNG. Only read. */
typedef struct {
    const char *assignment;
    const char *scene_path;
    const char *scene_text;
    size_t scene_len;
    const char *source; /* the text's name in messages ("<upload>") */
    /* Render overrides of a given scene (NULL: none); an assignment's
     * scene is graded as it is, so they are not applied to it. */
    const rd_scene_overrides *ov;
    const unsigned char *png;
    size_t png_len;
} rd_grade_input;

typedef struct {
    rd_grade_stage stage;
    char assignment[64]; /* "" for a given scene */
    char title[160];
    rd_grade_thresholds thresholds;
    rd_shininess_domain shininess; /* the assignment's (REAL for a given scene) */
    char key[17];                  /* the reference's */
    uint8_t *reference, *image;    /* 8-bit RGB, width x height */
    int width, height;
    int reference_cached;   /* the cache had it */
    rd_grade_result result; /* after rd_grade_finish */
} rd_grade_output;

/* Fills *s (rd_scene_init'ed by the caller, who frees it) with the scene to
 * render and o with everything but the comparison. */
rd_error_code rd_grade_prepare(const rd_grader *g, const rd_grade_input *in, rd_scene *s, rd_grade_output *o,
                               rd_error *err);

/* For many images of one assignment (a batch): rd_grade_prepare without
 * an image, so that the reference is found or rendered once. o's size is
 * the scene's, its image NULL; in->png is not read. */
rd_error_code rd_grade_prepare_reference(const rd_grader *g, const rd_grade_input *in, rd_scene *s, rd_grade_output *o,
                                         rd_error *err);

/* Takes a copy of the rendered reference (width x height of o) and puts it
 * in g's cache. RD_ERR_INVALID when its size is not the image's. */
rd_error_code rd_grade_set_reference(const rd_grader *g, rd_grade_output *o, const uint8_t *rgb, int w, int h,
                                     rd_error *err);

/* Renders s with `threads` on the calling thread and sets it as o's
 * reference (rd_grade_set_reference). */
rd_error_code rd_grade_render_reference(const rd_grader *g, const rd_scene *s, int threads, rd_grade_output *o,
                                        rd_error *err);

/* Compares the image with the reference (both present). RD_ERR_NOMEM
 * when out of memory, with o->result incomplete. */
rd_error_code rd_grade_finish(rd_grade_output *o);

/* The whole pipeline on the calling thread, rendering with `threads`. */
rd_error_code rd_grade_run(const rd_grader *g, const rd_grade_input *in, int threads, rd_grade_output *o,
                           rd_error *err);

void rd_grade_output_free(rd_grade_output *o);

/* The verdict (grading.md) as a cJSON tree the caller may extend and then
 * deletes; NULL when out of memory. */
cJSON *rd_grade_json(const rd_grade_output *o);

#endif
