/* Shared between the farm's files: its state and a job's local copy. Not
 * a public interface. */
#ifndef RD_FARM_INTERNAL_H
#define RD_FARM_INTERNAL_H

#include <pthread.h>
#include <stdatomic.h>

#include "farm.h"
#include "rayd/job.h"

/* A stored job as this daemon holds it while it renders some of its
 * tiles: the scene read back from the store, the core's job with every
 * pixel this daemon has seen, and which pass each tile holds here. Tiles
 * render under the read lock (distinct tiles touch distinct pixels);
 * reading every tile into it (a pass's end, a partial image) and moving it
 * to another pass take the write lock. */
typedef struct farm_ctx {
    char id[RD_STORE_ID_MAX];
    int refs;       /* under farm.mu */
    int built;      /* under farm.mu: core ready (or failed) */
    int building;   /* under farm.mu: a thread is building it */
    int have_scene; /* scene and params are read (by the submitter here, or a build) */
    rd_error_code build_rc;
    rd_error build_err;
    rd_scene scene;
    rd_job_params params;
    rd_job *core;
    int tiles;
    int64_t submitted_ms, started_ms;
    int64_t opened_ms;          /* when the pass the core is in was opened */
    int pass;                   /* the pass the core is in; -1 before the first */
    int *tile_pass;             /* passes each tile's pixels here hold */
    rd_job_counts *tile_counts; /* each tile's rays over its passes so far */
    size_t charged;             /* bytes counted against the queue's budget */
    int counted;                /* under farm.mu: counted as one of the queue's jobs */
    pthread_rwlock_t rw;
    atomic_int stop; /* the job ended: tiles stop within milliseconds */
    struct farm_ctx *next;
} farm_ctx;

struct rd_farm {
    rd_farm_options opt;
    char daemon_id[RD_STORE_ID_MAX];
    char *store_spec;
    rd_store *api;           /* HTTP threads' reads, cancels and pings */
    rd_store *submit;        /* submissions and partial images (render threads) */
    rd_store *watch;         /* the watcher: events, lease renewals, sweeps */
    rd_store **worker_store; /* one per render thread of the queue, used by that thread alone */
    pthread_t watcher;
    int nworkers, watcher_on;
    int stopped; /* rd_farm_stop has run */
    /* mu guards stopping, ctxs (the list, each refs, built, counted and
     * charged), stuck and nstuck; ctx_cv waits for a context's build. */
    pthread_mutex_t mu;
    pthread_cond_t ctx_cv;
    int stopping;
    farm_ctx *ctxs;
    /* Passes seen completed but not opened, for a worker to end. */
    struct {
        char id[RD_STORE_ID_MAX];
        int pass;
    } stuck[16];
    int nstuck;
    /* Work a render thread did while the store would not take it (a tile's
     * pixels, or a job's failure), kept for a later farm_run rather than
     * waited out on the queue's thread: a lease this daemon holds is
     * renewed, so nobody else would claim that tile again. */
    struct {
        rd_store_tile tile;  /* the claim (a failure: its job_id) */
        unsigned char *blob; /* the tile's bytes; NULL for a failure */
        size_t len;
        rd_error why; /* a failure's */
    } pending[16];
    int npending;
    atomic_ullong tiles, tiles_lost, passes, done, failed, cancelled, submitted, store_errors, rays, read_back;
    atomic_int store_up;
    /* When a call of any of the farm's handles last found no space
     * (rd_now_ms), 0 if none has. */
    atomic_llong nospace_ms;
};

/* How long after a write found no space the farm takes no new job and
 * says it is full: a small write may still fit (SQLite reuses its log's
 * pages) where the tiles of the jobs it holds do not, and the room left is
 * theirs. */
enum { FARM_NOSPACE_MS = 30000 };

/* The farm as the queue's source (rd_jq_source, farm.c): one stored
 * tile, or a stuck pass's end, on the queue's render thread `worker`. */
int farm_run(void *arg, int worker, size_t room);
/* Tiles in progress stop within milliseconds; nothing more is claimed. */
void farm_halt(void *arg);

/* farm_ctx.c: the cache of jobs held here. */

/* The job's context, built (scene read, core made) on first use; with a
 * reference the caller drops with farm_ctx_put. NULL with err set when it
 * cannot be built (its error is the job's, or the store's). */
farm_ctx *farm_ctx_get(rd_farm *f, rd_store *h, const char *id, rd_error *err);
void farm_ctx_put(rd_farm *f, farm_ctx *c);

/* The scene its submitter read here, for the job's first build on this
 * daemon (which then reads nothing back): takes over *scene (left empty).
 * Counted against the budget while held; dropped like any unused context. */
void farm_ctx_adopt(rd_farm *f, const char *id, rd_scene *scene, const rd_job_params *p);

/* Reads a stored job's scene: the one reader of the submitter and every
 * renderer, so that the same text and parameters give the same scene
 * everywhere. Sets p's progress cap from the scene. */
rd_error_code farm_read_scene(rd_farm *f, const char *text, size_t len, const char *format, rd_job_params *p,
                              rd_scene *s, rd_error *err);

/* The jobs held here whose tiles still render, oldest first, into ids;
 * returns how many (at most CTX_HELD_MAX). */
enum { CTX_HELD_MAX = 4 };
int farm_ctx_held(rd_farm *f, char ids[][RD_STORE_ID_MAX]);

/* The job ended: stop its tiles here and forget it once unused. */
void farm_ctx_ended(rd_farm *f, const char *id);

/* Every context, unused or not: the farm is stopping. */
void farm_ctx_free_all(rd_farm *f);

/* Puts the core on pass `pass` as the store's schedule says (the write
 * lock held by the caller). RD_ERR_CANCELLED when the store's job is at
 * another pass (the claim is stale, or another daemon ended the pass);
 * RD_ERR_INVALID when its schedule is not one this daemon reads. */
rd_error_code farm_ctx_sync_pass(rd_farm *f, rd_store *h, farm_ctx *c, int pass, rd_error *err);

/* Reads every stored tile newer than the pixels here (the write lock held
 * by the caller); *complete is 1 when every tile holds `passes` passes. */
rd_error_code farm_ctx_gather(rd_store *h, farm_ctx *c, int passes, int *complete, rd_error *err);

/* A tile's stored bytes: a header (the rays of its passes) and the core's
 * state. */
size_t farm_blob_bytes(const farm_ctx *c, int t);
void farm_blob_write(const farm_ctx *c, int t, void *out);
rd_error_code farm_blob_read(farm_ctx *c, int t, const void *in, size_t len, rd_error *err);

/* farm_schedule.c: the schedule text the pass's finisher writes. */
/* max_samples: the cap the job's progress is measured against. */
char *farm_schedule_text(const rd_job_schedule *sc, int64_t opened_ms, int max_samples);
rd_error_code farm_schedule_parse(const char *text, rd_job_schedule *sc, int64_t *opened_ms, rd_error *err);

/* The statistics text of a job (GET /v1/jobs/{id} shows it): what the
 * core measured, with the rays of every tile. */
char *farm_stats_text(farm_ctx *c, int64_t now_ms, int final);

/* farm_json.c: the status JSON of a stored job. */
char *farm_job_json(const rd_store_job_info *in);

/* Notes the store's answer: up, or in trouble (unreachable, full,
 * damaged); a full one's time for farm_full. */
void farm_store_result(rd_farm *f, rd_error_code rc);
/* RD_ERR_NOSPACE, saying how long ago, within FARM_NOSPACE_MS of the last
 * call that found no space; else RD_OK. */
rd_error_code farm_full(rd_farm *f, rd_error *err);

#endif
