#define _GNU_SOURCE /* POLLRDHUP */
#include "job_queue.h"

#include <math.h>
#include <poll.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>

#include "job_image.h"
#include "rayd/clock.h"
#include "rayd/job.h"
#include "timed_wait.h"

double rd_jq_hist_cover(double job_timeout_ms) { return job_timeout_ms > 0 ? job_timeout_ms / 1e3 : 3600; }

enum { TILE_PENDING, TILE_RENDERING, TILE_DONE };

/* Locking. One mutex, q->mu, guards the queue and every job's fields but
 * those marked otherwise below. Every static function in this file runs
 * with it held, except the threads' entry points, call_done and the
 * constructors; a function that lets it go for slow work says "Releases
 * q->mu" and is the only one touching what it releases it for, by the
 * phase rule below. `_locked` names the variant of a public call
 * (rd_jq_job_unref, rd_jq_cancel) for a caller already holding q->mu.
 *
 * Where a job is. Clients see "queued" until it runs; a phase ending in
 * -ING is owned by one worker outside the lock, and nobody else touches the
 * job's render state (scene, core, png, exr) then. */
typedef enum { PH_NEW, PH_PREPARING, PH_WAITING, PH_STARTING, PH_RUNNING, PH_FINISHING, PH_ENDED } phase;

/* The registry keeps every list it sweeps in the order jobs entered it and
 * finds jobs by id through a hash table, so that submitting, finishing and
 * looking up cost the same with 4 kept jobs as with --max-jobs-kept. */
typedef struct jq_list jq_list;
typedef struct {
    rd_jq_job *prev, *next;
    jq_list *list; /* NULL when not in one */
} jq_link;
struct jq_list {
    rd_jq_job *head, *tail;
    size_t n;
    size_t link_offset; /* of the jq_link inside rd_jq_job */
};

/* Guarded by q->mu unless marked: "phase owner" fields are written by the
 * worker owning the job's -ING phase, with q->mu released, and read by
 * others only in phases no worker owns; "set once" fields are written at
 * submission, before the job is shared. */
struct rd_jq_job {
    rd_jq *q; /* set once */
    int refs;
    char id[RD_CAP_MAX]; /* set once */
    rd_jq_status status;
    phase ph;
    rd_jq_task task; /* set once; task.arg is the phase owner's */
    rd_scene scene;  /* phase owner (PREPARING fills it, STARTING reads it) */
    int render;      /* prepare left the render in */
    rd_job *core;    /* phase owner, and render threads' tiles (each its own pixels) while RUNNING */
    int tiles_total, next_tile, tiles_done, inflight;
    uint64_t tiles_given; /* over all passes: the fair-share key */
    unsigned char *tile_state;
    rd_progress_settings progress;
    int spp, pass_spp; /* samples per pixel of the passes ended, of the one running */
    int cancel;        /* asked to stop */
    int timed_out;
    int hung_up;     /* cancelled because its client went away */
    int requested;   /* cancelled by rd_jq_cancel */
    atomic_int stop; /* atomic: cancel as the tracer sees it, without the lock */
    int watch_fd, watch_http11, probe_sent;
    rd_jq_done_fn done;
    void *user;
    int notify_prepared;
    int internal;
    int renders_nothing;
    rd_jq_job *hold;
    double t_submit, t_start, t_end;
    rd_job_counts counts;
    rd_render_stats stats; /* what the core measured so far (rd_job_stats); copied in under q->mu */
    unsigned char *png;    /* written under q->mu once FINISHING ends */
    size_t png_len;
    int hdr;              /* keeps exr beside png */
    size_t prepare_bytes; /* reserved while prepare runs (rd_jq_submit_options) */
    unsigned char *exr;   /* the linear image, with hdr */
    size_t exr_len;
    rd_error error;
    size_t charged;   /* bytes of the budget it holds */
    size_t footprint; /* what it will hold once admitted */
    int active, registered;
    int sync; /* a waiting client takes the PNG: limits do not evict it */
    int was_sync;
    int width, height;
    uint64_t idnum; /* the id's value: its hash-table key */
    rd_jq_job *next_active, *next_hash;
    jq_link in_all, in_kept, in_results;
};

/* One render thread's start: which one it is, for the source's run. */
typedef struct {
    rd_jq *q;
    int index;
} jq_thread;

/* Guarded by mu unless marked; "set once" fields are written by
 * rd_jq_start before any thread runs. */
struct rd_jq {
    pthread_mutex_t mu;
    pthread_cond_t work_cv, idle_cv, watch_cv;
    rd_jq_options opt;            /* set once */
    pthread_t *threads, watchdog; /* set once */
    jq_thread *thread_args;       /* set once */
    int nthreads, has_watchdog;   /* set once */
    int stopping;
    int stopped; /* rd_jq_stop has joined the threads */
    /* The source's turn (rd_jq_source), all under mu: src.run is set once
     * before work for it arrives; src_given counts its units since nothing
     * of the queue's own last ran (its fair-share key); no thread asks it
     * before src_after (ms) unless woken. */
    rd_jq_source src;
    uint64_t src_given;
    double src_after;
    uint64_t src_wakes;
    rd_jq_job *active_head, *active_tail;
    jq_list all;       /* registered jobs, oldest first */
    jq_list kept[2];   /* finished and evictable, by was_sync, oldest first */
    jq_list results;   /* asynchronous results holding a PNG, oldest first */
    rd_jq_job **by_id; /* registered jobs by idnum, chained */
    size_t nby_id;     /* a power of two */
    size_t active_count, running_count, result_bytes, reserved;
    size_t preparing_bytes;   /* the prepare_bytes of the preparations running */
    atomic_llong external;    /* atomic: added to without the lock (rd_jq_external_bytes) */
    atomic_int external_jobs; /* atomic: likewise */
    uint64_t n_done, n_failed, n_cancelled, rays;
    rd_hist render, wait;
};

const char *rd_jq_status_name(rd_jq_status s)
{
    static const char *const names[] = {"queued", "running", "done", "failed", "cancelled"};
    return (unsigned)s < 5 ? names[s] : "?";
}

static void job_free(rd_jq_job *j)
{
    rd_job_free(j->core);
    rd_scene_free(&j->scene);
    free(j->tile_state);
    free(j->png);
    free(j->exr);
    if (j->task.free)
        j->task.free(j->task.arg);
    free(j);
}

static void unref_locked(rd_jq_job *j)
{
    if (--j->refs > 0)
        return;
    rd_jq_job *held = j->hold;
    job_free(j);
    if (held)
        unref_locked(held);
}

void rd_jq_job_unref(rd_jq_job *j)
{
    rd_jq *q = j->q;
    pthread_mutex_lock(&q->mu);
    unref_locked(j);
    pthread_mutex_unlock(&q->mu);
}

void *rd_jq_task_arg(rd_jq_job *j) { return j->task.arg; }

/* The budget a job holds becomes n bytes. */
static void charge(rd_jq *q, rd_jq_job *j, size_t n)
{
    q->reserved = q->reserved - j->charged + n;
    j->charged = n;
}

static size_t used_bytes(rd_jq *q)
{
    long long ext = atomic_load(&q->external);
    return q->reserved + q->result_bytes + (ext > 0 ? (size_t)ext : 0);
}

static void remove_active(rd_jq *q, rd_jq_job *j)
{
    rd_jq_job **pp = &q->active_head, *prev = NULL;
    while (*pp && *pp != j) {
        prev = *pp;
        pp = &(*pp)->next_active;
    }
    if (*pp) {
        *pp = j->next_active;
        if (q->active_tail == j)
            q->active_tail = prev;
        j->active = 0;
        q->active_count--;
        if (j->status == RD_JQ_RUNNING)
            q->running_count--;
    }
}

static jq_link *link_of(const jq_list *l, rd_jq_job *j) { return (jq_link *)((char *)j + l->link_offset); }

static void list_init(jq_list *l, size_t link_offset)
{
    memset(l, 0, sizeof *l);
    l->link_offset = link_offset;
}

static void list_push(jq_list *l, rd_jq_job *j)
{
    jq_link *k = link_of(l, j);
    if (k->list)
        return;
    k->list = l;
    k->prev = l->tail;
    k->next = NULL;
    if (l->tail)
        link_of(l, l->tail)->next = j;
    else
        l->head = j;
    l->tail = j;
    l->n++;
}

static void list_remove(jq_list *l, rd_jq_job *j)
{
    jq_link *k = link_of(l, j);
    if (k->list != l)
        return;
    if (k->prev)
        link_of(l, k->prev)->next = k->next;
    else
        l->head = k->next;
    if (k->next)
        link_of(l, k->next)->prev = k->prev;
    else
        l->tail = k->prev;
    k->list = NULL;
    l->n--;
}

static rd_jq_job **bucket(rd_jq *q, uint64_t idnum) { return &q->by_id[idnum & (q->nby_id - 1)]; }

/* Doubles the table once it holds more jobs than buckets; when that
 * allocation fails the chains just grow longer. */
static void grow_buckets(rd_jq *q)
{
    if (q->all.n <= q->nby_id)
        return;
    rd_jq_job **fresh = calloc(q->nby_id * 2, sizeof *fresh);
    if (!fresh)
        return;
    rd_jq_job **old = q->by_id;
    size_t nold = q->nby_id;
    q->by_id = fresh;
    q->nby_id = nold * 2;
    for (size_t b = 0; b < nold; b++)
        for (rd_jq_job *j = old[b], *next; j; j = next) {
            next = j->next_hash;
            rd_jq_job **head = bucket(q, j->idnum);
            j->next_hash = *head;
            *head = j;
        }
    free(old);
}

static void register_job(rd_jq *q, rd_jq_job *j)
{
    j->registered = 1;
    list_push(&q->all, j);
    rd_jq_job **head = bucket(q, j->idnum);
    j->next_hash = *head;
    *head = j;
    grow_buckets(q);
}

static void drop_result(rd_jq *q, rd_jq_job *j)
{
    list_remove(&q->results, j);
    if (j->png) {
        q->result_bytes -= j->png_len + j->exr_len;
        free(j->png);
        j->png = NULL;
        free(j->exr);
        j->exr = NULL;
        j->exr_len = 0;
    }
}

static void drop_registered(rd_jq *q, rd_jq_job *j)
{
    rd_jq_job **pp = bucket(q, j->idnum);
    while (*pp != j)
        pp = &(*pp)->next_hash;
    *pp = j->next_hash;
    list_remove(&q->all, j);
    list_remove(&q->kept[0], j);
    list_remove(&q->kept[1], j);
    j->registered = 0;
    drop_result(q, j);
    unref_locked(j);
}

static int finished(const rd_jq_job *j) { return !j->active && j->t_end > 0; }

/* A finished registered job becomes evictable once no waiting client
 * still has to take its PNG; its result becomes evictable once it is no
 * synchronous client's. Called when either may have changed. */
static void make_evictable(rd_jq *q, rd_jq_job *j)
{
    if (!j->registered || !finished(j))
        return;
    if (!(j->sync && j->png))
        list_push(&q->kept[j->was_sync ? 1 : 0], j);
    if (j->png && !j->sync)
        list_push(&q->results, j);
}

/* Drops finished jobs past their TTL, then the oldest past --max-jobs-kept
 * (answered synchronous renders before asynchronous results, which a
 * client may still come for), then the oldest results while over the
 * result memory. The lists are oldest first by the time a job became
 * evictable, which is its end but for a synchronous client slow to take
 * its PNG: such a job may hold back an older one's TTL by that delay.
 * */
static void sweep(rd_jq *q)
{
    double now = rd_now_ms();
    for (int k = 0; k < 2; k++)
        while (q->kept[k].head && now - q->kept[k].head->t_end > q->opt.result_ttl_ms)
            drop_registered(q, q->kept[k].head);
    while (q->kept[0].n + q->kept[1].n > q->opt.kept_max)
        drop_registered(q, q->kept[1].head ? q->kept[1].head : q->kept[0].head);
    while (q->result_bytes > q->opt.result_memory && q->results.head)
        drop_result(q, q->results.head);
}

/* The outcome counters of /metrics. */
static void count_outcome(rd_jq *q, const rd_jq_job *j, rd_jq_status st)
{
    if (st == RD_JQ_DONE) {
        q->n_done++;
        rd_hist_observe(&q->render, (j->t_end - j->t_start) / 1e3);
    } else if (st == RD_JQ_FAILED) {
        q->n_failed++;
    } else {
        q->n_cancelled++;
    }
    q->rays += j->counts.camera + j->counts.shadow + j->counts.secondary;
}

/* The job leaves the active list with its final status; the caller then
 * calls its done callback without the lock. */
static void end_job(rd_jq *q, rd_jq_job *j, rd_jq_status st)
{
    remove_active(q, j);
    j->status = st;
    j->ph = PH_ENDED;
    j->t_end = rd_now_ms();
    if (!j->internal)
        count_outcome(q, j, st);
    rd_stats_add_counts(&j->stats, &j->counts, j->t_start > 0 ? j->t_end - j->t_start : 0);
    /* Only the status and the PNG outlive the render. */
    rd_job_free(j->core);
    j->core = NULL;
    rd_scene_free(&j->scene);
    charge(q, j, 0);
    j->watch_fd = -1;
    if (j->png)
        q->result_bytes += j->png_len + j->exr_len;
    make_evictable(q, j);
    sweep(q);
    pthread_cond_broadcast(&q->idle_cv);
    pthread_cond_broadcast(&q->work_cv); /* memory came free */
}

static void fail_job(rd_jq *q, rd_jq_job *j, const rd_error *err)
{
    j->error = *err;
    end_job(q, j, RD_JQ_FAILED);
}

/* Called without the lock; the callback is read under it, since a request
 * that ends may detach it at any time. */
static void call_done(rd_jq_job *j)
{
    pthread_mutex_lock(&j->q->mu);
    rd_jq_done_fn fn = j->done;
    void *user = j->user;
    j->done = NULL;
    pthread_mutex_unlock(&j->q->mu);
    if (fn)
        fn(j, user);
}

/* Runs the done callback of a job that just ended or was prepared, the
 * job kept alive meanwhile. Releases q->mu while it calls. */
static void notify_done(rd_jq *q, rd_jq_job *j)
{
    j->refs++;
    pthread_mutex_unlock(&q->mu);
    call_done(j);
    pthread_mutex_lock(&q->mu);
    unref_locked(j);
}

/* 1 when the client is gone. An end of stream alone may be a half-close: a
 * client that sent its request and shut its sending side still reads the
 * answer. An HTTP/1.1 client in that state is sent one interim "102
 * Processing" (which clients skip); a peer that has really closed answers
 * it with a reset, seen at a later look. */
static int client_gone(rd_jq_job *j)
{
    int fd = j->watch_fd;
    struct pollfd p = {fd, POLLIN | POLLRDHUP, 0};
    if (poll(&p, 1, 0) <= 0)
        return 0;
    if (p.revents & (POLLHUP | POLLERR | POLLNVAL))
        return 1;
    char c;
    int eof = (p.revents & POLLRDHUP) || recv(fd, &c, 1, MSG_PEEK | MSG_DONTWAIT) == 0;
    if (!eof)
        return 0;
    if (!j->watch_http11)
        return 1;
    if (!j->probe_sent) {
        static const char processing[] = "HTTP/1.1 102 Processing\r\n\r\n";
        j->probe_sent = 1;
        if (send(fd, processing, sizeof processing - 1, MSG_NOSIGNAL | MSG_DONTWAIT) < 0)
            return 1;
    }
    return 0;
}

static void cancel_locked(rd_jq *q, rd_jq_job *j)
{
    j->cancel = 1;
    j->watch_fd = -1;
    atomic_store(&j->stop, 1);
    pthread_cond_broadcast(&q->work_cv);
}

/* Every 20 ms: time limits and hung-up clients of jobs whose render
 * threads are all busy tracing. */
static void *watchdog(void *arg)
{
    rd_jq *q = arg;
    pthread_mutex_lock(&q->mu);
    while (!q->stopping) {
        double now = rd_now_ms();
        for (rd_jq_job *j = q->active_head; j; j = j->next_active) {
            if (j->cancel)
                continue;
            int started = j->ph == PH_STARTING || j->ph == PH_RUNNING;
            if (started && q->opt.job_timeout_ms > 0 && now - j->t_start > q->opt.job_timeout_ms) {
                j->timed_out = 1;
                cancel_locked(q, j);
            } else if (j->watch_fd >= 0 && client_gone(j)) {
                j->hung_up = 1;
                cancel_locked(q, j);
            }
        }
        rd_timed_wait(&q->watch_cv, &q->mu, 20);
    }
    pthread_mutex_unlock(&q->mu);
    return NULL;
}

/* A cancelled job nobody is working on ends here. Releases q->mu (its
 * done callback). */
static void end_cancelled(rd_jq *q, rd_jq_job *j)
{
    if (j->timed_out) {
        rd_error e;
        rd_error_set(&e, RD_ERR_TIMEOUT, 0, 0, "the render took longer than the limit of %.0f ms (--job-timeout-ms)",
                     q->opt.job_timeout_ms);
        fail_job(q, j, &e);
    } else {
        end_job(q, j, RD_JQ_CANCELLED);
    }
    notify_done(q, j);
}

static rd_job_options core_options(const rd_jq_job *j)
{
    rd_job_options jo = {RD_JOB_TILE, j->progress, 1, 0, NULL};
    return jo;
}

/* Runs the task's preparation. Releases q->mu while it does. */
static void prepare_job(rd_jq *q, rd_jq_job *j)
{
    j->ph = PH_PREPARING;
    size_t own = j->prepare_bytes;
    charge(q, j, j->charged + own);
    q->preparing_bytes += own;
    pthread_mutex_unlock(&q->mu);
    rd_error err = {0};
    int render = 1;
    rd_error_code rc = j->task.prepare ? j->task.prepare(j->task.arg, &j->scene, &render, &err) : RD_OK;
    size_t need = 0;
    if (!rc && render) {
        j->progress.max_samples = j->scene.render.samples < 1 ? 1 : j->scene.render.samples;
        rd_job_options jo = core_options(j);
        need = rd_job_estimate_bytes(&j->scene, &jo);
        rc = rd_jq_check_budget(q, "the render", need, &err);
    }
    size_t held = rc ? 0 : rd_scene_bytes(&j->scene);
    pthread_mutex_lock(&q->mu);
    q->preparing_bytes -= own;
    if (own) {
        charge(q, j, j->charged - own);
        pthread_cond_broadcast(&q->work_cv); /* a waiting preparation may fit now */
    }
    j->render = render;
    j->width = j->scene.render.width;
    j->height = j->scene.render.height;
    if (rc) {
        fail_job(q, j, &err);
    } else if (j->cancel) {
        end_cancelled(q, j);
        return;
    } else {
        charge(q, j, held);
        j->footprint = need;
        j->ph = PH_WAITING;
        pthread_cond_broadcast(&q->work_cv);
    }
    if (j->notify_prepared || rc)
        notify_done(q, j);
}

/* A render thread takes the job up: the end of its wait in the queue.
 * */
static void mark_started(rd_jq *q, rd_jq_job *j)
{
    j->t_start = rd_now_ms();
    if (!j->internal)
        rd_hist_observe(&q->wait, (j->t_start - j->t_submit) / 1e3);
}

/* What a finished job gives: its task's own finish, which takes the 8-bit
 * image (NULL when prepare skipped the render), or the image clients take. */
static rd_error_code finish_output(rd_jq *q, rd_jq_job *j, rd_job_image *im, rd_error *err)
{
    if (!j->task.finish)
        return j->core ? rd_job_image_encode(j->core, &q->opt.png, j->hdr, im, err) : RD_OK;
    if (!j->core)
        return j->task.finish(j->task.arg, NULL, 0, 0, err);
    int w = rd_job_width(j->core), h = rd_job_height(j->core);
    uint8_t *rgb = malloc((size_t)w * (size_t)h * 3);
    if (!rgb)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    rd_job_rgb8(j->core, rgb);
    rd_error_code rc = j->task.finish(j->task.arg, rgb, w, h, err);
    free(rgb);
    return rc;
}

/* Called once a job's last tile or its preparation is done. Releases
 * q->mu while it encodes. */
static void finish_job(rd_jq *q, rd_jq_job *j)
{
    j->ph = PH_FINISHING;
    if (j->t_start == 0)
        mark_started(q, j);
    pthread_mutex_unlock(&q->mu);
    rd_error err = {0};
    rd_job_image im = {0};
    rd_error_code rc = finish_output(q, j, &im, &err);
    rd_render_stats st = j->stats;
    if (j->core)
        rd_job_stats(j->core, &st);
    pthread_mutex_lock(&q->mu);
    j->stats = st;
    if (rc) {
        fail_job(q, j, &err);
    } else {
        j->png = im.png;
        j->png_len = im.png_len;
        j->exr = im.exr;
        j->exr_len = im.exr_len;
        end_job(q, j, RD_JQ_DONE);
    }
    notify_done(q, j);
}

/* Admitted: allocate the render's state. Releases q->mu while it does. */
static void start_job(rd_jq *q, rd_jq_job *j)
{
    j->ph = PH_STARTING;
    mark_started(q, j);
    charge(q, j, j->footprint);
    pthread_mutex_unlock(&q->mu);
    rd_job *core = NULL;
    rd_error err = {0};
    rd_job_options jo = core_options(j);
    rd_error_code rc = rd_job_create(&j->scene, &jo, &core, &err);
    unsigned char *ts = NULL;
    if (!rc && !(ts = calloc((size_t)rd_job_tile_count(core), 1)))
        rc = rd_error_set(&err, RD_ERR_NOMEM, 0, 0, "out of memory");
    rd_render_stats plan = {0};
    int first = 0;
    if (!rc) {
        if (q->opt.job_timeout_ms > 0)
            rd_job_set_deadline(core, j->t_start + q->opt.job_timeout_ms);
        rd_job_set_cancel(core, &j->stop);
        rd_job_stats(core, &plan);
        first = rd_job_first_pass(core);
    }
    pthread_mutex_lock(&q->mu);
    /* Status readers copy stats under the lock. */
    j->stats = plan;
    if (rc) {
        rd_job_free(core);
        fail_job(q, j, &err);
        notify_done(q, j);
        return;
    }
    j->core = core;
    j->tile_state = ts;
    j->tiles_total = rd_job_tile_count(core);
    j->spp = 0;
    j->pass_spp = first;
    j->status = RD_JQ_RUNNING;
    j->ph = PH_RUNNING;
    q->running_count++;
    pthread_cond_broadcast(&q->work_cv);
}

/* The last tile of a pass is done: the core ends the pass (estimate,
 * curve point, the next pass begun) and the job starts rendering it or
 * finishes. Releases q->mu while the core ends the pass, with the job in
 * PH_FINISHING so no other worker touches it: that reads every pixel. */
static void end_of_pass(rd_jq *q, rd_jq_job *j)
{
    j->ph = PH_FINISHING;
    pthread_mutex_unlock(&q->mu);
    int next = rd_job_end_pass(j->core);
    rd_render_stats st;
    rd_job_stats(j->core, &st);
    pthread_mutex_lock(&q->mu);
    j->stats = st;
    j->spp = rd_job_samples_done(j->core);
    j->pass_spp = next;
    if (next == 0) {
        finish_job(q, j);
        return;
    }
    if (j->cancel) {
        j->ph = PH_RUNNING; /* reaped by the next worker to look */
        return;
    }
    j->next_tile = 0;
    j->tiles_done = 0;
    memset(j->tile_state, TILE_DONE, (size_t)j->tiles_total);
    j->ph = PH_RUNNING;
    pthread_cond_broadcast(&q->work_cv);
}

/* The job's next tile. Releases q->mu while it traces: the tile's pixels
 * are this thread's alone (TILE_RENDERING), the core's other state is
 * read only. */
static void render_tile(rd_jq *q, rd_jq_job *j)
{
    int tile = j->next_tile++;
    j->tiles_given++;
    j->tile_state[tile] = TILE_RENDERING;
    j->inflight++;
    pthread_mutex_unlock(&q->mu);
    rd_job_counts c = {0, 0, 0, 0};
    int complete = rd_job_render_tile(j->core, tile, &c);
    pthread_mutex_lock(&q->mu);
    if (!complete && !j->cancel) {
        /* Stopped by the core's own deadline before the watchdog saw it. */
        j->timed_out = 1;
        cancel_locked(q, j);
    }
    j->tile_state[tile] = TILE_DONE;
    j->counts.camera += c.camera;
    j->counts.shadow += c.shadow;
    j->counts.secondary += c.secondary;
    j->counts.nonfinite += c.nonfinite;
    j->tiles_done++;
    j->inflight--;
    if (j->tiles_done == j->tiles_total && !j->cancel)
        end_of_pass(q, j);
    else if (j->cancel && j->inflight == 0)
        pthread_cond_broadcast(&q->work_cv); /* someone ends it */
}

static int busy(const rd_jq_job *j) { return j->ph == PH_PREPARING || j->ph == PH_STARTING || j->ph == PH_FINISHING; }

/* A job holds its place from submission: until it is prepared its memory
 * is unknown, so under a budget no younger job may start ahead of it
 * (else a younger one whose preparation ended first could take the room
 * and leave it waiting, behind a runaway, for ever). Preparations that
 * render nothing hold no place. */
static int holds_unknown_place(const rd_jq_job *j)
{
    return (j->ph == PH_NEW || j->ph == PH_PREPARING) && !j->cancel && !j->renders_nothing;
}

/* May this prepared job start now? The oldest waiting job that does not fit
 * holds its place: younger ones start only if they fit beside it, so a
 * stream of small jobs cannot starve a large one. When nothing runs, the
 * oldest starts anyway (results and caches make room as they age).
 * */
static int admit(rd_jq *q, const rd_jq_job *j, size_t *held_back)
{
    if (!q->opt.memory_budget)
        return 1;
    size_t used = used_bytes(q) - j->charged;
    if (used + *held_back + j->footprint <= q->opt.memory_budget)
        return 1;
    if (*held_back == 0 && q->running_count == 0) {
        int starting = 0;
        for (const rd_jq_job *o = q->active_head; o; o = o->next_active)
            starting |= o->ph == PH_STARTING;
        if (!starting)
            return 1;
    }
    *held_back += j->footprint;
    return 0;
}

/* May this new job be prepared now? Only once what its preparation may
 * hold (a sandbox, an archive's expansion) fits beside what is used; when
 * nothing runs or prepares it goes anyway (results and caches make room
 * as they age), so one always runs. Younger jobs may pass one that waits.
 * */
static int prepare_fits(rd_jq *q, const rd_jq_job *j)
{
    size_t own = j->prepare_bytes;
    if (!own || !q->opt.memory_budget || used_bytes(q) + own <= q->opt.memory_budget)
        return 1;
    if (q->running_count || q->preparing_bytes)
        return 0;
    for (const rd_jq_job *o = q->active_head; o; o = o->next_active)
        if (o->ph == PH_PREPARING)
            return 0;
    return 1;
}

/* What new work of the source may take: by admit's rule, the budget left
 * beside what is used and what older waiting jobs were held back for;
 * anything when nothing at all runs. */
static size_t source_room(rd_jq *q, size_t held_back)
{
    if (!q->opt.memory_budget)
        return SIZE_MAX;
    size_t used = used_bytes(q) + held_back;
    if (held_back == 0 && q->running_count == 0 && atomic_load(&q->external) <= 0)
        return SIZE_MAX;
    return used >= q->opt.memory_budget ? 0 : q->opt.memory_budget - used;
}

/* Whether the source's turn comes before tile_job's next tile (the fair
 * share), and it may be asked now. */
static int source_turn(rd_jq *q, const rd_jq_job *tile_job)
{
    if (!q->src.run || rd_now_ms() < q->src_after)
        return 0;
    return !tile_job || q->src_given <= tile_job->tiles_given;
}

/* What a free worker does next: a cancelled job to end, a new job to
 * prepare, a prepared one to start, or the next tile by fair share, which
 * may be the source's (*room set, NULL returned). */
static rd_jq_job *pick(rd_jq *q, int preparer, int *source, size_t *room)
{
    *source = 0;
    rd_jq_job *tile_job = NULL;
    size_t held_back = 0;
    int older_unknown = 0; /* an older job holds a place of unknown size */
    for (rd_jq_job *j = q->active_head; j; j = j->next_active) {
        int unknown = q->opt.memory_budget && holds_unknown_place(j);
        if (busy(j)) {
            older_unknown |= unknown;
            continue;
        }
        if (preparer) {
            /* Work that renders nothing: a new job's preparation, a cancelled
             * job's end, a grade whose reference was cached. */
            if ((j->ph == PH_NEW && !j->cancel && prepare_fits(q, j)) || (j->cancel && j->inflight == 0) ||
                (j->ph == PH_WAITING && !j->render && !j->cancel))
                return j;
            continue;
        }
        if (j->cancel) {
            if (j->inflight == 0)
                return j;
            continue;
        }
        if (j->ph == PH_NEW && prepare_fits(q, j))
            return j;
        if (j->ph == PH_WAITING && (!j->render || !older_unknown) && admit(q, j, &held_back))
            return j;
        older_unknown |= unknown;
        /* Fair share: the next tile goes to the job that has been given
         * the fewest so far, the oldest on a tie. */
        if (j->ph == PH_RUNNING && j->next_tile < j->tiles_total &&
            (!tile_job || j->tiles_given < tile_job->tiles_given))
            tile_job = j;
    }
    if (preparer)
        return NULL;
    if (q->running_count == 0)
        q->src_given = 0; /* the next job of the queue's own starts level with it */
    if (source_turn(q, tile_job)) {
        *source = 1;
        *room = source_room(q, held_back);
        return NULL;
    }
    return tile_job;
}

/* One unit of the source's work, without the lock. A source that found
 * nothing is not asked again before the time it named, unless woken
 * meanwhile. Releases q->mu while it works. */
static void run_source(rd_jq *q, int worker, size_t room)
{
    q->src_given++;
    uint64_t wakes = q->src_wakes;
    rd_jq_source src = q->src;
    pthread_mutex_unlock(&q->mu);
    int wait_ms = src.run(src.arg, worker, room);
    pthread_mutex_lock(&q->mu);
    if (wait_ms > 0 && q->src_wakes == wakes)
        q->src_after = rd_now_ms() + wait_ms;
}

/* Nothing to do: wait for work, or until the source may be asked again.
 * */
static void idle_wait(rd_jq *q)
{
    double left = q->src.run ? q->src_after - rd_now_ms() : 0;
    if (left > 0)
        rd_timed_wait(&q->work_cv, &q->mu, left);
    else
        pthread_cond_wait(&q->work_cv, &q->mu);
}

/* A render thread, or with preparer set the one thread that only prepares
 * and finishes jobs that render nothing, so that reading a new scene (and
 * answering 400 or 202) never waits for a tile that may take seconds. */
static void work(rd_jq *q, int worker, int preparer)
{
    pthread_mutex_lock(&q->mu);
    while (!q->stopping) {
        int source = 0;
        size_t room = 0;
        rd_jq_job *j = pick(q, preparer, &source, &room);
        if (source) {
            run_source(q, worker, room);
            continue;
        }
        if (!j) {
            idle_wait(q);
            continue;
        }
        j->refs++;
        if (j->cancel)
            end_cancelled(q, j);
        else if (j->ph == PH_NEW)
            prepare_job(q, j);
        else if (j->ph == PH_WAITING && !j->render)
            finish_job(q, j);
        else if (j->ph == PH_WAITING)
            start_job(q, j);
        else
            render_tile(q, j);
        unref_locked(j);
    }
    pthread_mutex_unlock(&q->mu);
}

static void *worker(void *arg)
{
    jq_thread *t = arg;
    work(t->q, t->index, 0);
    return NULL;
}

static void *preparer(void *arg)
{
    jq_thread *t = arg;
    work(t->q, t->index, 1);
    return NULL;
}

rd_jq *rd_jq_start(const rd_jq_options *opt, rd_error *err)
{
    rd_jq *q = calloc(1, sizeof *q);
    if (!q) {
        rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
        return NULL;
    }
    q->opt = *opt;
    rd_hist_init(&q->render, rd_jq_hist_cover(opt->job_timeout_ms));
    rd_hist_init(&q->wait, rd_jq_hist_cover(opt->job_timeout_ms));
    if (q->opt.workers < 1)
        q->opt.workers = 1;
    if (q->opt.kept_max < 1)
        q->opt.kept_max = 1;
    list_init(&q->all, offsetof(rd_jq_job, in_all));
    list_init(&q->kept[0], offsetof(rd_jq_job, in_kept));
    list_init(&q->kept[1], offsetof(rd_jq_job, in_kept));
    list_init(&q->results, offsetof(rd_jq_job, in_results));
    q->nby_id = 64;
    q->by_id = calloc(q->nby_id, sizeof *q->by_id);
    if (!q->by_id) {
        free(q);
        rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
        return NULL;
    }
    pthread_mutex_init(&q->mu, NULL);
    pthread_cond_init(&q->work_cv, NULL);
    pthread_cond_init(&q->idle_cv, NULL);
    pthread_cond_init(&q->watch_cv, NULL);
    q->threads = calloc((size_t)q->opt.workers + 1, sizeof *q->threads);
    q->thread_args = calloc((size_t)q->opt.workers + 1, sizeof *q->thread_args);
    if (!q->threads || !q->thread_args) {
        free(q->threads);
        free(q->thread_args);
        free(q->by_id);
        free(q);
        rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
        return NULL;
    }
    for (int i = 0; i <= q->opt.workers; i++) {
        q->thread_args[i] = (jq_thread){q, i};
        if (pthread_create(&q->threads[i], NULL, i < q->opt.workers ? worker : preparer, &q->thread_args[i]) != 0)
            break;
        q->nthreads++;
    }
    q->has_watchdog = q->nthreads == q->opt.workers + 1 && pthread_create(&q->watchdog, NULL, watchdog, q) == 0;
    if (!q->has_watchdog) {
        rd_jq_free(q);
        rd_error_set(err, RD_ERR_NOMEM, 0, 0, "cannot start render threads");
        return NULL;
    }
    return q;
}

void rd_jq_stop(rd_jq *q)
{
    if (!q || q->stopped)
        return;
    rd_jq_cancel_all(q);
    pthread_mutex_lock(&q->mu);
    q->stopping = 1;
    pthread_cond_broadcast(&q->work_cv);
    pthread_cond_broadcast(&q->watch_cv);
    rd_jq_source src = q->src;
    pthread_mutex_unlock(&q->mu);
    /* A thread inside the source's tile returns once it is told. */
    if (src.stop)
        src.stop(src.arg);
    for (int i = 0; i < q->nthreads; i++)
        pthread_join(q->threads[i], NULL);
    if (q->has_watchdog)
        pthread_join(q->watchdog, NULL);
    /* Jobs still active were cancelled but never reached by a worker. */
    pthread_mutex_lock(&q->mu);
    while (q->active_head) {
        rd_jq_job *j = q->active_head;
        end_job(q, j, RD_JQ_CANCELLED);
        notify_done(q, j);
    }
    q->stopped = 1;
    pthread_mutex_unlock(&q->mu);
}

void rd_jq_free(rd_jq *q)
{
    if (!q)
        return;
    rd_jq_stop(q);
    pthread_mutex_lock(&q->mu);
    while (q->all.head)
        drop_registered(q, q->all.head);
    pthread_mutex_unlock(&q->mu);
    free(q->by_id);
    free(q->threads);
    free(q->thread_args);
    pthread_mutex_destroy(&q->mu);
    pthread_cond_destroy(&q->work_cv);
    pthread_cond_destroy(&q->idle_cv);
    pthread_cond_destroy(&q->watch_cv);
    free(q);
}

rd_error_code rd_jq_submit(rd_jq *q, const rd_jq_task *task, const rd_jq_submit_options *so, rd_jq_job **out,
                           rd_error *err)
{
    *out = NULL;
    size_t prep = so ? so->prepare_bytes : 0, need = task->input_bytes + prep;
    if (prep && rd_jq_check_budget(q, "the job", need, err)) {
        if (task->free)
            task->free(task->arg);
        return err->code;
    }
    rd_jq_job *j = calloc(1, sizeof *j);
    if (!j) {
        if (task->free)
            task->free(task->arg);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    }
    j->q = q;
    j->task = *task;
    if (task->stop)
        *task->stop = &j->stop;
    rd_scene_init(&j->scene);
    if (so) {
        j->progress = so->progress;
        j->watch_fd = so->watch_fd;
        j->watch_http11 = so->watch_http11;
        j->done = so->done;
        j->user = so->user;
        j->notify_prepared = so->notify_prepared;
        j->internal = so->internal;
        j->renders_nothing = so->renders_nothing;
        j->hold = so->hold;
        j->hdr = so->hdr;
        j->prepare_bytes = so->prepare_bytes;
    } else {
        j->watch_fd = -1;
    }
    j->sync = j->was_sync = j->done != NULL && !j->notify_prepared;
    j->t_submit = rd_now_ms();
    rd_error_code made = rd_cap_new(j->id, 0, err);
    j->idnum = rd_cap_bucket(j->id);
    pthread_mutex_lock(&q->mu);
    sweep(q);
    int ext = atomic_load(&q->external_jobs);
    int full = q->stopping || q->active_count + (size_t)(ext > 0 ? ext : 0) >= q->opt.queue_length;
    if (made || full) {
        if (j->hold)
            unref_locked(j->hold);
        pthread_mutex_unlock(&q->mu);
        job_free(j);
        return made ? made
                    : rd_error_set(err, RD_ERR_BUSY, 0, 0, "the render queue is full (%zu jobs, --queue)",
                                   q->opt.queue_length);
    }
    j->refs = j->internal ? 1 : 2; /* the registry's and the caller's */
    j->status = RD_JQ_QUEUED;
    j->ph = PH_NEW;
    j->active = 1;
    charge(q, j, task->input_bytes);
    if (q->active_tail)
        q->active_tail->next_active = j;
    else
        q->active_head = j;
    q->active_tail = j;
    q->active_count++;
    if (!j->internal)
        register_job(q, j);
    pthread_cond_broadcast(&q->work_cv);
    pthread_mutex_unlock(&q->mu);
    *out = j;
    return RD_OK;
}

/* A scene given at submission: preparation only hands it over. */
static rd_error_code take_scene(void *arg, rd_scene *scene, int *render, rd_error *err)
{
    (void)render, (void)err;
    rd_scene *given = arg;
    rd_scene_free(scene);
    *scene = *given;
    rd_scene_init(given);
    return RD_OK;
}

static void free_scene(void *arg)
{
    rd_scene *s = arg;
    if (s) {
        rd_scene_free(s);
        free(s);
    }
}

rd_error_code rd_jq_submit_scene(rd_jq *q, rd_scene *scene, const rd_jq_submit_options *so, rd_jq_job **out,
                                 rd_error *err)
{
    rd_scene *copy = malloc(sizeof *copy);
    if (!copy) {
        rd_scene_free(scene);
        *out = NULL;
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    }
    *copy = *scene;
    rd_scene_init(scene);
    rd_jq_task t = {take_scene, NULL, free_scene, copy, rd_scene_bytes(copy), NULL};
    return rd_jq_submit(q, &t, so, out, err);
}

rd_jq_job *rd_jq_find(rd_jq *q, const char *id)
{
    pthread_mutex_lock(&q->mu);
    sweep(q);
    rd_jq_job *found = NULL;
    for (rd_jq_job *j = rd_cap_valid(id, 0) ? *bucket(q, rd_cap_bucket(id)) : NULL; j; j = j->next_hash)
        if (rd_cap_equal(j->id, id)) {
            found = j;
            j->refs++;
            break;
        }
    pthread_mutex_unlock(&q->mu);
    return found;
}

void rd_jq_detach(rd_jq *q, rd_jq_job *j)
{
    pthread_mutex_lock(&q->mu);
    j->done = NULL;
    j->user = NULL;
    j->watch_fd = -1;
    j->sync = 0;
    make_evictable(q, j);
    pthread_mutex_unlock(&q->mu);
}

int rd_jq_cancel(rd_jq *q, rd_jq_job *j)
{
    pthread_mutex_lock(&q->mu);
    int live = j->active;
    if (live && !j->cancel) {
        j->requested = 1;
        cancel_locked(q, j);
    }
    pthread_mutex_unlock(&q->mu);
    return live;
}

static double progress_of(const rd_jq_job *j)
{
    if (j->status == RD_JQ_DONE)
        return 1.0;
    double p = j->tiles_total > 0 ? (double)j->tiles_done / j->tiles_total : 0;
    if (j->status == RD_JQ_RUNNING && rd_progress_is_progressive(&j->progress)) {
        /* Samples toward the cap, or time toward the budget. */
        double by_spp = (j->spp + (double)j->pass_spp * j->tiles_done / (j->tiles_total ? j->tiles_total : 1)) /
                        j->progress.max_samples;
        double by_time = j->progress.time_budget_ms > 0 ? (rd_now_ms() - j->t_start) / j->progress.time_budget_ms : 0;
        p = by_spp > by_time ? by_spp : by_time;
        if (p > 0.99)
            p = 0.99;
    }
    return p;
}

void rd_jq_info_get(rd_jq *q, rd_jq_job *j, rd_jq_info *out)
{
    pthread_mutex_lock(&q->mu);
    memset(out, 0, sizeof *out);
    snprintf(out->id, sizeof out->id, "%s", j->id);
    out->status = j->status;
    out->progress = progress_of(j);
    double now = rd_now_ms();
    out->elapsed_ms = j->t_start > 0 ? (j->t_end > 0 ? j->t_end : now) - j->t_start : 0;
    out->queued_ms = (j->t_start > 0 ? j->t_start : now) - j->t_submit;
    out->samples = j->status == RD_JQ_DONE ? j->stats.samples : j->spp;
    out->stopped_by = j->stats.stopped_by;
    out->passes = j->stats.passes;
    out->curve_len = j->stats.curve_len;
    memcpy(out->curve, j->stats.curve, sizeof out->curve);
    out->error_estimate = j->stats.error_estimate;
    out->stats = j->stats;
    if (j->active) {
        out->stats.camera_rays = j->counts.camera;
        out->stats.shadow_rays = j->counts.shadow;
        out->stats.secondary_rays = j->counts.secondary;
    }
    out->error = j->error;
    out->width = j->width;
    out->height = j->height;
    out->hung_up = j->hung_up;
    out->requested = j->requested;
    out->prepared = j->ph >= PH_WAITING;
    out->hdr = j->hdr;
    pthread_mutex_unlock(&q->mu);
}

rd_error_code rd_jq_png(rd_jq *q, rd_jq_job *j, int partial, unsigned char **png, size_t *len, rd_error *err)
{
    *png = NULL;
    *len = 0;
    pthread_mutex_lock(&q->mu);
    if (j->png) {
        unsigned char *copy = malloc(j->png_len);
        if (copy) {
            memcpy(copy, j->png, j->png_len);
            *png = copy;
            *len = j->png_len;
        }
        pthread_mutex_unlock(&q->mu);
        return copy ? RD_OK : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    }
    if (!partial || j->ph != PH_RUNNING || !j->core) {
        rd_jq_status st = j->status;
        pthread_mutex_unlock(&q->mu);
        if (st == RD_JQ_DONE)
            return rd_error_set(err, RD_ERR_INVALID, 0, 0, "the image has expired (--result-memory)");
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "job is %s: no image yet", rd_jq_status_name(st));
    }
    /* Tiles marked done were written before the lock that marked them. */
    int w = rd_job_width(j->core), h = rd_job_height(j->core);
    uint8_t *rgb = calloc((size_t)w * (size_t)h * 3, 1);
    if (rgb)
        for (int t = 0; t < j->tiles_total; t++)
            if (j->tile_state[t] == TILE_DONE)
                rd_job_tile_rgb8(j->core, t, rgb);
    pthread_mutex_unlock(&q->mu);
    if (!rgb)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    rd_error_code rc = rd_png_encode(rgb, w, h, &q->opt.png, png, len, err);
    free(rgb);
    return rc;
}

rd_error_code rd_jq_exr(rd_jq *q, rd_jq_job *j, unsigned char **exr, size_t *len, rd_error *err)
{
    *exr = NULL;
    *len = 0;
    pthread_mutex_lock(&q->mu);
    rd_jq_status st = j->status;
    unsigned char *copy = j->exr ? malloc(j->exr_len) : NULL;
    if (copy) {
        memcpy(copy, j->exr, j->exr_len);
        *exr = copy;
        *len = j->exr_len;
    }
    int had = j->exr != NULL;
    pthread_mutex_unlock(&q->mu);
    if (had)
        return copy ? RD_OK : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    if (st == RD_JQ_DONE)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "the image has expired (--result-memory)");
    return rd_error_set(err, RD_ERR_INVALID, 0, 0, "job is %s: no image yet", rd_jq_status_name(st));
}

void rd_jq_release_png(rd_jq *q, rd_jq_job *j)
{
    pthread_mutex_lock(&q->mu);
    drop_result(q, j);
    j->sync = 0;
    make_evictable(q, j);
    pthread_mutex_unlock(&q->mu);
}

void rd_jq_external_bytes(rd_jq *q, long long delta)
{
    atomic_fetch_add(&q->external, delta);
    if (delta < 0) {
        pthread_mutex_lock(&q->mu);
        pthread_cond_broadcast(&q->work_cv);
        pthread_mutex_unlock(&q->mu);
    }
}

rd_error_code rd_jq_check_budget(const rd_jq *q, const char *what, size_t need, rd_error *err)
{
    if (!q->opt.memory_budget || need <= q->opt.memory_budget)
        return RD_OK;
    return rd_error_set(err, RD_ERR_LIMIT, 0, 0, "%s needs about %zu MiB, over the limit of %zu MiB (--memory-budget)",
                        what, need >> 20, q->opt.memory_budget >> 20);
}

void rd_jq_set_source(rd_jq *q, const rd_jq_source *src)
{
    pthread_mutex_lock(&q->mu);
    q->src = *src;
    q->src_after = 0;
    pthread_cond_broadcast(&q->work_cv);
    pthread_mutex_unlock(&q->mu);
}

void rd_jq_wake(rd_jq *q)
{
    pthread_mutex_lock(&q->mu);
    q->src_wakes++;
    q->src_after = 0;
    pthread_cond_broadcast(&q->work_cv);
    pthread_mutex_unlock(&q->mu);
}

void rd_jq_observe_source_job(rd_jq *q, double wait_s, double render_s)
{
    pthread_mutex_lock(&q->mu);
    if (wait_s >= 0)
        rd_hist_observe(&q->wait, wait_s);
    if (render_s >= 0)
        rd_hist_observe(&q->render, render_s);
    pthread_mutex_unlock(&q->mu);
}

void rd_jq_external_jobs(rd_jq *q, int delta) { atomic_fetch_add(&q->external_jobs, delta); }

void rd_jq_metrics_get(rd_jq *q, rd_jq_metrics *m)
{
    pthread_mutex_lock(&q->mu);
    memset(m, 0, sizeof *m);
    for (rd_jq_job *j = q->active_head; j; j = j->next_active)
        m->waiting_memory += j->ph == PH_WAITING;
    m->queued = q->active_count - q->running_count;
    m->running = q->running_count;
    m->done = q->n_done;
    m->failed = q->n_failed;
    m->cancelled = q->n_cancelled;
    m->rays = q->rays;
    m->render_seconds = q->render;
    m->queue_wait_seconds = q->wait;
    m->result_bytes = q->result_bytes;
    m->jobs_kept = q->all.n;
    m->memory_budget = q->opt.memory_budget;
    m->memory_reserved = q->reserved;
    long long ext = atomic_load(&q->external);
    m->external_bytes = ext > 0 ? (size_t)ext : 0;
    int ejobs = atomic_load(&q->external_jobs);
    m->external_jobs = ejobs > 0 ? (size_t)ejobs : 0;
    pthread_mutex_unlock(&q->mu);
}

int rd_jq_wait_ended(rd_jq *q, rd_jq_job *j, double timeout_ms)
{
    double end = rd_now_ms() + timeout_ms;
    pthread_mutex_lock(&q->mu);
    while (!finished(j)) {
        double left = end - rd_now_ms();
        if (left <= 0)
            break;
        rd_timed_wait(&q->idle_cv, &q->mu, left);
    }
    int ended = finished(j);
    pthread_mutex_unlock(&q->mu);
    return ended;
}

int rd_jq_drain(rd_jq *q, double timeout_ms)
{
    double end = rd_now_ms() + timeout_ms;
    pthread_mutex_lock(&q->mu);
    while (q->active_count > 0) {
        double left = end - rd_now_ms();
        if (left <= 0)
            break;
        rd_timed_wait(&q->idle_cv, &q->mu, left);
    }
    int idle = q->active_count == 0;
    pthread_mutex_unlock(&q->mu);
    return idle;
}

void rd_jq_cancel_all(rd_jq *q)
{
    pthread_mutex_lock(&q->mu);
    for (rd_jq_job *j = q->active_head; j; j = j->next_active)
        if (!j->cancel)
            cancel_locked(q, j);
    pthread_mutex_unlock(&q->mu);
}
