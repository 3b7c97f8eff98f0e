#define _GNU_SOURCE /* pthread_rwlockattr_setkind_np */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "farm_internal.h"
#include "rayd/clock.h"
#include "scene_open.h"

/* The header of a tile's stored bytes: the rays its passes took, so the
 * job's totals come out the same whichever daemons rendered it. */
typedef struct {
    uint32_t magic, version;
    uint64_t camera, shadow, secondary, nonfinite;
} blob_header;

enum { BLOB_MAGIC = 0x54445952u /* "RYDT" */, BLOB_VERSION = 1 };

size_t farm_blob_bytes(const farm_ctx *c, int t) { return sizeof(blob_header) + rd_job_tile_state_bytes(c->core, t); }

void farm_blob_write(const farm_ctx *c, int t, void *out)
{
    const rd_job_counts *k = &c->tile_counts[t];
    blob_header h = {BLOB_MAGIC, BLOB_VERSION, k->camera, k->shadow, k->secondary, k->nonfinite};
    memcpy(out, &h, sizeof h);
    rd_job_tile_state_save(c->core, t, (unsigned char *)out + sizeof h);
}

rd_error_code farm_blob_read(farm_ctx *c, int t, const void *in, size_t len, rd_error *err)
{
    blob_header h;
    if (!in || len < sizeof h)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "tile %d of job %s: %zu bytes, not a tile", t, c->id, len);
    memcpy(&h, in, sizeof h);
    if (h.magic != BLOB_MAGIC || h.version != BLOB_VERSION)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0,
                            "tile %d of job %s was stored by another version of rayd (format %u)", t, c->id,
                            (unsigned)h.version);
    rd_error_code rc = rd_job_tile_state_load(c->core, t, (const unsigned char *)in + sizeof h, len - sizeof h, err);
    if (rc)
        return rc;
    c->tile_counts[t] = (rd_job_counts){h.camera, h.shadow, h.secondary, h.nonfinite};
    return RD_OK;
}

/* The queue counts a job rendering here among its --queue jobs from its
 * build until it ends. Under farm.mu. */
static void uncount(rd_farm *f, farm_ctx *c)
{
    if (c->counted && f->opt.jobs)
        rd_jq_external_jobs(f->opt.jobs, -1);
    c->counted = 0;
}

static void ctx_free(rd_farm *f, farm_ctx *c)
{
    uncount(f, c);
    if (c->charged && f->opt.jobs)
        rd_jq_external_bytes(f->opt.jobs, -(long long)c->charged);
    rd_job_free(c->core);
    rd_scene_free(&c->scene);
    free(c->tile_pass);
    free(c->tile_counts);
    pthread_rwlock_destroy(&c->rw);
    free(c);
}

rd_error_code farm_read_scene(rd_farm *f, const char *text, size_t len, const char *format, rd_job_params *p,
                              rd_scene *s, rd_error *err)
{
    rd_scene_source src = {.text = text,
                           .len = len,
                           .source = "<upload>",
                           .format = strcmp(format, "json") == 0 ? RD_FMT_JSON : RD_FMT_CFG,
                           .assets_dir = f->opt.scenes_dir};
    rd_error_code rc = rd_scene_open(&src, &p->ov, &f->opt.limits, s, NULL, err);
    /* The cap of the schedule (and of progress) is the scene's samples. */
    if (!rc)
        p->progress.max_samples = s->render.samples < 1 ? 1 : s->render.samples;
    return rc;
}

/* The scene of a job this daemon did not submit (or whose submitter's
 * parse it no longer holds), read back from the store. */
static rd_error_code read_back(rd_farm *f, rd_store *h, farm_ctx *c, rd_error *err)
{
    rd_store_job_input in;
    rd_error_code rc = rd_store_job_input_get(h, c->id, &in, err);
    if (rc)
        return rc;
    rc = rd_job_params_parse(&c->params, in.query, err);
    if (!rc)
        rc = farm_read_scene(f, in.scene, in.scene_len, in.format, &c->params, &c->scene, err);
    rd_store_job_input_free(&in);
    if (!rc)
        c->have_scene = 1;
    atomic_fetch_add(&f->read_back, 1);
    return rc;
}

/* The core for the job, from the scene its submitter read here or one
 * read back as its submitter did: the same text, parameters and limits
 * give the same scene (farm_read_scene). */
static rd_error_code build(rd_farm *f, rd_store *h, farm_ctx *c, rd_error *err)
{
    rd_store_job_info info;
    rd_error_code rc = rd_store_job_get(h, c->id, &info, err);
    if (rc)
        return rc;
    c->submitted_ms = info.submitted_ms;
    c->started_ms = info.started_ms ? info.started_ms : rd_wall_ms();
    c->opened_ms = c->started_ms;
    rd_store_job_info_free(&info);
    if (!c->have_scene && (rc = read_back(f, h, c, err)))
        return rc;
    rd_job_options jo = {f->opt.tile, c->params.progress, 1, 0, NULL};
    size_t need = rd_job_estimate_bytes(&c->scene, &jo);
    pthread_mutex_lock(&f->mu); /* the metrics read it */
    long long more = (long long)need - (long long)c->charged;
    c->charged = need;
    pthread_mutex_unlock(&f->mu);
    rd_jq_external_bytes(f->opt.jobs, more);
    rc = rd_job_create(&c->scene, &jo, &c->core, err);
    if (rc)
        return rc;
    rd_job_set_cancel(c->core, &c->stop);
    if (f->opt.job_timeout_ms > 0) {
        double left = (double)c->started_ms + f->opt.job_timeout_ms - (double)rd_wall_ms();
        rd_job_set_deadline(c->core, rd_now_ms() + (left > 0 ? left : 0) + 1e-3);
    }
    c->tiles = rd_job_tile_count(c->core);
    c->tile_pass = calloc((size_t)c->tiles, sizeof *c->tile_pass);
    c->tile_counts = calloc((size_t)c->tiles, sizeof *c->tile_counts);
    if (!c->tile_pass || !c->tile_counts)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    rd_job_first_pass(c->core);
    c->pass = 0;
    return RD_OK;
}

/* At most this many jobs are held here; a claim for another drops the
 * unused ones first (their tiles are in the store). */
enum { CTX_KEPT = CTX_HELD_MAX };

int farm_ctx_held(rd_farm *f, char ids[][RD_STORE_ID_MAX])
{
    int n = 0;
    pthread_mutex_lock(&f->mu);
    /* New contexts go first in the list: walk it to its end, then back. */
    farm_ctx *live[CTX_HELD_MAX * 2];
    int k = 0;
    for (farm_ctx *c = f->ctxs; c && k < CTX_HELD_MAX * 2; c = c->next)
        if (c->built && !c->build_rc && !atomic_load(&c->stop))
            live[k++] = c;
    for (int i = k - 1; i >= 0 && n < CTX_HELD_MAX; i--)
        snprintf(ids[n++], RD_STORE_ID_MAX, "%s", live[i]->id);
    pthread_mutex_unlock(&f->mu);
    return n;
}

/* Drops the unused contexts past the first `keep`: what they held is in
 * the store. Under farm.mu. */
static void drop_unused(rd_farm *f, int keep)
{
    int n = 0;
    for (farm_ctx **pp = &f->ctxs; *pp;) {
        farm_ctx *c = *pp;
        if (++n > keep && c->refs == 0 && !c->building) {
            *pp = c->next;
            ctx_free(f, c);
        } else {
            pp = &c->next;
        }
    }
}

/* A new context, first in the list, with one reference. Under farm.mu. */
static farm_ctx *ctx_new(rd_farm *f, const char *id)
{
    drop_unused(f, CTX_KEPT - 1);
    farm_ctx *c = calloc(1, sizeof *c);
    if (!c)
        return NULL;
    snprintf(c->id, sizeof c->id, "%s", id);
    c->refs = 1;
    c->pass = -1;
    rd_scene_init(&c->scene);
    /* Writers first: render threads take the read lock tile after tile,
     * and under glibc's default a snapshot or a pass's end waited until no
     * tile was rendering at all (a partial image of a slow job took
     * minutes). Now a writer waits for the tiles in flight only. */
    pthread_rwlockattr_t ra;
    pthread_rwlockattr_init(&ra);
    pthread_rwlockattr_setkind_np(&ra, PTHREAD_RWLOCK_PREFER_WRITER_NONRECURSIVE_NP);
    pthread_rwlock_init(&c->rw, &ra);
    pthread_rwlockattr_destroy(&ra);
    c->next = f->ctxs;
    f->ctxs = c;
    return c;
}

/* Builds c on this thread, the one that found it unbuilt. Under farm.mu
 * (released and taken again). */
static void build_here(rd_farm *f, rd_store *h, farm_ctx *c)
{
    c->building = 1;
    pthread_mutex_unlock(&f->mu);
    rd_error_code rc = build(f, h, c, &c->build_err);
    pthread_mutex_lock(&f->mu);
    c->building = 0;
    c->build_rc = rc;
    c->built = 1;
    if (!rc && !atomic_load(&c->stop)) {
        rd_jq_external_jobs(f->opt.jobs, 1);
        c->counted = 1;
    }
    pthread_cond_broadcast(&f->ctx_cv);
}

farm_ctx *farm_ctx_get(rd_farm *f, rd_store *h, const char *id, rd_error *err)
{
    pthread_mutex_lock(&f->mu);
    farm_ctx *c = f->ctxs;
    while (c && strcmp(c->id, id) != 0)
        c = c->next;
    if (c)
        c->refs++;
    else if (!(c = ctx_new(f, id))) {
        pthread_mutex_unlock(&f->mu);
        rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
        return NULL;
    }
    if (!c->built && !c->building)
        build_here(f, h, c);
    while (!c->built)
        pthread_cond_wait(&f->ctx_cv, &f->mu);
    pthread_mutex_unlock(&f->mu);
    if (c->build_rc) {
        if (err)
            *err = c->build_err;
        farm_ctx_put(f, c);
        return NULL;
    }
    return c;
}

void farm_ctx_adopt(rd_farm *f, const char *id, rd_scene *scene, const rd_job_params *p)
{
    size_t bytes = rd_scene_bytes(scene);
    pthread_mutex_lock(&f->mu);
    farm_ctx *c = ctx_new(f, id);
    if (c) {
        c->scene = *scene;
        rd_scene_init(scene);
        c->params = *p;
        c->have_scene = 1;
        c->charged = bytes;
        c->refs = 0;
    }
    pthread_mutex_unlock(&f->mu);
    if (c)
        rd_jq_external_bytes(f->opt.jobs, (long long)bytes);
    else
        rd_scene_free(scene);
}

/* A context that failed to build, or whose job ended, goes once unused:
 * the next claim builds it again from the store. */
void farm_ctx_put(rd_farm *f, farm_ctx *c)
{
    pthread_mutex_lock(&f->mu);
    if (--c->refs == 0 && (c->build_rc || atomic_load(&c->stop))) {
        for (farm_ctx **pp = &f->ctxs; *pp; pp = &(*pp)->next)
            if (*pp == c) {
                *pp = c->next;
                break;
            }
        pthread_mutex_unlock(&f->mu);
        ctx_free(f, c);
        return;
    }
    pthread_mutex_unlock(&f->mu);
}

void farm_ctx_ended(rd_farm *f, const char *id)
{
    pthread_mutex_lock(&f->mu);
    farm_ctx *c = f->ctxs;
    while (c && strcmp(c->id, id) != 0)
        c = c->next;
    if (c) {
        atomic_store(&c->stop, 1);
        uncount(f, c);
        c->refs++;
    }
    pthread_mutex_unlock(&f->mu);
    if (c)
        farm_ctx_put(f, c);
}

void farm_ctx_free_all(rd_farm *f)
{
    while (f->ctxs) {
        farm_ctx *c = f->ctxs;
        f->ctxs = c->next;
        ctx_free(f, c);
    }
}

rd_error_code farm_ctx_sync_pass(rd_farm *f, rd_store *h, farm_ctx *c, int pass, rd_error *err)
{
    (void)f;
    if (c->pass == pass)
        return RD_OK;
    rd_store_job_info info;
    rd_error_code rc = rd_store_job_get(h, c->id, &info, err);
    if (rc)
        return rc;
    rd_job_schedule sc;
    int64_t opened = 0;
    if (!info.schedule)
        rc = rd_error_set(err, RD_ERR_INVALID, 0, 0, "job %s has no schedule for pass %d", c->id, pass);
    else
        rc = farm_schedule_parse(info.schedule, &sc, &opened, err);
    rd_store_job_info_free(&info);
    if (!rc && sc.pass != pass)
        rc = rd_error_set(err, RD_ERR_CANCELLED, 0, 0, "job %s is at pass %d, not %d", c->id, sc.pass, pass);
    if (!rc)
        rc = rd_job_schedule_set(c->core, &sc, err);
    if (!rc) {
        c->pass = pass;
        c->opened_ms = opened;
    }
    return rc;
}

rd_error_code farm_ctx_gather(rd_store *h, farm_ctx *c, int passes, int *complete, rd_error *err)
{
    rd_store_tile_data *td = NULL;
    size_t n = 0;
    rd_error_code rc = rd_store_tiles_get(h, c->id, &td, &n, err);
    if (rc)
        return rc;
    int have = 0;
    for (size_t i = 0; i < n && !rc; i++) {
        int t = td[i].index;
        if (t < 0 || t >= c->tiles) {
            rc = rd_error_set(err, RD_ERR_INVALID, 0, 0, "job %s has a tile %d of %d", c->id, t, c->tiles);
            break;
        }
        if (td[i].passes != c->tile_pass[t]) {
            rc = farm_blob_read(c, t, td[i].data, td[i].len, err);
            if (!rc)
                c->tile_pass[t] = td[i].passes;
        }
        have += td[i].passes >= passes;
    }
    rd_store_tiles_free(td, n);
    if (!rc && complete)
        *complete = have == c->tiles;
    return rc;
}
