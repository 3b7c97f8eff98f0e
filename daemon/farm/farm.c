#include "farm.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "farm_internal.h"
#include "hash.h"
#include "job_image.h"
#include "rayd/clock.h"

/* How long a render thread waits before it tries the store again after
 * finding it unreachable, and at most between claims when no event wakes
 * it (events can be lost while a connection is down). */
enum { RETRY_MS = 500, IDLE_MS = 2000, RETRY_FOR_MS = 2000 };

/* The store's trouble, which a later call may not have: unreachable, full,
 * or damaged (a page another call may not read). What was rendered waits
 * for it rather than being thrown away. */
static int trouble(rd_error_code rc)
{
    return rc == RD_ERR_UNAVAILABLE || rc == RD_ERR_NOSPACE || rc == RD_ERR_DAMAGED;
}

/* An answer a later call may not give: the store's trouble, or busy. Work
 * that got one is left for a later try, never failed for it. */
static int transient(rd_error_code rc) { return trouble(rc) || rc == RD_ERR_BUSY; }

void farm_store_result(rd_farm *f, rd_error_code rc)
{
    if (trouble(rc)) {
        atomic_fetch_add(&f->store_errors, 1);
        if (rc == RD_ERR_NOSPACE)
            atomic_store(&f->nospace_ms, (long long)rd_now_ms());
        if (atomic_exchange(&f->store_up, 0))
            rd_log_msg(f->opt.log, "warning", "%s; retrying",
                       rc == RD_ERR_NOSPACE   ? "the job store has no space left to write"
                       : rc == RD_ERR_DAMAGED ? "the job store is damaged (a corrupt page)"
                                              : "the job store is unreachable");
    } else if (!atomic_exchange(&f->store_up, 1)) {
        rd_log_msg(f->opt.log, "info", "the job store is reachable again");
    }
}

rd_error_code farm_full(rd_farm *f, rd_error *err)
{
    long long seen = atomic_load(&f->nospace_ms), ago = rd_now_ms() - seen;
    if (!seen || ago >= FARM_NOSPACE_MS || ago < 0)
        return RD_OK;
    return rd_error_set(err, RD_ERR_NOSPACE, 0, 0, "store: no space left: a write failed %.1f s ago",
                        (double)ago / 1e3);
}

static void sleep_ms(int ms)
{
    struct timespec ts = {ms / 1000, (long)(ms % 1000) * 1000000L};
    nanosleep(&ts, NULL);
}

static int stopping(rd_farm *f)
{
    pthread_mutex_lock(&f->mu);
    int s = f->stopping;
    pthread_mutex_unlock(&f->mu);
    return s;
}

/* Whether to try a store call again after its answer rc: the store's
 * trouble or RD_ERR_BUSY (other writers held it past its timeout), the
 * farm not stopping, and less than RETRY_FOR_MS since the first try at t0
 * (sleeps RETRY_MS first). A render thread is the queue's: it does not
 * wait out an outage, so synchronous renders go on meanwhile. What it gives
 * up is found again: a tile not stored is claimed again once its lease
 * runs out, and a pass completed but not ended is ended by whoever sees it
 * stuck (farm_watch.c). */
static int retry_again(rd_farm *f, rd_error_code rc, double t0)
{
    if (!transient(rc) || stopping(f) || rd_now_ms() - t0 >= RETRY_FOR_MS)
        return 0;
    sleep_ms(RETRY_MS);
    return 1;
}

#define RETRY_IO(f, rc, call)                                                                                          \
    for (double t0_ = rd_now_ms();;) {                                                                                 \
        (rc) = (call);                                                                                                 \
        farm_store_result((f), (rc));                                                                                  \
        if (!retry_again((f), (rc), t0_))                                                                              \
            break;                                                                                                     \
    }

static void wake(rd_farm *f) { rd_jq_wake(f->opt.jobs); }

/* Keeps what the store would not take for a later try (takes over blob). */
static void keep_pending(rd_farm *f, const rd_store_tile *t, unsigned char *blob, size_t len, const rd_error *why)
{
    pthread_mutex_lock(&f->mu);
    int room = f->npending < (int)(sizeof f->pending / sizeof f->pending[0]);
    if (room) {
        f->pending[f->npending].tile = *t;
        f->pending[f->npending].blob = blob;
        f->pending[f->npending].len = len;
        f->pending[f->npending].why = why ? *why : (rd_error){0};
        f->npending++;
    }
    pthread_mutex_unlock(&f->mu);
    if (!room) {
        rd_log_msg(f->opt.log, "warning", "job %s: a result the store would not take is dropped", t->job_id);
        free(blob);
    }
}

static void failed(rd_farm *f, const char *id, const rd_error *why)
{
    atomic_fetch_add(&f->failed, 1);
    rd_log_msg(f->opt.log, "info", "job %s failed: %s", id, why->message);
}

static void fail_job(rd_farm *f, rd_store *h, const char *id, const rd_error *why)
{
    rd_error_code rc;
    rd_error err = {0};
    RETRY_IO(f, rc, rd_store_job_fail(h, id, why, NULL, &err));
    if (rc == RD_OK)
        failed(f, id, why);
    if (transient(rc)) {
        rd_store_tile t = {0};
        snprintf(t.job_id, sizeof t.job_id, "%s", id);
        keep_pending(f, &t, NULL, 0, why);
    }
    farm_ctx_ended(f, id);
}

/* The image, assembled from every tile (the write lock held). */
static void finish(rd_farm *f, rd_store *h, farm_ctx *c, int64_t now)
{
    rd_error err = {0};
    rd_job_image im = {0};
    char *stats = farm_stats_text(c, now, 1);
    rd_error_code rc = stats ? rd_job_image_encode(c->core, &f->opt.png, c->params.hdr, &im, &err)
                             : rd_error_set(&err, RD_ERR_NOMEM, 0, 0, "out of memory");
    if (rc) {
        fail_job(f, h, c->id, &err);
    } else {
        rd_store_result r = {im.png, im.png_len, im.exr, im.exr_len, stats};
        RETRY_IO(f, rc, rd_store_job_finish(h, c->id, &r, &err));
        if (rc == RD_OK) {
            atomic_fetch_add(&f->done, 1);
            rd_jq_observe_source_job(f->opt.jobs, (double)(c->started_ms - c->submitted_ms) / 1e3,
                                     (double)(now - c->started_ms) / 1e3);
        }
        farm_ctx_ended(f, c->id);
    }
    rd_job_image_free(&im);
    free(stats);
}

/* Opens the next pass with the schedule the core has begun (the write
 * lock held). Another daemon may have ended the same pass: then its
 * schedule is the job's, and the core reads it back at the next claim. */
static void open_next(rd_farm *f, rd_store *h, farm_ctx *c, int pass, int64_t now)
{
    rd_job_schedule sc;
    rd_job_schedule_get(c->core, &sc);
    char *text = farm_schedule_text(&sc, now, c->params.progress.max_samples);
    char *stats = farm_stats_text(c, now, 0);
    rd_error err = {0};
    rd_error_code rc = RD_ERR_NOMEM;
    if (text && stats) {
        RETRY_IO(f, rc, rd_store_job_stats(h, c->id, stats, &err));
        RETRY_IO(f, rc, rd_store_pass_open(h, c->id, pass + 1, text, &err));
    }
    if (rc == RD_OK) {
        c->pass = pass + 1;
        c->opened_ms = now;
        atomic_fetch_add(&f->passes, 1);
        wake(f);
    } else {
        c->pass = -1;
    }
    free(text);
    free(stats);
}

/* Every tile holds pass `pass`: end it as the core's schedule says. Also
 * for a pass another daemon completed and never opened (it died), so the
 * pass is checked against the store first. */
static void end_pass(rd_farm *f, rd_store *h, farm_ctx *c, int pass)
{
    pthread_rwlock_wrlock(&c->rw);
    rd_error err = {0};
    int complete = 0;
    rd_error_code rc;
    RETRY_IO(f, rc, farm_ctx_sync_pass(f, h, c, pass, &err));
    if (!rc)
        RETRY_IO(f, rc, farm_ctx_gather(h, c, pass + 1, &complete, &err));
    if (rc || !complete) {
        if (rc && rc != RD_ERR_CANCELLED && !transient(rc) && rc != RD_ERR_NOT_FOUND)
            fail_job(f, h, c->id, &err);
        pthread_rwlock_unlock(&c->rw);
        return;
    }
    int64_t now = rd_wall_ms();
    int next = rd_job_end_pass_at(c->core, (double)(now - c->started_ms), (double)(now - c->opened_ms));
    if (next > 0 && pass + 1 < RD_CURVE_MAX)
        open_next(f, h, c, pass, now);
    else
        finish(f, h, c, now);
    pthread_rwlock_unlock(&c->rw);
}

/* The tile's pixels as the claim's pass starts from them (the read lock
 * held: only this tile's pixels are written). */
static rd_error_code tile_input(rd_store *h, farm_ctx *c, const rd_store_tile *t, rd_error *err)
{
    if (t->pass == 0 || c->tile_pass[t->index] == t->pass)
        return RD_OK;
    rd_store_tile_data td = {0};
    rd_error_code rc = rd_store_tile_get(h, c->id, t->index, &td, err);
    if (!rc && td.passes != t->pass)
        rc = rd_error_set(err, RD_ERR_INVALID, 0, 0, "tile %d of job %s holds %d passes, not %d", t->index, c->id,
                          td.passes, t->pass);
    if (!rc)
        rc = farm_blob_read(c, t->index, td.data, td.len, err);
    if (!rc)
        c->tile_pass[t->index] = t->pass;
    free(td.data);
    return rc;
}

/* Renders the claimed tile; its bytes in *blob (NULL when it did not
 * complete: cancelled, or past the job's time limit, *timed_out). */
static rd_error_code render(rd_farm *f, rd_store *h, farm_ctx *c, const rd_store_tile *t, unsigned char **blob,
                            size_t *len, int *timed_out, rd_error *err)
{
    *blob = NULL;
    *timed_out = 0;
    if (c->pass != t->pass) {
        pthread_rwlock_wrlock(&c->rw);
        rd_error_code rc = farm_ctx_sync_pass(f, h, c, t->pass, err);
        pthread_rwlock_unlock(&c->rw);
        if (rc)
            return rc;
    }
    pthread_rwlock_rdlock(&c->rw);
    rd_error_code rc = c->pass == t->pass ? tile_input(h, c, t, err)
                                          : rd_error_set(err, RD_ERR_CANCELLED, 0, 0, "job %s moved on", c->id);
    rd_job_counts k = {0, 0, 0, 0};
    if (!rc && rd_job_render_tile(c->core, t->index, &k)) {
        rd_job_counts *tc = &c->tile_counts[t->index];
        tc->camera += k.camera;
        tc->shadow += k.shadow;
        tc->secondary += k.secondary;
        tc->nonfinite += k.nonfinite;
        c->tile_pass[t->index] = t->pass + 1;
        *len = farm_blob_bytes(c, t->index);
        if ((*blob = malloc(*len)))
            farm_blob_write(c, t->index, *blob);
        else
            rc = rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
        atomic_fetch_add(&f->rays, k.camera + k.shadow + k.secondary);
    } else if (!rc) {
        *timed_out = !atomic_load(&c->stop);
    }
    pthread_rwlock_unlock(&c->rw);
    return rc;
}

static void timed_out(rd_farm *f, rd_store *h, const char *id)
{
    rd_error why;
    rd_error_set(&why, RD_ERR_TIMEOUT, 0, 0,
                 "the render took longer than the job time limit of %.0f ms "
                 "(--job-timeout-ms)",
                 f->opt.job_timeout_ms);
    fail_job(f, h, id, &why);
}

static void do_claim(rd_farm *f, rd_store *h, const rd_store_tile *t)
{
    rd_error err = {0};
    farm_ctx *c;
    for (double t0 = rd_now_ms();;) {
        c = farm_ctx_get(f, h, t->job_id, &err);
        farm_store_result(f, c ? RD_OK : err.code);
        if (c || !retry_again(f, err.code, t0))
            break;
    }
    if (!c) {
        if (!transient(err.code) && err.code != RD_ERR_NOT_FOUND)
            fail_job(f, h, t->job_id, &err);
        return;
    }
    unsigned char *blob = NULL;
    size_t len = 0;
    int late = 0;
    rd_error_code rc;
    RETRY_IO(f, rc, render(f, h, c, t, &blob, &len, &late, &err));
    if (late) {
        timed_out(f, h, c->id);
    } else if (rc == RD_ERR_CANCELLED) {
        /* A claim the store has moved past: give the lease back rather
         * than have the renewals keep it (with the others this daemon
         * holds, which their renders then lose; this should not happen). */
        rd_log_msg(f->opt.log, "warning", "job %s, tile %d: %s", c->id, t->index, err.message);
        RETRY_IO(f, rc, rd_store_release(h, f->daemon_id, NULL, &err));
    } else if (rc == RD_ERR_NOT_FOUND) {
        farm_ctx_ended(f, c->id); /* deleted meanwhile */
    } else if (rc && !transient(rc)) {
        fail_job(f, h, c->id, &err);
    } else if (blob) {
        rd_store_tile_outcome out = RD_STORE_TILE_MORE;
        RETRY_IO(f, rc, rd_store_tile_done(h, f->daemon_id, t, blob, len, &out, &err));
        if (transient(rc)) {
            keep_pending(f, t, blob, len, NULL);
            blob = NULL;
        } else {
            atomic_fetch_add(rc == RD_OK ? &f->tiles : &f->tiles_lost, 1);
        }
        if (rc == RD_ERR_CANCELLED)
            farm_ctx_ended(f, c->id);
        if (rc == RD_OK && out != RD_STORE_TILE_MORE)
            end_pass(f, h, c, t->pass);
    }
    free(blob);
    farm_ctx_put(f, c);
}

/* A pass the watcher saw completed and not opened, twice in a row. */
static int take_stuck(rd_farm *f, char *id, int *pass)
{
    if (f->nstuck == 0)
        return 0;
    f->nstuck--;
    snprintf(id, RD_STORE_ID_MAX, "%s", f->stuck[f->nstuck].id);
    *pass = f->stuck[f->nstuck].pass;
    return 1;
}

static void do_stuck(rd_farm *f, rd_store *h, const char *id, int pass)
{
    rd_error err = {0};
    farm_ctx *c = farm_ctx_get(f, h, id, &err);
    farm_store_result(f, c ? RD_OK : err.code);
    if (!c)
        return;
    rd_log_msg(f->opt.log, "info", "job %s: ending pass %d, which its daemon completed but did not end", id, pass);
    end_pass(f, h, c, pass);
    farm_ctx_put(f, c);
}

/* What this daemon may claim next: a tile of a job it holds (its memory
 * is counted already), else of the oldest job that fits in the room the
 * queue's admission rule leaves (rd_jq_source). */
static rd_error_code claim_next(rd_farm *f, rd_store *h, size_t room, rd_store_tile *t, int *n, rd_error *err)
{
    char held[CTX_HELD_MAX][RD_STORE_ID_MAX];
    int nheld = farm_ctx_held(f, held);
    *n = 0;
    for (int i = 0; i < nheld; i++) {
        rd_store_claim_filter only = {held[i], 0};
        rd_error_code rc = rd_store_claim_where(h, f->daemon_id, 1, f->opt.lease_ms, &only, t, n, err);
        if (rc || *n)
            return rc;
    }
    if (room == 0)
        return RD_OK;
    rd_store_claim_filter fit = {NULL, room == SIZE_MAX || room > INT64_MAX ? 0 : (int64_t)room};
    return rd_store_claim_where(h, f->daemon_id, 1, f->opt.lease_ms, &fit, t, n, err);
}

/* One try of a result kept back (keep_pending): 1 when there was one. *rc
 * is the store's answer; a transient one keeps it back again. */
static int retry_pending(rd_farm *f, rd_store *h, rd_error_code *rc)
{
    pthread_mutex_lock(&f->mu);
    int have = f->npending > 0;
    rd_store_tile t = {0};
    unsigned char *blob = NULL;
    size_t len = 0;
    rd_error why = {0}, err = {0};
    if (have) {
        f->npending--;
        t = f->pending[f->npending].tile;
        blob = f->pending[f->npending].blob;
        len = f->pending[f->npending].len;
        why = f->pending[f->npending].why;
    }
    pthread_mutex_unlock(&f->mu);
    if (!have)
        return 0;
    rd_store_tile_outcome out = RD_STORE_TILE_MORE;
    *rc = blob ? rd_store_tile_done(h, f->daemon_id, &t, blob, len, &out, &err)
               : rd_store_job_fail(h, t.job_id, &why, NULL, &err);
    farm_store_result(f, *rc);
    if (transient(*rc)) {
        keep_pending(f, &t, blob, len, &why);
        return 1;
    }
    free(blob);
    if (!blob && *rc == RD_OK)
        failed(f, t.job_id, &why);
    if (blob)
        atomic_fetch_add(*rc == RD_OK ? &f->tiles : &f->tiles_lost, 1);
    farm_ctx *c = blob && *rc == RD_OK && out != RD_STORE_TILE_MORE ? farm_ctx_get(f, h, t.job_id, &err) : NULL;
    if (c) {
        end_pass(f, h, c, t.pass);
        farm_ctx_put(f, c);
    }
    return 1;
}

int farm_run(void *arg, int worker, size_t room)
{
    rd_farm *f = arg;
    if (worker < 0 || worker >= f->nworkers)
        return IDLE_MS;
    rd_store *h = f->worker_store[worker];
    char id[RD_STORE_ID_MAX];
    int pass = 0;
    if (stopping(f))
        return IDLE_MS;
    rd_error_code kept;
    if (retry_pending(f, h, &kept))
        return transient(kept) ? RETRY_MS : 0;
    pthread_mutex_lock(&f->mu);
    int stuck = take_stuck(f, id, &pass);
    pthread_mutex_unlock(&f->mu);
    if (stuck) {
        do_stuck(f, h, id, pass);
        return 0;
    }
    rd_store_tile t;
    int n = 0;
    rd_error err = {0};
    rd_error_code rc = claim_next(f, h, room, &t, &n, &err);
    farm_store_result(f, rc);
    if (!rc && n == 1) {
        do_claim(f, h, &t);
        return 0;
    }
    return rc ? RETRY_MS : IDLE_MS;
}

void farm_halt(void *arg)
{
    rd_farm *f = arg;
    pthread_mutex_lock(&f->mu);
    f->stopping = 1;
    for (farm_ctx *c = f->ctxs; c; c = c->next)
        atomic_store(&c->stop, 1);
    pthread_mutex_unlock(&f->mu);
}
