#define _GNU_SOURCE /* POLLRDHUP */
#include "job_queue.h"

#include <math.h>
#include <poll.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include <sys/socket.h>
#include <time.h>

#include "job.h"

const double rd_jq_buckets[12] = {0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30};

enum { TILE_PENDING, TILE_RENDERING, TILE_DONE };

struct rd_jq_job {
    rd_jq *q;
    int refs;
    char id[24];
    rd_job_status status;
    rd_scene scene;
    rd_job *core;
    int preparing, finishing;
    int tiles_total, next_tile, tiles_done, inflight;
    uint64_t tiles_given;       /* over all passes: the fair-share key */
    unsigned char *tile_state;
    int samples;
    rd_progress_settings progress;
    int pass, spp;
    double pass_t0, last_pass_ms;
    int last_pass_spp;
    rd_stop_reason stopped_by;
    rd_curve_point curve[RD_CURVE_MAX];
    int curve_len;
    int cancel;                 /* asked to stop */
    int timed_out;
    int watch_fd;
    rd_jq_done_fn done;
    void *user;
    double t_submit, t_start, t_end;
    rd_job_counts counts;
    rd_render_stats stats;
    double error_estimate;
    unsigned char *png;
    size_t png_len;
    rd_error error;
    int active, registered;
    int sync;                   /* a waiting client takes the PNG: limits do not evict it */
    int hung_up;                /* cancelled because its client went away */
    int width, height;
    rd_jq_job *next_active, *next_all;
};

/* Finished jobs whose status stays readable, at most. */
enum { KEPT_MAX = 4096 };

struct rd_jq {
    pthread_mutex_t mu;
    pthread_cond_t work_cv, idle_cv;
    rd_jq_options opt;
    pthread_t *threads;
    int nthreads;
    int stopping;
    rd_jq_job *active_head, *active_tail;
    rd_jq_job *all;
    size_t active_count, running_count, kept, result_bytes;
    uint64_t counter, key;
    uint64_t n_done, n_failed, n_cancelled, rays, render_count;
    double render_sum;
    uint64_t buckets[12];
};

const char *rd_job_status_name(rd_job_status s)
{
    static const char *const names[] = {"queued", "running", "done", "failed", "cancelled"};
    return (unsigned)s < 5 ? names[s] : "?";
}

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

static uint64_t mix(uint64_t z)
{
    z += 0x9e3779b97f4a7c15ULL;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

static void job_free(rd_jq_job *j)
{
    rd_job_free(j->core);
    rd_scene_free(&j->scene);
    free(j->tile_state);
    free(j->png);
    free(j);
}

/* Under q->mu. */
static void unref_locked(rd_jq_job *j)
{
    if (--j->refs == 0)
        job_free(j);
}

void rd_jq_job_ref(rd_jq_job *j)
{
    pthread_mutex_lock(&j->q->mu);
    j->refs++;
    pthread_mutex_unlock(&j->q->mu);
}

void rd_jq_job_unref(rd_jq_job *j)
{
    rd_jq *q = j->q;
    pthread_mutex_lock(&q->mu);
    unref_locked(j);
    pthread_mutex_unlock(&q->mu);
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
        if (j->status == RD_JOB_RUNNING)
            q->running_count--;
    }
}

/* Drops finished jobs past their TTL, then the oldest results while over
 * the memory limit. Under q->mu. */
static void sweep(rd_jq *q)
{
    double now = now_ms();
    size_t finished = 0;
    for (rd_jq_job *j = q->all; j; j = j->next_all)
        finished += !j->active;
    for (rd_jq_job **pp = &q->all; *pp;) {
        rd_jq_job *j = *pp;
        /* The list is newest first: past KEPT_MAX finished ones, the oldest go. */
        int too_many = !j->active && finished > KEPT_MAX;
        if (!j->active && j->t_end > 0 && !(j->sync && j->png) &&
            (now - j->t_end > q->opt.result_ttl_ms || too_many)) {
            finished--;
            *pp = j->next_all;
            j->registered = 0;
            q->kept--;
            if (j->png) {
                q->result_bytes -= j->png_len;
                free(j->png);
                j->png = NULL;
            }
            unref_locked(j);
        } else {
            pp = &j->next_all;
        }
    }
    while (q->result_bytes > q->opt.result_memory) {
        rd_jq_job *oldest = NULL;
        for (rd_jq_job *j = q->all; j; j = j->next_all)
            if (j->png && !j->sync && (!oldest || j->t_end < oldest->t_end))
                oldest = j;
        if (!oldest)
            break;
        q->result_bytes -= oldest->png_len;
        free(oldest->png);
        oldest->png = NULL;
    }
}

/* The job leaves the active list with its final status; the caller then
 * calls its done callback without the lock. Under q->mu. */
static void finish_locked(rd_jq *q, rd_jq_job *j, rd_job_status st)
{
    remove_active(q, j);
    j->status = st;
    j->t_end = now_ms();
    if (st == RD_JOB_DONE) {
        q->n_done++;
        double sec = (j->t_end - j->t_start) / 1e3;
        q->render_sum += sec;
        q->render_count++;
        for (int b = 0; b < 12; b++)
            if (sec <= rd_jq_buckets[b])
                q->buckets[b]++;
    } else if (st == RD_JOB_FAILED) {
        q->n_failed++;
    } else {
        q->n_cancelled++;
    }
    q->rays += j->counts.camera + j->counts.shadow + j->counts.secondary;
    j->stats.camera_rays = j->counts.camera;
    j->stats.shadow_rays = j->counts.shadow;
    j->stats.secondary_rays = j->counts.secondary;
    j->stats.nonfinite = j->counts.nonfinite;
    j->stats.samples = j->samples;
    j->stats.wall_ms = j->t_start > 0 ? j->t_end - j->t_start : 0;
    uint64_t rays = j->counts.camera + j->counts.shadow + j->counts.secondary;
    j->stats.rays_per_second = j->stats.wall_ms > 0 ? rays / (j->stats.wall_ms / 1e3) : 0;
    j->stats.error_estimate = j->error_estimate;
    /* A job that did not finish gives its memory back at once. */
    if (st != RD_JOB_DONE) {
        rd_job_free(j->core);
        j->core = NULL;
        rd_scene_free(&j->scene);
    }
    j->watch_fd = -1;
    pthread_cond_broadcast(&q->idle_cv);
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

static int hung_up(int fd)
{
    struct pollfd p = {fd, POLLIN | POLLRDHUP, 0};
    if (poll(&p, 1, 0) <= 0)
        return 0;
    if (p.revents & (POLLRDHUP | POLLHUP | POLLERR | POLLNVAL))
        return 1;
    char c;
    return recv(fd, &c, 1, MSG_PEEK | MSG_DONTWAIT) == 0;
}

/* The last tile of a pass is done: estimate the error, add a curve point,
 * and start the next pass or encode the image. Outside the lock, with
 * j->finishing set so no other thread touches the job. Returns 1 when the
 * job ended. */
static int end_of_pass(rd_jq *q, rd_jq_job *j)
{
    double est = rd_job_error_estimate(j->core);
    double now = now_ms();
    j->spp += j->last_pass_spp;
    j->last_pass_ms = now - j->pass_t0;
    if (j->curve_len < RD_CURVE_MAX) {
        rd_curve_point *cp = &j->curve[j->curve_len++];
        cp->ms = now - j->t_start;
        cp->samples = j->progress.adaptive ? rd_job_mean_samples(j->core) : j->spp;
        cp->error = est;
    }
    rd_stop_reason why;
    int next = rd_progress_next(&j->progress, j->pass + 1, j->spp, j->last_pass_ms, j->last_pass_spp,
                                now - j->t_start, est, &why);
    if (next > 0) {
        rd_job_begin_pass(j->core, j->pass + 1, next);
        pthread_mutex_lock(&q->mu);
        j->error_estimate = est;
        j->pass++;
        j->last_pass_spp = next;
        j->pass_t0 = now_ms();
        j->next_tile = 0;
        j->tiles_done = 0;
        memset(j->tile_state, TILE_DONE, (size_t)j->tiles_total);
        j->finishing = 0;
        pthread_cond_broadcast(&q->work_cv);
        pthread_mutex_unlock(&q->mu);
        return 0;
    }
    j->stopped_by = why;
    int w = rd_job_width(j->core), h = rd_job_height(j->core);
    uint8_t *rgb = malloc((size_t)w * (size_t)h * 3);
    rd_error err = {0};
    unsigned char *png = NULL;
    size_t len = 0;
    rd_error_code rc = RD_ERR_NOMEM;
    if (rgb) {
        rd_job_rgb8(j->core, rgb);
        rc = rd_png_encode(rgb, w, h, &q->opt.png, &png, &len, &err);
        free(rgb);
    }
    double mean = rd_job_mean_samples(j->core);
    pthread_mutex_lock(&q->mu);
    j->finishing = 0;
    j->error_estimate = est;
    j->samples = (int)floor(mean + 0.5);
    if (rc) {
        j->error = err;
        finish_locked(q, j, RD_JOB_FAILED);
    } else {
        j->png = png;
        j->png_len = len;
        q->result_bytes += len;
        finish_locked(q, j, RD_JOB_DONE);
        rd_job_free(j->core);
        j->core = NULL;
        /* Only the status and the PNG outlive the render. */
        rd_scene_free(&j->scene);
        sweep(q);
    }
    pthread_mutex_unlock(&q->mu);
    return 1;
}

static void *worker(void *arg)
{
    rd_jq *q = arg;
    pthread_mutex_lock(&q->mu);
    while (!q->stopping) {
        rd_jq_job *pick = NULL, *ended = NULL;
        int tile = -1;
        double now = now_ms();
        for (rd_jq_job *j = q->active_head; j; j = j->next_active) {
            if (j->preparing || j->finishing)
                continue;
            if (!j->cancel && j->status == RD_JOB_RUNNING && q->opt.job_timeout_ms > 0 &&
                now - j->t_start > q->opt.job_timeout_ms) {
                j->cancel = 1;
                j->timed_out = 1;
            }
            if (!j->cancel && j->watch_fd >= 0 && hung_up(j->watch_fd)) {
                j->cancel = 1;
                j->hung_up = 1;
            }
            if (j->cancel) {
                if (j->inflight == 0) {
                    if (j->timed_out) {
                        rd_error_set(&j->error, RD_ERR_LIMIT, 0, 0,
                                     "the render took longer than the limit of %.0f ms (--job-timeout-ms)",
                                     q->opt.job_timeout_ms);
                        finish_locked(q, j, RD_JOB_FAILED);
                    } else {
                        finish_locked(q, j, RD_JOB_CANCELLED);
                    }
                    ended = j;
                    break;
                }
                continue;
            }
            /* Fair share: the next tile goes to the job that has been given
             * the fewest so far, the oldest on a tie. A lone job gets every
             * core; a small job arriving behind a large one starts at once
             * and finishes in about its own render time. */
            if ((j->status == RD_JOB_QUEUED || (j->status == RD_JOB_RUNNING && j->next_tile < j->tiles_total)) &&
                (!pick || j->tiles_given < pick->tiles_given))
                pick = j;
        }
        if (ended) {
            ended->refs++;
            pthread_mutex_unlock(&q->mu);
            call_done(ended);
            pthread_mutex_lock(&q->mu);
            unref_locked(ended);
            continue;
        }
        if (!pick) {
            pthread_cond_wait(&q->work_cv, &q->mu);
            continue;
        }
        rd_jq_job *j = pick;
        j->refs++;
        if (j->status == RD_JOB_QUEUED) {
            /* Build the plan (and BVH) outside the lock; other workers move on. */
            j->preparing = 1;
            j->t_start = now_ms();
            pthread_mutex_unlock(&q->mu);
            rd_job *core = NULL;
            rd_error err = {0};
            rd_job_options jo = {16, rd_progress_is_progressive(&j->progress), j->progress.adaptive};
            rd_error_code rc = rd_job_create(&j->scene, &jo, &core, &err);
            unsigned char *ts = NULL;
            if (!rc && !(ts = calloc((size_t)rd_job_tile_count(core), 1)))
                rc = rd_error_set(&err, RD_ERR_NOMEM, 0, 0, "out of memory");
            pthread_mutex_lock(&q->mu);
            j->preparing = 0;
            if (rc) {
                rd_job_free(core);
                j->error = err;
                finish_locked(q, j, RD_JOB_FAILED);
                pthread_mutex_unlock(&q->mu);
                call_done(j);
                pthread_mutex_lock(&q->mu);
            } else {
                j->core = core;
                if (q->opt.job_timeout_ms > 0)
                    rd_job_set_deadline(core, j->t_start + q->opt.job_timeout_ms);
                j->tile_state = ts;
                j->tiles_total = rd_job_tile_count(core);
                rd_stop_reason why;
                j->pass = 0;
                j->spp = 0;
                j->last_pass_spp = rd_progress_next(&j->progress, 0, 0, 0, 0, 0, 0, &why);
                j->pass_t0 = now_ms();
                rd_job_begin_pass(core, 0, j->last_pass_spp);
                rd_job_plan_stats(core, &j->stats);
                j->status = RD_JOB_RUNNING;
                q->running_count++;
                pthread_cond_broadcast(&q->work_cv);
            }
            unref_locked(j);
            continue;
        }
        tile = j->next_tile++;
        j->tiles_given++;
        j->tile_state[tile] = TILE_RENDERING;
        j->inflight++;
        pthread_mutex_unlock(&q->mu);
        rd_job_counts c = {0, 0, 0, 0};
        int complete = rd_job_render_tile(j->core, tile, &c);
        pthread_mutex_lock(&q->mu);
        if (!complete && !j->cancel) {
            /* The tile ran past the job's time limit. */
            j->cancel = 1;
            j->timed_out = 1;
        }
        j->tile_state[tile] = TILE_DONE;
        j->counts.camera += c.camera;
        j->counts.shadow += c.shadow;
        j->counts.secondary += c.secondary;
        j->counts.nonfinite += c.nonfinite;
        j->tiles_done++;
        j->inflight--;
        if (j->tiles_done == j->tiles_total && !j->cancel) {
            j->finishing = 1;
            pthread_mutex_unlock(&q->mu);
            if (end_of_pass(q, j))
                call_done(j);
            pthread_mutex_lock(&q->mu);
        } else if (j->cancel && j->inflight == 0) {
            pthread_cond_broadcast(&q->work_cv); /* someone ends it */
        }
        unref_locked(j);
    }
    pthread_mutex_unlock(&q->mu);
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
    if (q->opt.workers < 1)
        q->opt.workers = 1;
    pthread_mutex_init(&q->mu, NULL);
    pthread_cond_init(&q->work_cv, NULL);
    pthread_cond_init(&q->idle_cv, NULL);
    if (getrandom(&q->key, sizeof q->key, 0) != (ssize_t)sizeof q->key)
        q->key = (uint64_t)now_ms() * 0x2545f4914f6cdd1dULL;
    q->threads = calloc((size_t)q->opt.workers, sizeof *q->threads);
    if (!q->threads) {
        free(q);
        rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
        return NULL;
    }
    for (int i = 0; i < q->opt.workers; i++) {
        if (pthread_create(&q->threads[i], NULL, worker, q) != 0)
            break;
        q->nthreads++;
    }
    if (q->nthreads == 0) {
        free(q->threads);
        free(q);
        rd_error_set(err, RD_ERR_NOMEM, 0, 0, "cannot start render threads");
        return NULL;
    }
    return q;
}

void rd_jq_stop(rd_jq *q)
{
    if (!q)
        return;
    rd_jq_cancel_all(q);
    pthread_mutex_lock(&q->mu);
    q->stopping = 1;
    pthread_cond_broadcast(&q->work_cv);
    pthread_mutex_unlock(&q->mu);
    for (int i = 0; i < q->nthreads; i++)
        pthread_join(q->threads[i], NULL);
    /* Jobs still active were cancelled but never reached by a worker. */
    while (q->active_head) {
        rd_jq_job *j = q->active_head;
        finish_locked(q, j, RD_JOB_CANCELLED);
        call_done(j);
    }
    while (q->all) {
        rd_jq_job *j = q->all;
        q->all = j->next_all;
        unref_locked(j);
    }
    free(q->threads);
    pthread_mutex_destroy(&q->mu);
    pthread_cond_destroy(&q->work_cv);
    pthread_cond_destroy(&q->idle_cv);
    free(q);
}

rd_error_code rd_jq_submit(rd_jq *q, rd_scene *scene, const rd_progress_settings *progress, int watch_fd,
                           rd_jq_done_fn done, void *user, rd_jq_job **out, rd_error *err)
{
    *out = NULL;
    rd_jq_job *j = calloc(1, sizeof *j);
    if (!j) {
        rd_scene_free(scene);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    }
    j->q = q;
    j->scene = *scene;
    memset(scene, 0, sizeof *scene);
    j->samples = j->scene.render.samples < 1 ? 1 : j->scene.render.samples;
    j->width = j->scene.render.width;
    j->height = j->scene.render.height;
    j->sync = done != NULL;
    if (progress)
        j->progress = *progress;
    j->progress.max_samples = j->samples;
    j->watch_fd = watch_fd;
    j->done = done;
    j->user = user;
    j->t_submit = now_ms();
    pthread_mutex_lock(&q->mu);
    sweep(q);
    if (q->stopping || q->active_count >= q->opt.queue_length) {
        pthread_mutex_unlock(&q->mu);
        rd_scene_free(&j->scene);
        free(j);
        return rd_error_set(err, RD_ERR_LIMIT, 0, 0, "the render queue is full (%zu jobs, --queue)",
                            q->opt.queue_length);
    }
    snprintf(j->id, sizeof j->id, "%016llx", (unsigned long long)mix(q->key ^ ++q->counter));
    j->refs = 2; /* the registry's and the caller's */
    j->status = RD_JOB_QUEUED;
    j->active = 1;
    j->registered = 1;
    if (q->active_tail)
        q->active_tail->next_active = j;
    else
        q->active_head = j;
    q->active_tail = j;
    q->active_count++;
    j->next_all = q->all;
    q->all = j;
    q->kept++;
    pthread_cond_broadcast(&q->work_cv);
    pthread_mutex_unlock(&q->mu);
    *out = j;
    return RD_OK;
}

rd_jq_job *rd_jq_find(rd_jq *q, const char *id)
{
    pthread_mutex_lock(&q->mu);
    sweep(q);
    rd_jq_job *found = NULL;
    for (rd_jq_job *j = q->all; j; j = j->next_all)
        if (strcmp(j->id, id) == 0) {
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
    pthread_mutex_unlock(&q->mu);
}

int rd_jq_cancel(rd_jq *q, rd_jq_job *j)
{
    pthread_mutex_lock(&q->mu);
    int live = j->active;
    if (live) {
        j->cancel = 1;
        j->watch_fd = -1;
        pthread_cond_broadcast(&q->work_cv);
    }
    pthread_mutex_unlock(&q->mu);
    return live;
}

void rd_jq_info_get(rd_jq *q, rd_jq_job *j, rd_jq_info *out)
{
    pthread_mutex_lock(&q->mu);
    memset(out, 0, sizeof *out);
    snprintf(out->id, sizeof out->id, "%s", j->id);
    out->status = j->status;
    out->progress = j->status == RD_JOB_DONE ? 1.0
                    : j->tiles_total > 0     ? (double)j->tiles_done / j->tiles_total
                                             : 0;
    if (j->status == RD_JOB_RUNNING && rd_progress_is_progressive(&j->progress)) {
        /* Progress of a progressive job: samples toward the cap, or time toward the budget. */
        double by_spp = (j->spp + (double)j->last_pass_spp * j->tiles_done / (j->tiles_total ? j->tiles_total : 1)) /
                        j->progress.max_samples;
        double by_time = j->progress.time_budget_ms > 0 ? (now_ms() - j->t_start) / j->progress.time_budget_ms : 0;
        out->progress = by_spp > by_time ? by_spp : by_time;
        if (out->progress > 0.99)
            out->progress = 0.99;
    }
    double now = now_ms();
    out->elapsed_ms = j->t_start > 0 ? (j->t_end > 0 ? j->t_end : now) - j->t_start : 0;
    out->queued_ms = (j->t_start > 0 ? j->t_start : now) - j->t_submit;
    out->samples = j->status == RD_JOB_DONE ? j->samples : j->spp;
    out->stopped_by = j->stopped_by;
    out->passes = j->pass + (j->status == RD_JOB_DONE ? 1 : 0);
    out->curve_len = j->curve_len;
    memcpy(out->curve, j->curve, sizeof j->curve);
    out->error_estimate = j->error_estimate;
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
    if (!partial || j->status != RD_JOB_RUNNING || !j->core || j->finishing) {
        rd_job_status st = j->status;
        pthread_mutex_unlock(&q->mu);
        if (st == RD_JOB_DONE)
            return rd_error_set(err, RD_ERR_INVALID, 0, 0, "the image has expired (--result-memory)");
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "job is %s: no image yet", rd_job_status_name(st));
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

void rd_jq_release_png(rd_jq *q, rd_jq_job *j)
{
    pthread_mutex_lock(&q->mu);
    if (j->png) {
        q->result_bytes -= j->png_len;
        free(j->png);
        j->png = NULL;
    }
    j->sync = 0;
    pthread_mutex_unlock(&q->mu);
}

void rd_jq_metrics_get(rd_jq *q, rd_jq_metrics *m)
{
    pthread_mutex_lock(&q->mu);
    m->queued = q->active_count - q->running_count;
    m->running = q->running_count;
    m->done = q->n_done;
    m->failed = q->n_failed;
    m->cancelled = q->n_cancelled;
    m->rays = q->rays;
    m->render_seconds_sum = q->render_sum;
    m->render_count = q->render_count;
    memcpy(m->render_seconds_bucket, q->buckets, sizeof q->buckets);
    m->result_bytes = q->result_bytes;
    m->jobs_kept = q->kept;
    pthread_mutex_unlock(&q->mu);
}

int rd_jq_drain(rd_jq *q, double timeout_ms)
{
    double end = now_ms() + timeout_ms;
    pthread_mutex_lock(&q->mu);
    while (q->active_count > 0) {
        double left = end - now_ms();
        if (left <= 0)
            break;
        struct timespec ts;
        clock_gettime(CLOCK_REALTIME, &ts);
        long long ns = ts.tv_nsec + (long long)(left * 1e6);
        ts.tv_sec += ns / 1000000000LL;
        ts.tv_nsec = ns % 1000000000LL;
        pthread_cond_timedwait(&q->idle_cv, &q->mu, &ts);
    }
    int idle = q->active_count == 0;
    pthread_mutex_unlock(&q->mu);
    return idle;
}

void rd_jq_cancel_all(rd_jq *q)
{
    pthread_mutex_lock(&q->mu);
    for (rd_jq_job *j = q->active_head; j; j = j->next_active) {
        j->cancel = 1;
        j->watch_fd = -1;
    }
    pthread_cond_broadcast(&q->work_cv);
    pthread_mutex_unlock(&q->mu);
}
