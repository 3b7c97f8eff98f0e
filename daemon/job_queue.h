/* The daemon's render jobs: one bounded queue feeding one pool of render
 * threads. Jobs are cut into tiles; a free worker takes the next tile of the
 * oldest job that has one, so a job alone uses every core and later jobs
 * start as soon as earlier ones run out of tiles. Finished jobs keep their
 * PNG for GET /v1/jobs/{id}/image until their TTL or the result memory
 * limit evicts them.
 *
 * Thread safety: every function may be called from any thread.
 * Ownership: the queue owns its jobs; callers hold references
 * (rd_jq_job_ref / rd_jq_job_unref) to keep one alive while they use it. */
#ifndef RD_JOB_QUEUE_H
#define RD_JOB_QUEUE_H

#include <stddef.h>
#include <stdint.h>

#include "error.h"
#include "png_write.h"
#include "progress.h"
#include "render.h"
#include "scene.h"

typedef enum { RD_JOB_QUEUED, RD_JOB_RUNNING, RD_JOB_DONE, RD_JOB_FAILED, RD_JOB_CANCELLED } rd_job_status;

const char *rd_job_status_name(rd_job_status s);

typedef struct {
    int workers;                /* render threads */
    size_t queue_length;        /* jobs queued or running at most */
    double job_timeout_ms;      /* per job, from when it starts */
    size_t result_memory;       /* bytes of finished PNGs kept */
    double result_ttl_ms;       /* how long a finished job stays */
    rd_png_options png;
} rd_jq_options;

typedef struct rd_jq rd_jq;
typedef struct rd_jq_job rd_jq_job;

/* Called by a render thread when a job ends (done, failed or cancelled). */
typedef void (*rd_jq_done_fn)(rd_jq_job *job, void *user);

rd_jq *rd_jq_start(const rd_jq_options *opt, rd_error *err);

/* Stops taking tiles, cancels every job not finished, joins the workers
 * and frees everything. */
void rd_jq_stop(rd_jq *q);

/* Enqueues a render of *scene, which the queue takes over (the caller's
 * struct is left empty). watch_fd >= 0: a client socket; the job is
 * cancelled, between tiles, once the peer has hung up. done may be NULL.
 * On RD_ERR_LIMIT the queue is full and the scene is freed. The returned
 * job carries one reference for the caller. */
rd_error_code rd_jq_submit(rd_jq *q, rd_scene *scene, const rd_progress_settings *progress, int watch_fd,
                           rd_jq_done_fn done, void *user, rd_jq_job **out, rd_error *err);

/* Finds a job by id and returns it with a new reference, or NULL. */
rd_jq_job *rd_jq_find(rd_jq *q, const char *id);

void rd_jq_job_ref(rd_jq_job *j);
void rd_jq_job_unref(rd_jq_job *j);

/* Forgets a job's done callback and watched socket: its client is gone. */
void rd_jq_detach(rd_jq *q, rd_jq_job *j);

/* Asks a job to stop; it does within one tile. Returns 0 if it had already ended. */
int rd_jq_cancel(rd_jq *q, rd_jq_job *j);

/* A consistent copy of what a client may ask about a job. */
typedef struct {
    char id[24];
    rd_job_status status;
    double progress;            /* 0..1, tiles done over tiles */
    double elapsed_ms;          /* since it started (0 while queued) */
    double queued_ms;           /* waiting before it started */
    int samples;
    double error_estimate;
    rd_render_stats stats;
    rd_error error;             /* when failed */
    int width, height;
    rd_stop_reason stopped_by;
    int hung_up;                /* cancelled because its client went away */
    int passes;
    rd_curve_point curve[RD_CURVE_MAX];
    int curve_len;
} rd_jq_info;

void rd_jq_info_get(rd_jq *q, rd_jq_job *j, rd_jq_info *out);

/* The finished PNG (malloc'ed copy, caller frees), or with partial != 0
 * the image so far while it runs. RD_ERR_INVALID when there is none. */
rd_error_code rd_jq_png(rd_jq *q, rd_jq_job *j, int partial, unsigned char **png, size_t *len,
                        rd_error *err);

/* Drops a finished job's PNG (a synchronous answer has been sent). */
void rd_jq_release_png(rd_jq *q, rd_jq_job *j);

typedef struct {
    size_t queued, running;
    uint64_t done, failed, cancelled;
    uint64_t rays;
    double render_seconds_sum;
    uint64_t render_seconds_bucket[12]; /* cumulative, upper bounds in rd_jq_buckets */
    uint64_t render_count;
    size_t result_bytes;
    size_t jobs_kept;
} rd_jq_metrics;

extern const double rd_jq_buckets[12];

void rd_jq_metrics_get(rd_jq *q, rd_jq_metrics *m);

/* Waits until no job is queued or running, or timeout_ms passes; returns 1
 * when idle. */
int rd_jq_drain(rd_jq *q, double timeout_ms);

/* Cancels every job that has not finished (queued ones get status
 * cancelled). */
void rd_jq_cancel_all(rd_jq *q);

#endif
