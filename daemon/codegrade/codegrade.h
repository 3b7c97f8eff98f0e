/* Grading a student's calcReflectedLight (docs/grading.md, "Grading
 * code"): the one pipeline behind `rayd grade --code` and
 * POST /v1/grade/code.
 *
 *   1. the assignment's scene is opened and its reference found or
 *      rendered (api/grading); the material type the student writes is the
 *      most advanced of diffuse < phong < blinn_phong < cook_torrance in it;
 *   2. the scene is rendered once recording every call the renderer makes
 *      to that material's reflected light (the queries);
 *   3. in the sandbox (daemon/sandbox), rayd-eval compiles the file with
 *      the course's adapter and calls it on the fixed configurations
 *      (code_cases.h) and on every query;
 *   4. the configurations are checked (code_check.h), the scene rendered
 *      again with the student's values in place of rayd's, and that image
 *      graded against the reference like a student's PNG.
 *
 * Thread-safe: nothing is shared between runs but the grader's reference
 * cache, which is. Ownership: the result's buffers are malloc'ed by
 * rd_codegrade_run and freed by rd_codegrade_result_free, which the
 * caller calls once whatever happened. */
#ifndef RD_CODEGRADE_H
#define RD_CODEGRADE_H

#include <cJSON.h>
#include <stdatomic.h>
#include <stddef.h>
#include <sys/types.h>

#include "code_cases.h"
#include "code_check.h"
#include "grading.h"
#include "rayd/error.h"

/* An upload's size bound when the caller has none (--max-code-bytes). */
#define RD_CODE_MAX_BYTES_DEFAULT ((size_t)256 * 1024)

typedef struct {
    rd_grader grader;       /* the assignments, limits and reference cache */
    const char *bwrap;      /* absolute path of bubblewrap */
    const char *eval;       /* rayd-eval */
    const char *course_dir; /* the course's headers and adapter */
    double compile_ms;      /* the compiler's time */
    double run_ms;          /* all the calls' time */
    double stall_ms;        /* one call's */
    size_t max_queries;     /* calls the image may take */
    size_t max_bytes;       /* the upload */
    int threads;            /* to render the reference and the images */
    uid_t uid;              /* the sandbox's user when rayd runs as root */
    gid_t gid;
    const atomic_int *cancel; /* optional */
} rd_codegrade_config;

/* The defaults (docs/grading.md); grader, bwrap, eval and course_dir are
 * the caller's. */
rd_codegrade_config rd_codegrade_config_default(void);

typedef struct {
    const char *assignment;
    const char *filename; /* as uploaded: "PhongMaterial.h", or a .cpp */
    const char *source;
    size_t len;
} rd_codegrade_input;

/* One of the compiler's messages, its paths as the student knows them. */
typedef struct {
    char file[96];
    int line, column;
    char severity[16]; /* "error", "warning", "note", "fatal error" */
    char message[480];
} rd_code_diag;

#define RD_CODE_MAX_DIAGS 64

/* How the compile ended (code_frames.h's RD_COMPILE_*), -1 before it ran. */
typedef struct {
    int result;
    int status;
    double ms;
    char *messages; /* the compiler's output, paths shortened */
    rd_code_diag *diags;
    int ndiags;
    /* Why it failed in the student's terms, before the compiler's words:
     * "wrong_class" when the file defines another material's class than
     * the assignment's (NULL for none), and its words. */
    const char *cause;
    char words[240];
} rd_code_compile;

typedef struct {
    char assignment[64];
    const char *material; /* "phong"... */
    const char *class_name;
    rd_code_compile compile;
    rd_code_case *cases;
    rd_code_value *values; /* ncases of them, after the compile */
    size_t ncases;
    rd_code_report report;
    size_t image_calls; /* the queries of the image */
    int image_graded;
    rd_grade_output grade; /* the image against the reference */
    char *output;          /* what the code printed (the first bytes) */
    unsigned long long output_total;
    int output_limited;
    char *note; /* the evaluator could not do a step, or NULL */
    size_t restarts;
    double ms, sandbox_ms, calls_ms;
    int pass;
} rd_codegrade_result;

/* Runs the pipeline. RD_ERR_NOT_FOUND: no such assignment;
 * RD_ERR_INVALID: a bad file name, a file too long or with NUL bytes, an
 * assignment with no material a student writes (err says which);
 * RD_ERR_UNAVAILABLE: the sandbox cannot start; RD_ERR_LIMIT: the image needs more
 * than max_queries calls; RD_ERR_NOMEM. Else RD_OK, whatever the code did:
 * its result is in *out (pass, or why not). */
rd_error_code rd_codegrade_run(const rd_codegrade_config *cfg, const rd_codegrade_input *in, rd_codegrade_result *out,
                               rd_error *err);

void rd_codegrade_result_free(rd_codegrade_result *r);

/* The most memory one grade of a source_len-byte file may hold, which the
 * daemon reserves from its budget before the grade starts: the sandbox's
 * (rd_sandbox_memory_bytes: its address space limit, its tmpfs, the files
 * copied in, with max_queries queries) and the queries and values the
 * daemon keeps beside it. */
size_t rd_codegrade_memory_bytes(const rd_codegrade_config *cfg, size_t source_len);

/* The result as a cJSON tree without the image's verdict (the caller adds
 * it as "image"); NULL when out of memory. */
cJSON *rd_codegrade_json(const rd_codegrade_result *r);

/* The answer's summary for a person (rayd grade --code without --json):
 * the verdict, then each cause with its words and one example, read off
 * the JSON of rd_codegrade_json (code_summary.c). The
 * caller frees the text; NULL when out of memory. */
char *rd_codegrade_summary(const cJSON *answer);

/* The course's class for a material type ("PhongMaterial"), NULL if none. */
const char *rd_codegrade_class(rd_material_type t);

/* A skeleton the student starts from: the course's file for that
 * material word ("phong"), malloc'ed in *text; RD_ERR_NOT_FOUND. */
rd_error_code rd_codegrade_skeleton(const char *course_dir, const char *material, char **text, size_t *len,
                                    rd_error *err);

/* Shortens the compiler's paths to what the student knows and parses its
 * "file:line:column: severity: message" lines (code_diag.c). */
void rd_code_compile_messages(rd_code_compile *c, const char *raw, size_t len);

#endif
