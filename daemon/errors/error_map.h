/* How an error leaves the rayd binary, decided once: for every code of
 * RD_ERRORS (rayd/error.h) the HTTP status with its JSON error code
 * (docs/http-api.md) and the exit status of the commands (README). Grading
 * refines a few by the stage that failed, so that `rayd grade` and
 * POST /v1/grade answer the same input the same way. */
#ifndef RD_ERROR_MAP_H
#define RD_ERROR_MAP_H

#include "grading.h"
#include "rayd/error.h"

/* Exit statuses of every command. */
enum {
    RD_EXIT_OK = 0,
    RD_EXIT_USAGE = 1,     /* bad arguments, or a name that does not exist */
    RD_EXIT_SCENE = 2,     /* the scene or image could not be used: nothing written */
    RD_EXIT_IO = 3,        /* a file could not be read or written */
    RD_EXIT_GRADE_FAIL = 4 /* rayd grade: graded, and the image fails */
};

typedef struct {
    unsigned http;        /* status */
    const char *code;     /* the JSON error.code */
    int exit;             /* RD_EXIT_* */
    unsigned retry_after; /* seconds for a Retry-After header; 0: none */
    const char *lead;     /* said before the error's own message, or NULL */
} rd_error_answer;

/* The answer for c; codes outside RD_ERRORS answer as out of memory. */
rd_error_answer rd_error_answer_for(rd_error_code c);

/* The answer for a grade that failed at stage with code c. */
rd_error_answer rd_grade_error_answer(rd_grade_stage stage, rd_error_code c);

/* The answer for a code grade that could not run (codegrade.h): the
 * assignment's stages as a grade's; then a file that is not C++ text is
 * 422 bad_code, one too long 413 too_large, a sandbox that cannot start
 * (RD_ERR_UNAVAILABLE, which elsewhere is the job store's) 503
 * sandbox_unavailable. */
rd_error_answer rd_code_error_answer(rd_grade_stage stage, rd_error_code c);

#endif
