/* The daemon's stored jobs: POST /v1/jobs commits a job to the store
 * (store.h) before it is answered, and every daemon on that store renders
 * its tiles. A job is cut into tiles of --store-tile pixels; render threads
 * claim one tile at a time with a lease (renewed while the daemon lives),
 * render the pass the claim is for and store the tile's pixels (the core's
 * state, job.h) with the rays it took. Whoever completes a pass reads every
 * tile, ends the pass as the core's schedule says (estimate, curve, time
 * budget, target error) and opens the next pass with the schedule the
 * others follow, or assembles the image and finishes the job. Since every
 * sample depends only on (seed, pixel, pass), the image is the same bytes
 * whichever daemons rendered which tiles, and whether the job was resumed.
 *
 * A daemon killed mid-tile loses nothing committed: its leases run out
 * after --lease-ms and others (or itself, restarted with the same
 * --daemon-id, at once) render those tiles again; a pass completed but
 * never opened (its finisher died) is ended by the next daemon that sees it
 * stuck. The store unreachable: submissions fail with RD_ERR_UNAVAILABLE (503), the
 * render threads wait and retry, and nothing committed is lost.
 *
 * Errors are values (rd_error_code, err filled). Thread safety: every
 * function may be called from any thread. Ownership: what a function hands
 * out is malloc'ed for the caller. */
#ifndef RD_FARM_H
#define RD_FARM_H

#include <stddef.h>
#include <stdint.h>

#include "job_params.h"
#include "job_queue.h"
#include "log.h"
#include "png_write.h"
#include "rayd/error.h"
#include "rayd/scene.h"
#include "scene_limits.h"
#include "scene_load.h"
#include "store.h"

typedef struct rd_farm rd_farm;

typedef struct {
    const char *store_spec; /* a folder (SQLite) or a PostgreSQL URL/conninfo: rd_store_open */
    rd_store_options store;
    const char *daemon_id; /* names this daemon's leases; [A-Za-z0-9._:-] */
    int workers;           /* the queue's render threads (one store handle each) */
    int lease_ms;
    int tile; /* edge in pixels of a stored job's tiles */
    double job_timeout_ms;
    double result_ttl_ms;
    size_t queue_length; /* stored jobs queued or running at most; more are RD_ERR_BUSY */
    rd_scene_limits limits;
    const char *scenes_dir; /* where a scene's meshes and textures resolve */
    rd_png_options png;
    rd_log *log;
    /* The queue whose render threads render the stored tiles too (the
     * farm is its source, rd_jq_source), under its fair share and budget. */
    rd_jq *jobs;
} rd_farm_options;

/* Opens the store (its migrations applied), starts the watcher and makes
 * the farm the queue's source: from then on the queue's render threads
 * claim and render stored tiles. NULL with err set when the store cannot
 * be opened (RD_ERR_UNAVAILABLE, IO) or is newer than this binary (RD_ERR_UNSUPPORTED). */
rd_farm *rd_farm_start(const rd_farm_options *opt, rd_error *err);

/* Call after rd_jq_stop (whose threads render the farm's tiles, and which
 * stops those tiles within milliseconds: whoever claims them next renders
 * them again) and before rd_jq_free: stops the watcher, gives this
 * daemon's leases back and returns what it held to the queue's budget.
 * The other calls still work, on the store, until rd_farm_free. */
void rd_farm_stop(rd_farm *f);

/* Stops it if need be, closes the store and frees everything (NULL:
 * nothing). The queue of rd_farm_options.jobs may be gone by then. */
void rd_farm_free(rd_farm *f);

/* "sqlite" or "postgresql". */
const char *rd_farm_engine(const rd_farm *f);

/* Reads the scene as uploaded (len bytes in the format given, sniffed
 * when RD_FMT_AUTO) with the parameters given, and commits it as a job:
 * its id (32 hex digits) into id, and the job as committed, the JSON of
 * its 202, into *json (malloc'ed). The scene read here is the one this
 * daemon renders from (other daemons read the stored text the same way).
 * The scene's own error (a 4xx), RD_ERR_BUSY when --queue jobs are queued
 * or running, RD_ERR_LIMIT when it could never fit the memory budget,
 * RD_ERR_UNAVAILABLE when the store is unreachable. Call it on a render thread: it
 * parses, loads assets and waits for the commit. */
rd_error_code rd_farm_submit(rd_farm *f, const char *text, size_t len, rd_scene_format fmt, const rd_job_params *p,
                             char id[RD_STORE_ID_MAX], char **json, rd_error *err);

/* A stored job's status as the JSON of GET /v1/jobs/{id} (malloc'ed
 * text), its status in *status. RD_ERR_NOT_FOUND, RD_ERR_UNAVAILABLE. */
rd_error_code rd_farm_job_json(rd_farm *f, const char *id, char **json, rd_store_status *status, rd_error *err);

/* Cancels a job (the tiles rendering here stop at once, other daemons'
 * within their next look at the store); *changed is 0 when it had ended. */
rd_error_code rd_farm_cancel(rd_farm *f, const char *id, int *changed, rd_error *err);

/* A finished job's PNG or EXR. RD_ERR_INVALID when it has none of that
 * kind (*status says why), RD_ERR_NOT_FOUND, RD_ERR_UNAVAILABLE. */
rd_error_code rd_farm_image(rd_farm *f, const char *id, rd_store_image_kind kind, unsigned char **data, size_t *len,
                            rd_store_status *status, int *hdr, rd_error *err);

/* The image so far of a running job, as a PNG: the tiles stored by every
 * daemon, black where none is yet. Slow (it reads the scene and every
 * tile): call it on a render thread. RD_ERR_INVALID when the job is not
 * running. */
rd_error_code rd_farm_partial_png(rd_farm *f, const char *id, unsigned char **png, size_t *len, rd_error *err);

/* RD_OK when the store answers now. */
rd_error_code rd_farm_ping(rd_farm *f, rd_error *err);

typedef struct {
    uint64_t tiles;        /* tiles rendered and stored by this daemon */
    uint64_t tiles_lost;   /* rendered, but the lease had gone to another daemon or the job had ended */
    uint64_t passes;       /* passes this daemon ended */
    uint64_t done, failed; /* jobs this daemon finished or failed */
    uint64_t cancelled;    /* jobs cancelled through this daemon */
    uint64_t submitted;    /* jobs committed through this daemon */
    uint64_t store_errors; /* calls that found the store unreachable */
    uint64_t rays;         /* rays of the tiles rendered here */
    uint64_t read_back;    /* scenes read back from the store to render (not submitted here, or dropped) */
    int store_up;          /* the last call reached the store */
    int active;            /* stored jobs whose tiles render here now */
    size_t memory;         /* what the jobs held here count against the budget */
    /* The store's queue, shared by every daemon on it (store_known 0: it
     * did not answer): jobs queued, and running anywhere. */
    int store_known;
    size_t store_queued, store_running;
} rd_farm_metrics;

/* m zeroed by the caller. Asks the store for its queue: call it where a
 * store round trip may wait (the /metrics route). */
void rd_farm_metrics_get(rd_farm *f, rd_farm_metrics *m);

#endif
