/* What the HTTP side asks of the farm: committing a job, its status, its
 * image, cancelling it, and whether the store answers. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "capability.h"
#include "farm_internal.h"

const char *rd_farm_engine(const rd_farm *f) { return rd_store_engine_name(f->api); }

rd_error_code rd_farm_ping(rd_farm *f, rd_error *err)
{
    rd_error_code rc = rd_store_ping(f->api, err);
    farm_store_result(f, rc);
    return rc ? rc : farm_full(f, err);
}

/* The schedule's first pass as the core will begin it (rd_job_first_pass),
 * so status readers know the pass and the cap before any daemon has read
 * the scene. */
static char *first_schedule(const rd_progress_settings *p, int64_t now)
{
    rd_stop_reason why;
    rd_job_schedule sc;
    memset(&sc, 0, sizeof sc);
    int n = rd_progress_next(p, 0, 0, 0, 0, 0, 0, &why);
    sc.pass_samples = n < 1 ? 1 : n;
    return farm_schedule_text(&sc, now, p->max_samples);
}

static rd_error_code check_room(rd_farm *f, size_t need, rd_error *err)
{
    if (rd_jq_check_budget(f->opt.jobs, "the render", need, err))
        return err->code;
    rd_store_job_brief *b = NULL;
    size_t n = 0;
    unsigned active = RD_STORE_MASK(RD_STORE_QUEUED) | RD_STORE_MASK(RD_STORE_RUNNING);
    rd_error_code rc = rd_store_jobs_list(f->submit, active, f->opt.queue_length, &b, &n, err);
    farm_store_result(f, rc);
    free(b);
    if (!rc && n >= f->opt.queue_length)
        rc = rd_error_set(err, RD_ERR_BUSY, 0, 0, "the render queue is full; try again shortly");
    return rc;
}

/* The job as committed, for the submitter's answer: what a GET of it
 * would read back at once. */
static char *committed_json(const rd_store_job_spec *spec)
{
    rd_store_job_info info = {.status = RD_STORE_QUEUED,
                              .hdr = spec->hdr,
                              .width = spec->width,
                              .height = spec->height,
                              .memory_bytes = spec->memory_bytes,
                              .submitted_ms = spec->submitted_ms,
                              .tiles_total = spec->tiles,
                              .passes = spec->passes,
                              .gated = spec->gated,
                              .open_pass = 1,
                              .schedule = (char *)spec->schedule};
    snprintf(info.id, sizeof info.id, "%s", spec->id);
    snprintf(info.format, sizeof info.format, "%s", spec->format);
    return farm_job_json(&info);
}

/* Commits the job read as s; its id into id, the answer into *json. */
static rd_error_code commit(rd_farm *f, const char *text, size_t len, const char *format, const rd_job_params *p,
                            const rd_scene *s, char id[RD_STORE_ID_MAX], char **json, rd_error *err)
{
    rd_job_options jo = {f->opt.tile, p->progress, 1, 0, NULL};
    size_t need = rd_job_estimate_bytes(s, &jo);
    rd_error_code rc = check_room(f, need, err);
    if (rc)
        return rc;
    int w = s->render.width, h = s->render.height, t = f->opt.tile;
    int64_t now = rd_wall_ms();
    char fresh[RD_STORE_ID_MAX];
    rc = rd_cap_new(fresh, 0, err); /* the ids of GET and DELETE are capabilities */
    if (rc)
        return rc;
    char *sched = first_schedule(&jo.progress, now);
    if (!sched)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    rd_store_job_spec spec = {.id = fresh,
                              .scene = text,
                              .scene_len = len,
                              .format = format,
                              .query = p->query,
                              .hdr = p->hdr,
                              .width = w,
                              .height = h,
                              .memory_bytes = (int64_t)need,
                              .submitted_ms = now,
                              .tiles = ((w + t - 1) / t) * ((h + t - 1) / t),
                              .passes = rd_progress_is_progressive(&jo.progress) ? RD_CURVE_MAX : 1,
                              .gated = 1,
                              .schedule = sched};
    rc = farm_full(f, err);
    if (!rc) {
        rc = rd_store_job_create(f->submit, &spec, err);
        farm_store_result(f, rc);
    }
    if (!rc && !(*json = committed_json(&spec)))
        rc = rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory"); /* committed: it renders unanswered */
    free(sched);
    if (!rc) {
        memcpy(id, fresh, RD_STORE_ID_MAX);
        atomic_fetch_add(&f->submitted, 1);
    }
    return rc;
}

rd_error_code rd_farm_submit(rd_farm *f, const char *text, size_t len, rd_scene_format fmt, const rd_job_params *params,
                             char id[RD_STORE_ID_MAX], char **json, rd_error *err)
{
    *json = NULL;
    if (fmt == RD_FMT_AUTO)
        fmt = rd_scene_sniff(text, len);
    const char *format = fmt == RD_FMT_JSON ? "json" : "cfg";
    rd_job_params p = *params;
    rd_scene s;
    rd_scene_init(&s);
    rd_error_code rc = farm_read_scene(f, text, len, format, &p, &s, err);
    if (!rc)
        rc = commit(f, text, len, format, &p, &s, id, json, err);
    if (!rc)
        farm_ctx_adopt(f, id, &s, &p);
    rd_scene_free(&s);
    return rc;
}

rd_error_code rd_farm_job_json(rd_farm *f, const char *id, char **json, rd_store_status *status, rd_error *err)
{
    rd_store_job_info info;
    rd_error_code rc = rd_store_job_get(f->api, id, &info, err);
    farm_store_result(f, rc);
    if (rc)
        return rc;
    *json = farm_job_json(&info);
    if (status)
        *status = info.status;
    rd_store_job_info_free(&info);
    return *json ? RD_OK : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
}

rd_error_code rd_farm_cancel(rd_farm *f, const char *id, int *changed, rd_error *err)
{
    int ch = 0;
    rd_error_code rc = rd_store_job_cancel(f->api, id, &ch, err);
    farm_store_result(f, rc);
    if (rc)
        return rc;
    farm_ctx_ended(f, id);
    if (ch)
        atomic_fetch_add(&f->cancelled, 1);
    if (changed)
        *changed = ch;
    return RD_OK;
}

rd_error_code rd_farm_image(rd_farm *f, const char *id, rd_store_image_kind kind, unsigned char **data, size_t *len,
                            rd_store_status *status, int *hdr, rd_error *err)
{
    rd_store_job_info info;
    rd_error_code rc = rd_store_job_get(f->api, id, &info, err);
    farm_store_result(f, rc);
    if (rc)
        return rc;
    *status = info.status;
    *hdr = info.hdr;
    rd_store_job_info_free(&info);
    if (*status != RD_STORE_DONE)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "job %s is %s: it has no image", id,
                            rd_store_status_name(*status));
    rc = rd_store_job_image(f->api, id, kind, data, len, err);
    farm_store_result(f, rc);
    return rc;
}

/* Every tile that holds a pass, from this daemon's pixels and the store's
 * newer ones; black elsewhere. */
static rd_error_code snapshot(rd_farm *f, farm_ctx *c, uint8_t *rgb, rd_error *err)
{
    pthread_rwlock_wrlock(&c->rw);
    rd_error_code rc = farm_ctx_gather(f->submit, c, 0, NULL, err);
    farm_store_result(f, rc);
    for (int t = 0; !rc && t < c->tiles; t++)
        if (c->tile_pass[t] > 0)
            rd_job_tile_rgb8(c->core, t, rgb);
    pthread_rwlock_unlock(&c->rw);
    return rc;
}

rd_error_code rd_farm_partial_png(rd_farm *f, const char *id, unsigned char **png, size_t *len, rd_error *err)
{
    rd_store_job_info info;
    rd_error_code rc = rd_store_job_get(f->submit, id, &info, err);
    farm_store_result(f, rc);
    if (rc)
        return rc;
    rd_store_status st = info.status;
    rd_store_job_info_free(&info);
    if (st != RD_STORE_RUNNING)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "job %s is %s, not running", id, rd_store_status_name(st));
    farm_ctx *c = farm_ctx_get(f, f->submit, id, err);
    if (!c)
        return err->code;
    int w = rd_job_width(c->core), h = rd_job_height(c->core);
    uint8_t *rgb = calloc((size_t)w * (size_t)h, 3);
    rc = rgb ? snapshot(f, c, rgb, err) : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    farm_ctx_put(f, c);
    if (!rc)
        rc = rd_png_encode(rgb, w, h, &f->opt.png, png, len, err);
    free(rgb);
    return rc;
}

/* The store's queue, every daemon's: bounded by --queue, which refuses
 * submissions past it, so a list of that many counts it. */
static void store_queue(rd_farm *f, rd_farm_metrics *m)
{
    rd_store_job_brief *b = NULL;
    size_t n = 0;
    rd_error err = {0};
    unsigned active = RD_STORE_MASK(RD_STORE_QUEUED) | RD_STORE_MASK(RD_STORE_RUNNING);
    rd_error_code rc = rd_store_jobs_list(f->api, active, f->opt.queue_length + 1, &b, &n, &err);
    farm_store_result(f, rc);
    m->store_known = rc == RD_OK;
    for (size_t i = 0; !rc && i < n; i++)
        *(b[i].status == RD_STORE_QUEUED ? &m->store_queued : &m->store_running) += 1;
    free(b);
}

void rd_farm_metrics_get(rd_farm *f, rd_farm_metrics *m)
{
    store_queue(f, m);
    m->tiles = atomic_load(&f->tiles);
    m->tiles_lost = atomic_load(&f->tiles_lost);
    m->passes = atomic_load(&f->passes);
    m->done = atomic_load(&f->done);
    m->failed = atomic_load(&f->failed);
    m->cancelled = atomic_load(&f->cancelled);
    m->submitted = atomic_load(&f->submitted);
    m->store_errors = atomic_load(&f->store_errors);
    m->rays = atomic_load(&f->rays);
    m->read_back = atomic_load(&f->read_back);
    m->store_up = atomic_load(&f->store_up);
    char ids[CTX_HELD_MAX][RD_STORE_ID_MAX];
    m->active = farm_ctx_held(f, ids);
    pthread_mutex_lock(&f->mu);
    m->memory = 0;
    for (farm_ctx *c = f->ctxs; c; c = c->next)
        m->memory += c->charged;
    pthread_mutex_unlock(&f->mu);
}
