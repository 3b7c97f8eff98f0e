/* Grading one student image: find or render the reference, decode the
 * image, compare, build the verdict (grading.md). Used by `rayd grade` and
 * POST /v1/grade. */
#ifndef RD_GRADING_H
#define RD_GRADING_H

#include <stddef.h>
#include <stdint.h>

#include "rayd/error.h"
#include "grade.h"
#include "scene_limits.h"

typedef struct {
    const char *assignments_dir;
    const char *cache_dir;      /* NULL: no reference cache */
    const char *assets_dir;     /* where a posted scene's files resolve */
    int threads;
    rd_scene_limits limits;
} rd_grader;

typedef enum {
    RD_GRADE_OK,
    RD_GRADE_UNKNOWN_ASSIGNMENT,
    RD_GRADE_BAD_SCENE,         /* err holds the scene's own error */
    RD_GRADE_NOT_PNG,
    RD_GRADE_BAD_PNG,
    RD_GRADE_SIZE_MISMATCH,
    RD_GRADE_FAILED             /* out of memory, render failure */
} rd_grade_status;

typedef struct {
    rd_grade_status status;
    char assignment[64];        /* "" for a posted scene */
    char title[160];
    rd_grade_thresholds thresholds;
    rd_grade_result result;
    uint8_t *reference, *image; /* 8-bit RGB, malloc'ed: free with rd_grade_output_free */
    int width, height;
    int reference_cached;
    double reference_ms;
} rd_grade_output;

/* Grades png against the assignment `name`, or, when name is NULL, against
 * the scene in scene_text (cfg or JSON, named source in messages). */
rd_error_code rd_grade_run(const rd_grader *g, const char *name, const char *scene_text, size_t scene_len,
                           const char *source, const unsigned char *png, size_t png_len, rd_grade_output *out,
                           rd_error *err);

void rd_grade_output_free(rd_grade_output *o);

/* The verdict as JSON text (malloc'ed); diff_url may be NULL. */
char *rd_grade_json(const rd_grade_output *o, const char *diff_url);

#endif
