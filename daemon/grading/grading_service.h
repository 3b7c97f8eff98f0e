/* The grading service (docs/grading.md): what the daemon keeps and does to
 * grade, apart from how a request reaches it. One image against its
 * assignment's reference, a student's calcReflectedLight in the sandbox, a
 * class's batch, all on the render threads of the job queue it is given;
 * the references (api/grading's cache, in memory and --cache-dir) and the
 * images of recent grades, which share --grade-cache-bytes and count
 * against the queue's memory budget; every grade of an assignment as a
 * record in the job store until --grade-ttl, with the batches and their
 * rows; the code grader's slots, its lobe plots and whether its sandbox
 * starts here (probed once, at start).
 *
 * Ownership: rd_grading_start makes the service and whoever started it
 * frees it with rd_grading_free, after the job queue it was given has
 * stopped (the queue's tasks point into it). The service copies what it is
 * given except where a call says it takes a buffer over (then it frees it,
 * whatever happens); what it hands out (texts, PNGs) is malloc'ed for the
 * caller to free.
 *
 * Errors are values: a call returns an rd_error_code and fills err. The
 * records' store answers as store.h says (RD_ERR_UNAVAILABLE unreachable,
 * RD_ERR_NOSPACE, RD_ERR_DAMAGED, RD_ERR_BUSY); RD_ERR_NOT_FOUND comes with
 * a message naming what there is none of and what expires it;
 * RD_ERR_INVALID with a message for a bad argument; RD_ERR_NOMEM.
 *
 * Thread safety: every function may be called from any thread at once; the
 * tasks run on the queue's render threads. */
#ifndef RD_GRADING_SERVICE_H
#define RD_GRADING_SERVICE_H

#include <stddef.h>
#include <stdint.h>

#include "capability.h"
#include "grading.h"
#include "job_queue.h"
#include "log.h"
#include "rayd/error.h"
#include "scene_limits.h"
#include "store.h"

typedef struct rd_grading rd_grading;

typedef struct {
    rd_jq *jobs;            /* runs the grades; its budget counts what the service keeps */
    const char *store_spec; /* the records' store (rd_store_open) */
    rd_store_options store;
    const char *daemon_id; /* names the batches this daemon grades */
    int workers;           /* render threads: a batch is graded in as many slices */
    const char *assignments_dir;
    const char *roster;     /* the class's roster file (roster.h), read for every table; NULL: none */
    const char *scenes_dir; /* where an uploaded scene's files resolve */
    const char *cache_dir;  /* references on disk; NULL: memory only */
    size_t cache_bytes;     /* --grade-cache-bytes */
    rd_scene_limits limits;
    double ttl_ms; /* --grade-ttl */
    rd_log *log;
    /* Grading code (codegrade.h). */
    const char *bwrap;
    const char *course_dir;
    const char *code_eval;
    size_t max_code_bytes;
    double code_compile_ms, code_run_ms;
    unsigned sandbox_uid;         /* and gid, when the daemon runs as root */
    int max_code_jobs;            /* code grades at once */
    int max_code_jobs_per_client; /* of them, one client's */
} rd_grading_options;

/* Opens the records' store, ends the batches this daemon left running when
 * it was killed (their missing rows become error rows saying so), probes
 * the sandbox. NULL with err set when the store cannot be opened (its
 * code, the message naming it) or out of memory. */
rd_grading *rd_grading_start(const rd_grading_options *o, rd_error *err);

/* Closes the store and frees everything (NULL: nothing). */
void rd_grading_free(rd_grading *g);

/* References looked up by single grades: found cached, or rendered. */
typedef struct {
    unsigned long long reference_hits, reference_misses;
} rd_grading_metrics;

void rd_grading_metrics_get(rd_grading *g, rd_grading_metrics *m);

/* A grade task's outcome, read once its job has ended. json is the answer
 * (the caller's to free; NULL when the job failed or was cancelled) and
 * status its HTTP status (200, or 422 for code that did not compile); pass
 * the whole grade's; stage the step that failed (a failed render is the
 * reference's). */
typedef struct {
    char *json;
    unsigned status;
    int pass;
    rd_grade_stage stage;
} rd_grading_answer;

/* Whether a student's own submission to assignment is taken now (its
 * .grade's release, due and late_days; docs/grading.md, "A term"): NULL,
 * or the answer's code ("not_released", "closed") with a sentence for the
 * student in why[size]. An assignment that does not load is not refused
 * here: grading it says what is wrong. */
const char *rd_grading_window_refusal(rd_grading *g, const char *assignment, char *why, size_t size);

/* One image graded against an assignment (assignment set) or a scene given
 * as text (scene, scene_len). Takes image and scene over. */
typedef struct {
    char *image;
    size_t image_len;
    char *scene;
    size_t scene_len;
    const char *assignment; /* "" or NULL: the scene's grade, which is no record */
    const char *student;
} rd_grading_image;

/* The task grading in (for rd_jq_submit or a request's submission). */
rd_error_code rd_grading_image_task(rd_grading *g, rd_grading_image *in, rd_jq_task *task, rd_error *err);

/* The outcome of the task's argument (rd_jq_task_arg). */
rd_grading_answer rd_grading_image_answer(void *task_arg);

/* A student's file graded in the sandbox (codegrade.h). Takes code over. */
typedef struct {
    unsigned char *code;
    size_t code_len;
    const char *filename;
    const char *assignment;
    const char *student;
    const char *client; /* who holds the slot: at most --max-code-jobs-per-client */
} rd_grading_code;

/* The task grading in, with the submission options it needs (the memory
 * its sandbox may hold). RD_ERR_UNAVAILABLE when the sandbox does not start
 * here; RD_ERR_BUSY when --max-code-jobs grades run, or (*per_client set)
 * the client's share of them; err says which. */
rd_error_code rd_grading_code_task(rd_grading *g, rd_grading_code *in, rd_jq_task *task, rd_jq_submit_options *so,
                                   int *per_client, rd_error *err);

rd_grading_answer rd_grading_code_answer(void *task_arg);

/* NULL when code grading is on, else why its sandbox does not start. */
const char *rd_grading_code_unavailable(const rd_grading *g);

/* A code grade's lobe plot (SVG), while the last 128 are kept. */
rd_error_code rd_grading_lobe(rd_grading *g, const char *id, char **svg, rd_error *err);

/* A grade's verdict as JSON: the record's, for whoever has the id. */
rd_error_code rd_grading_verdict(rd_grading *g, const char *id, char **json, rd_error *err);

/* A grade's "diff.png", "reference.png" or "image.png": kept for the last
 * 256 grades; the diff also from its record. */
rd_error_code rd_grading_image_file(rd_grading *g, const char *id, const char *file, unsigned char **png, size_t *len,
                                    rd_error *err);

/* The records, oldest first: an assignment's, a student's, since a time
 * (Unix milliseconds, or a UTC date as 2026-12-01, 2026-12-01T09:30:00Z or
 * 2026-12-01T09:30:00.123Z; NULL: every one; RD_ERR_INVALID when it is
 * neither), at most 10000 (a longer history is read in pages by moving
 * since on); as CSV (a header first) or as JSON {"grades": [...]}. */
typedef struct {
    const char *assignment, *student, *since;
    int csv;
} rd_grading_filter;

rd_error_code rd_grading_list(rd_grading *g, const rd_grading_filter *f, char **text, rd_error *err);

/* The gradebook (docs/grading.md, "The gradebook"): one row per student
 * (the roster's, else every student with a record), one column per
 * assignment that loads, each cell the score of the student's record that
 * counts (empty: none), as CSV in the columns an LMS imports. */
typedef enum { RD_GRADEBOOK_MOODLE, RD_GRADEBOOK_CANVAS } rd_gradebook_format;

/* RD_ERR_LIMIT when the records are more than one answer holds (10000);
 * RD_ERR_SYNTAX when the roster no longer reads (err says where); the
 * store's errors. */
rd_error_code rd_grading_gradebook(rd_grading *g, rd_gradebook_format f, char **csv, rd_error *err);
/* The records of a student (UTF-8; a student who leaves the course)
 * deleted with their images, whichever batch they belong to; *deleted
 * says how many (none is not an error). RD_ERR_INVALID or RD_ERR_LIMIT for
 * a name no record can have. A batch still grading that student's image
 * records it once graded: delete after the batch ends. */
rd_error_code rd_grading_student_delete(rd_grading *g, const char *student, size_t *deleted, rd_error *err);

/* One record deleted with its images. RD_ERR_NOT_FOUND when there is no
 * record of that id. */
rd_error_code rd_grading_grade_delete(rd_grading *g, const char *id, rd_error *err);

/* A batch's images. student is UTF-8; error (a static text, or NULL) says
 * why the image is not graded but becomes an error row (a name that was
 * not UTF-8). */
typedef struct {
    char student[256];
    unsigned char *png;
    size_t len;
    const char *error;
    /* A regrade's (rd_grading_regrade): the record it grades again and
     * when that was submitted; "" and 0 otherwise. */
    char regrade_of[RD_CAP_MAX];
    long long submitted_ms;
} rd_grade_batch_image;

/* Records the batch (this daemon's, with its students), then grades it on
 * the render threads: the first task renders the reference (once, it is
 * cached), then hands the images out in slices. Its id in id. Takes the
 * images over (the array and each png); their bytes count against the
 * queue's budget until each is graded. */
rd_error_code rd_grading_batch_start(rd_grading *g, const char *assignment, rd_grade_batch_image *images, size_t n,
                                     char id[RD_STORE_ID_MAX], rd_error *err);

/* Grades again, as a batch of its own (its id in id), every image record
 * of assignment that has not been regraded yet, against the reference as
 * it is now (docs/grading.md, "Regrading"): each into a new record whose
 * regrade_of names the old one, with the old one's student and submission
 * time; the old record stays. A record whose image was not stored (older
 * than migration 7) gets an error row saying so. RD_ERR_NOT_FOUND when the
 * assignment has no image record; the store's errors; those of
 * rd_grading_batch_start. */
rd_error_code rd_grading_regrade(rd_grading *g, const char *assignment, char id[RD_STORE_ID_MAX], rd_error *err);

typedef enum {
    RD_BATCH_STATUS,    /* the batch's status with its rows (JSON) */
    RD_BATCH_ROWS_JSON, /* the rows, a JSON array */
    RD_BATCH_ROWS_CSV   /* the rows as CSV, a header first */
} rd_grading_batch_form;

rd_error_code rd_grading_batch_text(rd_grading *g, const char *id, rd_grading_batch_form form, char **text,
                                    rd_error *err);

/* The batches, newest first, as JSON {"batches": [{id, assignment, status,
 * total, done, created_at}]}: an assignment's (NULL: every one), created
 * at or before until (as since above; NULL: now), at most limit
 * (decimal text, 1 to 1000; NULL: 100). RD_ERR_INVALID with a message for
 * a bad until or limit. */
typedef struct {
    const char *assignment, *until, *limit;
} rd_grading_batch_filter;

rd_error_code rd_grading_batches_list(rd_grading *g, const rd_grading_batch_filter *f, char **text, rd_error *err);

/* A running batch is cancelled: its images not yet graded are dropped (and
 * leave the queue's budget), it takes no more rows, and *status is its
 * status (RD_BATCH_STATUS; the caller frees it). A batch that has ended
 * (done or cancelled) is deleted with its records and their images, and
 * *status is NULL. RD_ERR_NOT_FOUND when there is no batch of that id. */
rd_error_code rd_grading_batch_delete(rd_grading *g, const char *id, char **status, rd_error *err);

#endif
