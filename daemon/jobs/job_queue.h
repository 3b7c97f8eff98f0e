/* The daemon's render jobs: one bounded queue feeding one pool of render
 * threads. Everything slow about a job runs on those threads, never on the
 * caller's: preparing it (parsing, loading assets, decoding uploads),
 * rendering it in tiles, and finishing it (encoding, grading). One thread
 * only prepares new jobs (so a scene is read, and a bad one refused, even
 * while every render thread is inside a long tile); a free render thread
 * prepares the oldest new job too, then admits the oldest prepared job
 * whose memory fits the budget, then takes the next tile of the job that has
 * been given the fewest (fair share), so a small job waits at most for the
 * tiles in progress. Finished jobs keep their PNG for GET /v1/jobs/{id}/image until
 * their TTL or the result memory limit evicts them.
 *
 * Stopping is bounded: cancel, DELETE, a client's hang-up and the job
 * timeout set a flag the tracer looks at about once a millisecond (trace.h);
 * a watchdog thread notices timeouts and hang-ups while every render thread
 * is busy.
 *
 * Thread safety: every function may be called from any thread.
 * Ownership: the queue owns its jobs and their tasks' arguments; callers
 * get a reference with every job they are handed (rd_jq_submit,
 * rd_jq_find) and give it back with rd_jq_job_unref. */
#ifndef RD_JOB_QUEUE_H
#define RD_JOB_QUEUE_H

#include <stddef.h>
#include <stdint.h>

#include "capability.h"
#include "histogram.h"
#include "png_write.h"
#include "rayd/error.h"
#include "rayd/progress.h"
#include "rayd/render.h"
#include "rayd/scene.h"

typedef enum { RD_JQ_QUEUED, RD_JQ_RUNNING, RD_JQ_DONE, RD_JQ_FAILED, RD_JQ_CANCELLED } rd_jq_status;

const char *rd_jq_status_name(rd_jq_status s);

typedef struct {
    int workers;           /* render threads */
    size_t queue_length;   /* jobs queued or running at most */
    double job_timeout_ms; /* per job, from when it starts rendering */
    size_t result_memory;  /* bytes of finished PNGs kept */
    double result_ttl_ms;  /* how long a finished job stays */
    size_t kept_max;       /* finished jobs whose status stays readable */
    size_t memory_budget;  /* bytes of running jobs, results and caches; 0 = no limit */
    rd_png_options png;
} rd_jq_options;

typedef struct rd_jq rd_jq;
typedef struct rd_jq_job rd_jq_job;

/* What a job does, run on a render thread. Every member but prepare may be
 * NULL. */
typedef struct {
    /* Fills *scene (empty on entry). *render starts at 1; setting it to 0
     * skips rendering and goes straight to finish (with no image). An error
     * fails the job with it. */
    rd_error_code (*prepare)(void *arg, rd_scene *scene, int *render, rd_error *err);
    /* The rendered image as 8-bit RGB (NULL when prepare skipped the
     * render); an error fails the job. NULL: the image is encoded as the
     * job's PNG. */
    rd_error_code (*finish)(void *arg, const uint8_t *rgb, int width, int height, rd_error *err);
    void (*free)(void *arg); /* releases arg when the job is freed, with the queue locked: it must not call the queue */
    void *arg;
    size_t input_bytes; /* what arg holds until prepared: counted against the budget */
    /* Optional: at submission the queue stores here the address of the
     * job's stop flag (non-zero once it is cancelled, by a DELETE, a
     * hang-up, its time limit or a stop), for work inside prepare that
     * must end with the job (a sandbox). Valid while arg is. */
    const atomic_int **stop;
} rd_jq_task;

/* Called by a render thread when a job ends (done, failed or cancelled),
 * or, with notify_prepared, as soon as it is prepared or has failed to
 * be; at most once either way. */
typedef void (*rd_jq_done_fn)(rd_jq_job *job, void *user);

typedef struct {
    rd_progress_settings progress; /* max_samples is set from the scene */
    int watch_fd;                  /* a client socket: the job is cancelled once the peer hangs up; -1 */
    int watch_http11;              /* that client speaks HTTP/1.1 and may be sent an interim 102 */
    rd_jq_done_fn done;            /* may be NULL */
    void *user;
    int notify_prepared; /* call done once prepared (an asynchronous submission) */
    int internal;        /* work for a request, not a job of its own: no id to find, not in the metrics */
    rd_jq_job *hold;     /* a reference the job takes over and drops when it is freed; may be NULL */
    int hdr;             /* also keep the linear image as an EXR beside the PNG (a task without finish) */
    /* The task's prepare does all its work and always sets *render = 0 (a
     * code grade's sandbox, a batch's slice): it needs no render memory,
     * so it holds no place in the order of starts while it is prepared. */
    int renders_nothing;
    /* What the task's prepare itself may hold (a code grade's sandbox: its
     * memory limit and file systems), 0 for none. Such a job is prepared
     * only once these bytes fit the budget beside what is used (or when no
     * other such preparation runs), and they stay reserved while prepare
     * runs. A job whose input and preparation bytes exceed the whole budget
     * is refused at submission (RD_ERR_LIMIT). */
    size_t prepare_bytes;
} rd_jq_submit_options;

rd_jq *rd_jq_start(const rd_jq_options *opt, rd_error *err);

/* Stops taking tiles, cancels every job not finished (their done
 * callbacks run), stops the source (rd_jq_set_source) and joins the
 * threads. The queue's other calls still work, with nothing running, until
 * rd_jq_free. */
void rd_jq_stop(rd_jq *q);

/* Stops it if need be and frees everything (NULL: nothing). */
void rd_jq_free(rd_jq *q);

/* Enqueues a job; the queue takes over task->arg whatever the outcome
 * (freed with task->free). RD_ERR_BUSY when the queue is full. The
 * returned job carries one reference for the caller. */
rd_error_code rd_jq_submit(rd_jq *q, const rd_jq_task *task, const rd_jq_submit_options *so, rd_jq_job **out,
                           rd_error *err);

/* The same for a scene already in memory, which the queue takes over (the
 * caller's struct is left empty); the job encodes a PNG. */
rd_error_code rd_jq_submit_scene(rd_jq *q, rd_scene *scene, const rd_jq_submit_options *so, rd_jq_job **out,
                                 rd_error *err);

/* A job's task argument (for its submitter to read the results of finish
 * once the job has ended). */
void *rd_jq_task_arg(rd_jq_job *j);

/* Finds a job by id and returns it with a new reference, or NULL. */
rd_jq_job *rd_jq_find(rd_jq *q, const char *id);

void rd_jq_job_unref(rd_jq_job *j);

/* Forgets a job's done callback and watched socket: its client is gone. */
void rd_jq_detach(rd_jq *q, rd_jq_job *j);

/* Asks a job to stop; it does within milliseconds. Returns 0 if it had
 * already ended. */
int rd_jq_cancel(rd_jq *q, rd_jq_job *j);

/* A consistent copy of what a client may ask about a job. */
typedef struct {
    char id[RD_CAP_MAX];
    rd_jq_status status;
    double progress;   /* 0..1, tiles done over tiles */
    double elapsed_ms; /* since it started (0 while queued) */
    double queued_ms;  /* waiting before it started */
    int samples;
    double error_estimate;
    rd_render_stats stats;
    rd_error error;    /* when failed */
    int width, height; /* 0 until prepared */
    rd_stop_reason stopped_by;
    int hung_up;   /* cancelled because its client went away */
    int requested; /* cancelled by rd_jq_cancel (a DELETE), not by a stop */
    int prepared;  /* prepared (or failed or ended) */
    int passes;
    rd_curve_point curve[RD_CURVE_MAX];
    int curve_len;
    int hdr; /* submitted with hdr: its result has an EXR */
} rd_jq_info;

void rd_jq_info_get(rd_jq *q, rd_jq_job *j, rd_jq_info *out);

/* The finished PNG (malloc'ed copy, caller frees), or with partial != 0
 * the image so far while it runs. RD_ERR_INVALID when there is none. */
rd_error_code rd_jq_png(rd_jq *q, rd_jq_job *j, int partial, unsigned char **png, size_t *len, rd_error *err);

/* The finished EXR of a job submitted with hdr (malloc'ed copy, caller
 * frees); RD_ERR_INVALID when there is none. Kept and evicted with the PNG,
 * both counted in the result memory. */
rd_error_code rd_jq_exr(rd_jq *q, rd_jq_job *j, unsigned char **exr, size_t *len, rd_error *err);

/* Drops a finished job's PNG and EXR (a synchronous answer has been sent). */
void rd_jq_release_png(rd_jq *q, rd_jq_job *j);

/* Work for the same render threads besides the queue's own jobs: the
 * stored jobs' tiles (farm.h). It takes its turn under the fair share as
 * one more job would (the next unit goes to whichever has been given the
 * fewest), and its new work is admitted by the queue's one rule. */
typedef struct {
    /* Does one unit of work (a tile) on render thread `worker`, 0 ..
     * workers - 1, without the queue's lock. room: the bytes new work may
     * take under --memory-budget (SIZE_MAX: anything, nothing else runs);
     * work already held needs no room. Returns 0 when it did something,
     * else the milliseconds to wait before asking again (rd_jq_wake asks
     * sooner). */
    int (*run)(void *arg, int worker, size_t room);
    /* Called once by rd_jq_stop before it joins the threads: from then on
     * run returns within milliseconds. */
    void (*stop)(void *arg);
    void *arg;
} rd_jq_source;

/* RD_ERR_LIMIT, naming what ("the render") and the flag, when need bytes
 * could never fit the memory budget; RD_OK otherwise. The one answer for
 * the queue's jobs and the source's. */
rd_error_code rd_jq_check_budget(const rd_jq *q, const char *what, size_t need, rd_error *err);

/* Gives the render threads a source (once, before any work for it
 * arrives); it must outlive the queue's threads (rd_jq_stop joins them). */
void rd_jq_set_source(rd_jq *q, const rd_jq_source *src);

/* The source has work: a thread that found none asks again now. */
void rd_jq_wake(rd_jq *q);

/* A stored job rendered by these threads ended: its wait before it
 * started and its render go into the same histograms as the queue's own
 * (in seconds; a negative value is not observed). */
void rd_jq_observe_source_job(rd_jq *q, double wait_s, double render_s);

/* Memory held outside the queue (grading caches, stored jobs rendering
 * here) that counts against the budget: delta bytes more (or fewer). */
void rd_jq_external_bytes(rd_jq *q, long long delta);

/* Jobs rendered outside the queue by the same render threads' daemon
 * (stored jobs, farm.h) that count against queue_length: delta more (or
 * fewer). */
void rd_jq_external_jobs(rd_jq *q, int delta);

/* The duration histograms' bounds reach this many seconds: the job timeout,
 * or an hour when there is none, so renders (and waits) up to the longest
 * a job may take fall in finite buckets. */
double rd_jq_hist_cover(double job_timeout_ms);

typedef struct {
    size_t queued, running, waiting_memory;
    uint64_t done, failed, cancelled;
    uint64_t rays;
    rd_hist render_seconds;     /* jobs done: from their start to their image */
    rd_hist queue_wait_seconds; /* jobs started: from their submission to a render thread starting them */
    size_t result_bytes;
    size_t jobs_kept;
    size_t memory_budget, memory_reserved, external_bytes;
    size_t external_jobs;
} rd_jq_metrics;

void rd_jq_metrics_get(rd_jq *q, rd_jq_metrics *m);

/* Waits until job j has ended (done, failed or cancelled), or timeout_ms
 * passes; returns 1 when it has. */
int rd_jq_wait_ended(rd_jq *q, rd_jq_job *j, double timeout_ms);

/* Waits until no job is queued or running, or timeout_ms passes; returns 1
 * when idle. */
int rd_jq_drain(rd_jq *q, double timeout_ms);

/* Cancels every job that has not finished (queued ones get status
 * cancelled). */
void rd_jq_cancel_all(rd_jq *q);

#endif
