/* The watcher: one thread on its own store handle that wakes the render
 * threads when the store changes, stops the tiles of jobs that ended
 * elsewhere, renews this daemon's leases, expires old results and finds
 * passes whose finisher died. Then starting and stopping the farm. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "farm_internal.h"
#include "rayd/clock.h"

static void wake_all(rd_farm *f) { rd_jq_wake(f->opt.jobs); }

/* The jobs held here that have ended in the store (cancelled through
 * another daemon, failed elsewhere): their tiles stop now. */
static void check_held(rd_farm *f)
{
    char ids[8][RD_STORE_ID_MAX];
    int n = 0;
    pthread_mutex_lock(&f->mu);
    for (farm_ctx *c = f->ctxs; c && n < 8; c = c->next)
        if (!atomic_load(&c->stop))
            snprintf(ids[n++], RD_STORE_ID_MAX, "%s", c->id);
    pthread_mutex_unlock(&f->mu);
    for (int i = 0; i < n; i++) {
        rd_store_job_info info;
        rd_error err = {0};
        rd_error_code rc = rd_store_job_get(f->watch, ids[i], &info, &err);
        farm_store_result(f, rc);
        if (rc == RD_ERR_NOT_FOUND || (!rc && info.status != RD_STORE_QUEUED && info.status != RD_STORE_RUNNING))
            farm_ctx_ended(f, ids[i]);
        if (!rc)
            rd_store_job_info_free(&info);
    }
}

/* A pass completed and not opened at two sweeps in a row: its finisher is
 * gone (a daemon ending it would have opened it in milliseconds). */
typedef struct {
    char id[RD_STORE_ID_MAX];
    int pass;
} pending;

static int seen_before(const pending *prev, int nprev, const char *id, int pass)
{
    for (int i = 0; i < nprev; i++)
        if (prev[i].pass == pass && strcmp(prev[i].id, id) == 0)
            return 1;
    return 0;
}

static void find_stuck(rd_farm *f, pending *prev, int *nprev)
{
    rd_store_job_brief *b = NULL;
    size_t n = 0;
    rd_error err = {0};
    rd_error_code rc = rd_store_jobs_list(f->watch, RD_STORE_MASK(RD_STORE_RUNNING), 16, &b, &n, &err);
    farm_store_result(f, rc);
    if (rc)
        return;
    pending now[16];
    int nnow = 0;
    for (size_t i = 0; i < n; i++) {
        rd_store_job_info info;
        if (rd_store_job_get(f->watch, b[i].id, &info, &err))
            continue;
        if (info.gated && info.pass > 0 && info.pass == info.open_pass) {
            int pass = info.pass - 1;
            snprintf(now[nnow].id, RD_STORE_ID_MAX, "%s", info.id);
            now[nnow++].pass = pass;
            pthread_mutex_lock(&f->mu);
            int add = seen_before(prev, *nprev, info.id, pass) && f->nstuck < 16;
            if (add) {
                snprintf(f->stuck[f->nstuck].id, RD_STORE_ID_MAX, "%s", info.id);
                f->stuck[f->nstuck++].pass = pass;
            }
            pthread_mutex_unlock(&f->mu);
            if (add)
                wake_all(f);
        }
        rd_store_job_info_free(&info);
    }
    free(b);
    memcpy(prev, now, sizeof now);
    *nprev = nnow;
}

static void sweep(rd_farm *f, pending *prev, int *nprev)
{
    rd_error err = {0};
    size_t gone = 0;
    rd_error_code rc = rd_store_jobs_expire(f->watch, (int64_t)f->opt.result_ttl_ms, &gone, &err);
    farm_store_result(f, rc);
    find_stuck(f, prev, nprev);
    check_held(f);
}

static void *watch_main(void *arg)
{
    rd_farm *f = arg;
    double last_renew = 0, last_sweep = rd_now_ms(), last_check = 0;
    double renew_every = f->opt.lease_ms / 3.0, sweep_every = f->opt.lease_ms > 1000 ? f->opt.lease_ms : 1000;
    pending prev[16];
    int nprev = 0;
    for (;;) {
        pthread_mutex_lock(&f->mu);
        int stop = f->stopping;
        pthread_mutex_unlock(&f->mu);
        if (stop)
            break;
        rd_store_event ev = {RD_STORE_EV_NONE, ""};
        rd_error err = {0};
        rd_error_code rc = rd_store_wait(f->watch, 200, &ev, &err);
        farm_store_result(f, rc);
        if (!rc && ev.kind != RD_STORE_EV_NONE)
            wake_all(f);
        if (!rc && ev.kind == RD_STORE_EV_ENDED)
            farm_ctx_ended(f, ev.job_id);
        double now = rd_now_ms();
        if (!rc && ev.kind == RD_STORE_EV_CHANGED && now - last_check > 100) {
            check_held(f);
            last_check = now;
        }
        if (now - last_renew >= renew_every) {
            rc = rd_store_renew(f->watch, f->daemon_id, f->opt.lease_ms, NULL, &err);
            farm_store_result(f, rc);
            last_renew = now;
        }
        if (now - last_sweep >= sweep_every) {
            sweep(f, prev, &nprev);
            last_sweep = now;
        }
    }
    return NULL;
}

static void close_all(rd_farm *f)
{
    for (int i = 0; i < f->nworkers; i++)
        rd_store_close(f->worker_store[i]);
    free(f->worker_store);
    rd_store_close(f->api);
    rd_store_close(f->submit);
    rd_store_close(f->watch);
    farm_ctx_free_all(f);
    pthread_mutex_destroy(&f->mu);
    pthread_cond_destroy(&f->ctx_cv);
    free(f->store_spec);
    free(f);
}

static rd_store *open_one(rd_farm *f, rd_error *err) { return rd_store_open(f->store_spec, &f->opt.store, err); }

/* The store's handles: one for each render thread, and the farm's own. */
static rd_error_code open_handles(rd_farm *f, rd_error *err)
{
    /* The first open applies the migrations; the others find them done. */
    if (!(f->api = open_one(f, err)) || !(f->submit = open_one(f, err)) || !(f->watch = open_one(f, err)))
        return err->code;
    for (; f->nworkers < f->opt.workers; f->nworkers++)
        if (!(f->worker_store[f->nworkers] = open_one(f, err)))
            return err->code;
    /* A daemon restarted under its id takes up its tiles at once. */
    return rd_store_release(f->api, f->daemon_id, NULL, err);
}

rd_farm *rd_farm_start(const rd_farm_options *opt, rd_error *err)
{
    rd_farm *f = calloc(1, sizeof *f);
    if (!f) {
        rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
        return NULL;
    }
    f->opt = *opt;
    f->opt.workers = opt->workers < 1 ? 1 : opt->workers;
    f->opt.tile = opt->tile < 1 ? 64 : opt->tile;
    f->opt.lease_ms = opt->lease_ms < 100 ? 100 : opt->lease_ms;
    snprintf(f->daemon_id, sizeof f->daemon_id, "%s", opt->daemon_id);
    f->store_spec = strdup(opt->store_spec);
    pthread_mutex_init(&f->mu, NULL);
    pthread_cond_init(&f->ctx_cv, NULL);
    atomic_store(&f->store_up, 1);
    f->worker_store = calloc((size_t)f->opt.workers, sizeof *f->worker_store);
    if (!f->store_spec || !f->worker_store) {
        rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
        close_all(f);
        return NULL;
    }
    if (open_handles(f, err)) {
        close_all(f);
        return NULL;
    }
    if (pthread_create(&f->watcher, NULL, watch_main, f) != 0) {
        rd_error_set(err, RD_ERR_NOMEM, 0, 0, "cannot start the farm's watcher");
        close_all(f);
        return NULL;
    }
    f->watcher_on = 1;
    rd_jq_source src = {farm_run, farm_halt, f};
    rd_jq_set_source(f->opt.jobs, &src);
    return f;
}

void rd_farm_stop(rd_farm *f)
{
    if (!f || f->stopped)
        return;
    farm_halt(f);
    if (f->watcher_on)
        pthread_join(f->watcher, NULL);
    rd_error err = {0};
    rd_store_release(f->api, f->daemon_id, NULL, &err);
    pthread_mutex_lock(&f->mu);
    /* Their leases are given back: whoever claims those tiles renders them. */
    for (int i = 0; i < f->npending; i++)
        free(f->pending[i].blob);
    f->npending = 0;
    farm_ctx_free_all(f);
    f->stopped = 1;
    pthread_mutex_unlock(&f->mu);
}

void rd_farm_free(rd_farm *f)
{
    if (!f)
        return;
    rd_farm_stop(f);
    /* The queue may be gone: what is held now was never its to count. */
    f->opt.jobs = NULL;
    close_all(f);
}
