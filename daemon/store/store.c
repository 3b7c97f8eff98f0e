/* The store's entry points: arguments and limits are checked here, once, so
 * both engines refuse the same inputs with the same messages; then the
 * operation (store_ops.c) runs with the handle's mutex held. */
#include "store.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "store_internal.h"
#include "utf8.h"

#define MIB ((size_t)1 << 20)

/* The engines always get somewhere to write their error. */
#define USE_ERR(err)                                                                                                   \
    rd_error local_err_;                                                                                               \
    if (!(err))                                                                                                        \
    (err) = &local_err_

rd_store_options rd_store_options_default(void)
{
    rd_store_options o;
    memset(&o, 0, sizeof o);
    o.limits.scene_bytes = 16 * MIB;
    o.limits.text_bytes = MIB;
    o.limits.image_bytes = 256 * MIB;
    o.limits.tile_bytes = 16 * MIB;
    o.limits.tiles = 1 << 20;
    o.limits.passes = 65536;
    o.timeout_ms = 5000;
    o.sync_full = 1;
    return o;
}

static const char *const status_names[RD_STORE_STATUS_COUNT] = {"queued", "running", "done", "failed", "cancelled"};

const char *rd_store_status_name(rd_store_status st)
{
    return (unsigned)st < RD_STORE_STATUS_COUNT ? status_names[st] : "?";
}

static const char *const batch_status_names[] = {"running", "done", "cancelled"};

#define BATCH_STATUS_COUNT ((int)(sizeof batch_status_names / sizeof batch_status_names[0]))

const char *rd_store_batch_status_name(rd_store_batch_status st)
{
    return (unsigned)st < (unsigned)BATCH_STATUS_COUNT ? batch_status_names[st] : "?";
}

int rd_store_batch_status_parse(const char *name)
{
    for (int i = 0; name && i < BATCH_STATUS_COUNT; i++)
        if (strcmp(name, batch_status_names[i]) == 0)
            return i;
    return -1;
}

int rd_store_status_parse(const char *name)
{
    for (int i = 0; name && i < RD_STORE_STATUS_COUNT; i++)
        if (strcmp(name, status_names[i]) == 0)
            return i;
    return -1;
}

void *rd_store_dup(const void *data, size_t len)
{
    char *p = malloc(len + 1);
    if (p) {
        if (len)
            memcpy(p, data, len);
        p[len] = '\0';
    }
    return p;
}

/* "postgresql://", "postgres://", or a conninfo's first KEY=. */
static int is_postgres_spec(const char *spec)
{
    if (strncmp(spec, "postgresql://", 13) == 0 || strncmp(spec, "postgres://", 11) == 0)
        return 1;
    size_t k = strspn(spec, "abcdefghijklmnopqrstuvwxyz_");
    while (spec[k] == ' ')
        k++;
    return k > 0 && spec[k] == '=';
}

rd_store *rd_store_open(const char *spec, const rd_store_options *opt, rd_error *err)
{
    USE_ERR(err);
    rd_store_options o = opt ? *opt : rd_store_options_default();
    if (!spec || !*spec) {
        rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: no folder or PostgreSQL URL given");
        return NULL;
    }
    if (o.timeout_ms <= 0) {
        rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: the timeout must be positive, not %d ms", o.timeout_ms);
        return NULL;
    }
    rd_store *s = is_postgres_spec(spec) ? rd_store_pg_open(spec, &o, err) : rd_store_sqlite_open(spec, &o, err);
    if (s && pthread_mutex_init(&s->lock, NULL) != 0) {
        s->drv->close(s);
        rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no mutex");
        return NULL;
    }
    return s;
}

void rd_store_close(rd_store *s)
{
    if (!s)
        return;
    pthread_mutex_destroy(&s->lock);
    s->drv->close(s);
}

const char *rd_store_engine_name(const rd_store *s) { return s->drv->name; }

/* Checks: ids, texts, sizes. Each returns RD_OK or sets err. */

static rd_error_code check_id(const char *what, const char *id, rd_error *err)
{
    size_t n = id ? strlen(id) : 0;
    if (n == 0 || n >= RD_STORE_ID_MAX ||
        strspn(id, "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789._:-") != n)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: %s must be 1 to %d of A-Z a-z 0-9 . _ : -", what,
                            RD_STORE_ID_MAX - 1);
    return RD_OK;
}

/* NULL is fine; else valid UTF-8 (so that PostgreSQL takes it as text)
 * within the text limit. */
static rd_error_code check_text(const rd_store *s, const char *what, const char *text, rd_error *err)
{
    if (!text)
        return RD_OK;
    size_t n = strlen(text);
    if (n > s->opt.limits.text_bytes)
        return rd_error_set(err, RD_ERR_LIMIT, 0, 0, "store: %s has %zu bytes, over the limit of %zu", what, n,
                            s->opt.limits.text_bytes);
    if (rd_utf8_invalid_at(text, n) != n)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: %s is not UTF-8", what);
    return RD_OK;
}

static rd_error_code check_bytes(const char *what, const void *data, size_t len, size_t limit, rd_error *err)
{
    if (len > limit)
        return rd_error_set(err, RD_ERR_LIMIT, 0, 0, "store: %s has %zu bytes, over the limit of %zu", what, len,
                            limit);
    if (len && !data)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: %s of %zu bytes is NULL", what, len);
    return RD_OK;
}

static rd_error_code check_count(const char *what, int n, int limit, rd_error *err)
{
    if (n < 1 || n > limit)
        return rd_error_set(err, n < 1 ? RD_ERR_INVALID : RD_ERR_LIMIT, 0, 0, "store: %d %s, not within 1..%d", n, what,
                            limit);
    return RD_OK;
}

static rd_error_code check_spec(const rd_store *s, const rd_store_job_spec *j, rd_error *err)
{
    rd_error_code c = check_id("a job id", j->id, err);
    if (!c)
        c = check_bytes("the scene", j->scene, j->scene_len, s->opt.limits.scene_bytes, err);
    if (!c && (!j->format || (strcmp(j->format, "cfg") != 0 && strcmp(j->format, "json") != 0)))
        c = rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: a scene's format is cfg or json");
    if (!c)
        c = check_text(s, "the query", j->query, err);
    if (!c)
        c = check_text(s, "the schedule", j->schedule, err);
    if (!c && (j->width < 0 || j->height < 0 || j->memory_bytes < 0 || j->tiles < 0 || j->passes < 0))
        c = rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: negative size, memory or tile count");
    if (!c && (j->tiles > 0 || j->passes > 0)) {
        c = check_count("tiles", j->tiles, s->opt.limits.tiles, err);
        if (!c)
            c = check_count("passes", j->passes, s->opt.limits.passes, err);
    }
    return c;
}

/* An assignment or a student: UTF-8 of at most RD_STORE_NAME_MAX - 1
 * bytes; empty (or NULL) only when empty_ok. */
static rd_error_code check_name(const char *what, const char *name, int empty_ok, rd_error *err)
{
    size_t n = name ? strlen(name) : 0;
    if (n == 0 && !empty_ok)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: %s is empty", what);
    if (n >= RD_STORE_NAME_MAX)
        return rd_error_set(err, RD_ERR_LIMIT, 0, 0, "store: %s has %zu bytes, over the limit of %d", what, n,
                            RD_STORE_NAME_MAX - 1);
    if (rd_utf8_invalid_at(name ? name : "", n) != n)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: %s is not UTF-8", what);
    return RD_OK;
}

static rd_error_code check_metrics(const rd_store_grade *g, rd_error *err)
{
    const double v[4] = {g->failed_fraction, g->max_abs, g->psnr_db, g->ssim};
    static const char *const names[4] = {"failed_fraction", "max_abs", "psnr_db", "ssim"};
    for (int i = 0; i < 4; i++)
        if (!isfinite(v[i]))
            return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: grade %s: %s is not a finite number", g->id,
                                names[i]);
    return RD_OK;
}

/* The term's fields: a known kind, a lateness, a score within its points
 * or neither. */
static rd_error_code check_term(const rd_store_grade *g, rd_error *err)
{
    if (g->kind && strcmp(g->kind, "image") != 0 && strcmp(g->kind, "code") != 0)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: grade %s: kind is image or code", g->id);
    if (g->late_ms < 0)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: grade %s: late by %lld ms", g->id,
                            (long long)g->late_ms);
    int scored = isfinite(g->points) && g->points > 0;
    if (scored ? !(g->score >= 0 && g->score <= g->points) : !(isnan(g->points) || g->points == 0))
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: grade %s: a score is within its points (> 0)", g->id);
    return RD_OK;
}

/* A graded grade has its metrics, verdict and reference; one that could
 * not be graded has its message instead, did not pass and has no diff. */
static rd_error_code check_grade(const rd_store *s, const rd_store_grade *g, const unsigned char *diff, size_t len,
                                 rd_error *err)
{
    if (!g)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: no grade given");
    rd_error_code c = check_id("a grade id", g->id, err);
    if (!c && g->batch_id)
        c = check_id("a batch id", g->batch_id, err);
    if (!c)
        c = check_name("the assignment", g->assignment, 0, err);
    if (!c)
        c = check_name("the student", g->student, 1, err);
    if (!c && g->graded_ms < 0)
        c = rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: grade %s graded at %lld ms", g->id,
                         (long long)g->graded_ms);
    if (!c)
        c = check_term(g, err);
    if (!c && g->regrade_of)
        c = check_id("the regraded grade's id", g->regrade_of, err);
    if (!c)
        c = check_text(s, "the verdict", g->verdict, err);
    if (!c)
        c = check_text(s, "the reference key", g->reference_key, err);
    if (!c)
        c = check_text(s, "the error message", g->error, err);
    if (!c)
        c = check_bytes("the diff PNG", diff, len, s->opt.limits.image_bytes, err);
    if (!c && diff && !len)
        c = rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: grade %s: an empty diff PNG", g->id);
    if (c)
        return c;
    if (!g->error) {
        if (!g->verdict || !g->reference_key)
            return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: grade %s needs its verdict and reference key",
                                g->id);
        return check_metrics(g, err);
    }
    if (!g->error[0])
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: grade %s: an empty error message", g->id);
    if (g->pass)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: grade %s could not be graded: it did not pass", g->id);
    if (diff)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: grade %s could not be graded: it has no diff", g->id);
    return RD_OK;
}

static rd_error_code check_lease(int lease_ms, rd_error *err)
{
    if (lease_ms < 1)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: a lease of %d ms", lease_ms);
    return RD_OK;
}

/* The calls: check, lock, run. */

#define LOCKED(s, call)                                                                                                \
    do {                                                                                                               \
        pthread_mutex_lock(&(s)->lock);                                                                                \
        rd_error_code c_ = (call);                                                                                     \
        pthread_mutex_unlock(&(s)->lock);                                                                              \
        return c_;                                                                                                     \
    } while (0)

#define CHECKED(check)                                                                                                 \
    do {                                                                                                               \
        rd_error_code c_ = (check);                                                                                    \
        if (c_)                                                                                                        \
            return c_;                                                                                                 \
    } while (0)

rd_error_code rd_store_ping(rd_store *s, rd_error *err)
{
    USE_ERR(err);
    LOCKED(s, rd_store_op_ping(s, err));
}

rd_error_code rd_store_job_create(rd_store *s, const rd_store_job_spec *spec, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_spec(s, spec, err));
    LOCKED(s, rd_store_op_job_create(s, spec, err));
}

rd_error_code rd_store_job_get(rd_store *s, const char *id, rd_store_job_info *out, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a job id", id, err));
    LOCKED(s, rd_store_op_job_get(s, id, out, err));
}

void rd_store_job_info_free(rd_store_job_info *info)
{
    free(info->stats);
    free(info->schedule);
    info->stats = info->schedule = NULL;
}

rd_error_code rd_store_job_input_get(rd_store *s, const char *id, rd_store_job_input *out, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a job id", id, err));
    LOCKED(s, rd_store_op_job_input(s, id, out, err));
}

void rd_store_job_input_free(rd_store_job_input *in)
{
    free(in->scene);
    free(in->query);
    in->scene = in->query = NULL;
}

rd_error_code rd_store_job_start(rd_store *s, const char *id, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a job id", id, err));
    LOCKED(s, rd_store_op_job_start(s, id, err));
}

rd_error_code rd_store_job_stats(rd_store *s, const char *id, const char *stats, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a job id", id, err));
    CHECKED(check_text(s, "the statistics", stats, err));
    LOCKED(s, rd_store_op_job_stats(s, id, stats, err));
}

/* A job that had ended already is RD_ERR_CANCELLED for finish and fail. */
static rd_error_code end_job(rd_store *s, const char *id, rd_store_status to, const rd_error *why,
                             const rd_store_result *r, int *changed, rd_error *err)
{
    int ch = 0;
    pthread_mutex_lock(&s->lock);
    rd_error_code c = rd_store_op_job_end(s, id, to, why, r, &ch, err);
    pthread_mutex_unlock(&s->lock);
    if (c == RD_OK && !ch && to != RD_STORE_CANCELLED)
        c = rd_error_set(err, RD_ERR_CANCELLED, 0, 0, "store: job %s has ended already", id);
    if (c == RD_OK && changed)
        *changed = ch;
    return c;
}

rd_error_code rd_store_job_finish(rd_store *s, const char *id, const rd_store_result *r, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a job id", id, err));
    if (!r || !r->png || !r->png_len)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: a finished job needs its PNG");
    CHECKED(check_bytes("the PNG", r->png, r->png_len, s->opt.limits.image_bytes, err));
    CHECKED(check_bytes("the EXR", r->exr, r->exr_len, s->opt.limits.image_bytes, err));
    CHECKED(check_text(s, "the statistics", r->stats, err));
    return end_job(s, id, RD_STORE_DONE, NULL, r, NULL, err);
}

rd_error_code rd_store_job_fail(rd_store *s, const char *id, const rd_error *why, const char *stats, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a job id", id, err));
    if (!why || why->code == RD_OK || (unsigned)why->code >= RD_ERROR_COUNT)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: a failed job needs an error code");
    CHECKED(check_text(s, "the error message", why->message, err));
    CHECKED(check_text(s, "the statistics", stats, err));
    rd_store_result r = {.stats = stats};
    return end_job(s, id, RD_STORE_FAILED, why, &r, NULL, err);
}

rd_error_code rd_store_job_cancel(rd_store *s, const char *id, int *changed, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a job id", id, err));
    return end_job(s, id, RD_STORE_CANCELLED, NULL, NULL, changed, err);
}

rd_error_code rd_store_job_delete(rd_store *s, const char *id, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a job id", id, err));
    LOCKED(s, rd_store_op_job_delete(s, id, err));
}

rd_error_code rd_store_job_image(rd_store *s, const char *id, rd_store_image_kind kind, unsigned char **data,
                                 size_t *len, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a job id", id, err));
    if (kind != RD_STORE_PNG && kind != RD_STORE_EXR)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: no image kind %d", (int)kind);
    LOCKED(s, rd_store_op_job_image(s, id, kind, data, len, err));
}

rd_error_code rd_store_jobs_list(rd_store *s, unsigned mask, size_t max, rd_store_job_brief **out, size_t *n,
                                 rd_error *err)
{
    USE_ERR(err);
    mask &= (1u << RD_STORE_STATUS_COUNT) - 1;
    if (!mask || !max) {
        *out = NULL;
        *n = 0;
        return RD_OK;
    }
    LOCKED(s, rd_store_op_jobs_list(s, mask, max, out, n, err));
}

rd_error_code rd_store_jobs_expire(rd_store *s, int64_t ttl_ms, size_t *deleted, rd_error *err)
{
    USE_ERR(err);
    size_t d = 0;
    if (ttl_ms < 0)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: a negative TTL");
    pthread_mutex_lock(&s->lock);
    rd_error_code c = rd_store_op_jobs_expire(s, ttl_ms, &d, err);
    pthread_mutex_unlock(&s->lock);
    if (c == RD_OK && deleted)
        *deleted = d;
    return c;
}

rd_error_code rd_store_tiles_init(rd_store *s, const char *id, int tiles, int passes, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a job id", id, err));
    CHECKED(check_count("tiles", tiles, s->opt.limits.tiles, err));
    CHECKED(check_count("passes", passes, s->opt.limits.passes, err));
    LOCKED(s, rd_store_op_tiles_init(s, id, tiles, passes, err));
}

rd_error_code rd_store_claim_where(rd_store *s, const char *daemon, int max, int lease_ms,
                                   const rd_store_claim_filter *filter, rd_store_tile *out, int *n, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a daemon id", daemon, err));
    CHECKED(check_lease(lease_ms, err));
    CHECKED(check_count("tiles to claim", max, s->opt.limits.tiles, err));
    if (filter && filter->job_id)
        CHECKED(check_id("a job id", filter->job_id, err));
    rd_store_claim_filter any = {NULL, 0};
    LOCKED(s, rd_store_op_claim(s, daemon, max, lease_ms, filter ? filter : &any, out, n, err));
}

rd_error_code rd_store_claim(rd_store *s, const char *daemon, int max, int lease_ms, rd_store_tile *out, int *n,
                             rd_error *err)
{
    return rd_store_claim_where(s, daemon, max, lease_ms, NULL, out, n, err);
}

static rd_error_code leases(rd_store *s, const char *daemon, int lease_ms, int *count, rd_error *err)
{
    int k = 0;
    CHECKED(check_id("a daemon id", daemon, err));
    pthread_mutex_lock(&s->lock);
    rd_error_code c = rd_store_op_leases(s, daemon, lease_ms, &k, err);
    pthread_mutex_unlock(&s->lock);
    if (c == RD_OK && count)
        *count = k;
    return c;
}

rd_error_code rd_store_renew(rd_store *s, const char *daemon, int lease_ms, int *renewed, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_lease(lease_ms, err));
    return leases(s, daemon, lease_ms, renewed, err);
}

rd_error_code rd_store_release(rd_store *s, const char *daemon, int *released, rd_error *err)
{
    USE_ERR(err);
    return leases(s, daemon, -1, released, err);
}

rd_error_code rd_store_tile_done(rd_store *s, const char *daemon, const rd_store_tile *t, const void *data, size_t len,
                                 rd_store_tile_outcome *outcome, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a daemon id", daemon, err));
    CHECKED(check_id("a job id", t->job_id, err));
    CHECKED(check_bytes("a tile's result", data, len, s->opt.limits.tile_bytes, err));
    if (t->index < 0 || t->pass < 0)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: tile %d of pass %d", t->index, t->pass);
    rd_store_tile_outcome o;
    pthread_mutex_lock(&s->lock);
    rd_error_code c = rd_store_op_tile_done(s, daemon, t, data, len, &o, err);
    pthread_mutex_unlock(&s->lock);
    if (c == RD_OK && outcome)
        *outcome = o;
    return c;
}

rd_error_code rd_store_pass_open(rd_store *s, const char *id, int pass, const char *schedule, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a job id", id, err));
    /* Pass 0 of a gated job is open from the start: nobody opens it. */
    if (pass < 1)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: pass %d is not one to open (1 or later)", pass);
    CHECKED(check_text(s, "the schedule", schedule, err));
    LOCKED(s, rd_store_op_pass_open(s, id, pass, schedule, err));
}

rd_error_code rd_store_tiles_get(rd_store *s, const char *id, rd_store_tile_data **out, size_t *n, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a job id", id, err));
    LOCKED(s, rd_store_op_tiles_get(s, id, -1, out, n, err));
}

rd_error_code rd_store_tile_get(rd_store *s, const char *id, int index, rd_store_tile_data *out, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a job id", id, err));
    if (index < 0)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: tile %d", index);
    rd_store_tile_data *t = NULL;
    size_t n = 0;
    pthread_mutex_lock(&s->lock);
    rd_error_code c = rd_store_op_tiles_get(s, id, index, &t, &n, err);
    pthread_mutex_unlock(&s->lock);
    if (c == RD_OK && n == 0)
        c = rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: job %s has no tile %d", id, index);
    if (c == RD_OK)
        *out = t[0];
    free(t);
    return c;
}

void rd_store_tiles_free(rd_store_tile_data *t, size_t n)
{
    for (size_t i = 0; t && i < n; i++)
        free(t[i].data);
    free(t);
}

rd_error_code rd_store_wait(rd_store *s, int timeout_ms, rd_store_event *ev, rd_error *err)
{
    USE_ERR(err);
    memset(ev, 0, sizeof *ev);
    return s->drv->wait(s, timeout_ms < 0 ? 0 : timeout_ms, ev, err);
}

/* Grades and batches. */

rd_error_code rd_store_grade_put(rd_store *s, const rd_store_grade *g, const unsigned char *diff_png, size_t len,
                                 rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_grade(s, g, diff_png, len, err));
    rd_store_grade n = *g;
    n.student = g->student ? g->student : "";
    n.pass = g->error ? 0 : g->pass != 0;
    n.kind = g->kind ? g->kind : "image";
    n.submitted_ms = g->submitted_ms <= 0 ? g->graded_ms : g->submitted_ms;
    n.closed = g->closed != 0;
    LOCKED(s, rd_store_op_grade_put(s, &n, diff_png, len, err));
}

rd_error_code rd_store_grade_get(rd_store *s, const char *id, rd_store_grade *out, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a grade id", id, err));
    LOCKED(s, rd_store_op_grade_get(s, id, out, err));
}

void rd_store_grade_free(rd_store_grade *g)
{
    const char **texts[] = {&g->id,    &g->batch_id, &g->assignment, &g->student, &g->verdict, &g->reference_key,
                            &g->error, &g->kind,     &g->regrade_of};
    for (size_t i = 0; i < sizeof texts / sizeof texts[0]; i++) {
        free((void *)*texts[i]);
        *texts[i] = NULL;
    }
}

void rd_store_grades_free(rd_store_grade *g, size_t n)
{
    for (size_t i = 0; g && i < n; i++)
        rd_store_grade_free(&g[i]);
    free(g);
}

rd_error_code rd_store_grade_image(rd_store *s, const char *id, rd_store_grade_image_kind kind, unsigned char **data,
                                   size_t *len, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a grade id", id, err));
    if (kind != RD_STORE_GRADE_DIFF && kind != RD_STORE_GRADE_IMAGE)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: no grade image kind %d", (int)kind);
    LOCKED(s, rd_store_op_grade_image(s, id, kind, data, len, err));
}

rd_error_code rd_store_grade_image_put(rd_store *s, const char *id, rd_store_grade_image_kind kind,
                                       const unsigned char *data, size_t len, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a grade id", id, err));
    if (kind != RD_STORE_GRADE_DIFF && kind != RD_STORE_GRADE_IMAGE)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: no grade image kind %d", (int)kind);
    CHECKED(check_bytes("a grade's image", data, len, s->opt.limits.image_bytes, err));
    if (!data || !len)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: grade %s: an empty image", id);
    LOCKED(s, rd_store_op_grade_image_put(s, id, kind, data, len, err));
}

rd_error_code rd_store_grades_list(rd_store *s, const rd_store_grade_filter *f, rd_store_grade **out, size_t *n,
                                   rd_error *err)
{
    USE_ERR(err);
    rd_store_grade_filter all = {NULL, NULL, NULL, INT64_MIN, SIZE_MAX};
    if (!f)
        f = &all;
    if (f->assignment)
        CHECKED(check_name("the assignment", f->assignment, 0, err));
    if (f->student)
        CHECKED(check_name("the student", f->student, 1, err));
    if (f->batch_id)
        CHECKED(check_id("a batch id", f->batch_id, err));
    if (!f->max) {
        *out = NULL;
        *n = 0;
        return RD_OK;
    }
    LOCKED(s, rd_store_op_grades_list(s, f, out, n, err));
}

rd_error_code rd_store_grades_expire(rd_store *s, int64_t ttl_ms, size_t *deleted, rd_error *err)
{
    USE_ERR(err);
    size_t d = 0;
    if (ttl_ms < 0)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: a negative TTL");
    pthread_mutex_lock(&s->lock);
    rd_error_code c = rd_store_op_grades_expire(s, ttl_ms, &d, err);
    pthread_mutex_unlock(&s->lock);
    if (c == RD_OK && deleted)
        *deleted = d;
    return c;
}

rd_error_code rd_store_batch_create(rd_store *s, const char *id, const char *assignment, int total, const char *daemon,
                                    const char *students, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a batch id", id, err));
    CHECKED(check_name("the assignment", assignment, 0, err));
    if (daemon && *daemon)
        CHECKED(check_id("a daemon id", daemon, err));
    CHECKED(check_text(s, "the students", students, err));
    if (total < 1)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: a batch of %d grades", total);
    LOCKED(s, rd_store_op_batch_create(s, id, assignment, total, daemon ? daemon : "", students ? students : "", err));
}

rd_error_code rd_store_batches_running(rd_store *s, const char *daemon, size_t max, rd_store_batch **out, size_t *n,
                                       rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a daemon id", daemon, err));
    if (!max) {
        *out = NULL;
        *n = 0;
        return RD_OK;
    }
    LOCKED(s, rd_store_op_batches_running(s, daemon, max, out, n, err));
}

rd_error_code rd_store_batch_students(rd_store *s, const char *id, char **students, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a batch id", id, err));
    LOCKED(s, rd_store_op_batch_students(s, id, students, err));
}

rd_error_code rd_store_batch_get(rd_store *s, const char *id, rd_store_batch *out, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a batch id", id, err));
    LOCKED(s, rd_store_op_batch_get(s, id, out, err));
}

rd_error_code rd_store_batch_cancel(rd_store *s, const char *id, int *changed, rd_error *err)
{
    USE_ERR(err);
    int ch = 0;
    CHECKED(check_id("a batch id", id, err));
    pthread_mutex_lock(&s->lock);
    rd_error_code c = rd_store_op_batch_cancel(s, id, &ch, err);
    pthread_mutex_unlock(&s->lock);
    if (c == RD_OK && changed)
        *changed = ch;
    return c;
}

rd_error_code rd_store_batches_list(rd_store *s, const rd_store_batch_filter *f, rd_store_batch **out, size_t *n,
                                    rd_error *err)
{
    USE_ERR(err);
    rd_store_batch_filter all = {NULL, 0, SIZE_MAX};
    if (!f)
        f = &all;
    if (f->assignment)
        CHECKED(check_name("the assignment", f->assignment, 0, err));
    if (!f->max) {
        *out = NULL;
        *n = 0;
        return RD_OK;
    }
    LOCKED(s, rd_store_op_batches_list(s, f, out, n, err));
}

/* Runs a deletion, and gives its ids only to a caller that wants them. */
static rd_error_code deleted(rd_store *s, const char *column, const char *value, rd_store_grade_id **ids, size_t *n,
                             rd_error *err)
{
    rd_store_grade_id *list = NULL;
    size_t k = 0;
    pthread_mutex_lock(&s->lock);
    rd_error_code c = column ? rd_store_op_grades_delete(s, column, value, &list, &k, err)
                             : rd_store_op_batch_delete(s, value, &list, &k, err);
    pthread_mutex_unlock(&s->lock);
    if (c)
        return c;
    if (ids)
        *ids = list;
    else
        free(list);
    if (n)
        *n = k;
    return RD_OK;
}

rd_error_code rd_store_batch_delete(rd_store *s, const char *id, rd_store_grade_id **ids, size_t *n, rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_id("a batch id", id, err));
    return deleted(s, NULL, id, ids, n, err);
}

rd_error_code rd_store_grades_delete(rd_store *s, const char *student, rd_store_grade_id **ids, size_t *n,
                                     rd_error *err)
{
    USE_ERR(err);
    CHECKED(check_name("the student", student, 1, err));
    return deleted(s, "student", student ? student : "", ids, n, err);
}

rd_error_code rd_store_grade_delete(rd_store *s, const char *id, rd_error *err)
{
    USE_ERR(err);
    size_t n = 0;
    CHECKED(check_id("a grade id", id, err));
    CHECKED(deleted(s, "id", id, NULL, &n, err));
    return n ? RD_OK : rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: no grade %s", id);
}
