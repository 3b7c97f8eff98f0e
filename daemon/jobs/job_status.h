/* What GET /v1/jobs/{id} answers (and DELETE, and the 202 of POST
 * /v1/jobs): one view of a job, filled from the queue for a job in this
 * daemon's memory (POST /v1/render) or from the store for a stored one
 * (POST /v1/jobs, whichever daemon renders it), and written once, so that
 * a client reads both alike. */
#ifndef RD_JOB_STATUS_H
#define RD_JOB_STATUS_H

#include "job_queue.h"
#include "rayd/stats.h"

typedef struct {
    const char *id;
    rd_jq_status status; /* a stored job's rd_store_status has the same order */
    double progress;     /* 0..1 */
    double elapsed_ms;   /* since it started (0 while queued) */
    double queued_ms;    /* waiting before it started */
    int width, height;   /* 0 until its scene is read */
    /* samples, error_estimate, passes, curve, stopped_by and the costs;
     * the other figures are not given (RD_STATS_PROCESS, json_text.h). */
    rd_render_stats stats;
    /* When failed (and then both set): the answer's error.code
     * (error_map.h) and message. */
    const char *error_code, *error_message;
} rd_job_status;

/* The status as JSON text (free() it), or NULL when out of memory. The
 * figures are rd_stats_json's: the costs under "stats" once a render
 * thread has begun the job (running or done), stopped_by once it is done;
 * "error" when it failed. */
char *rd_job_status_json(const rd_job_status *s);

#endif
