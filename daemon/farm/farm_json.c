/* The texts a stored job carries: its schedule (how the pass in progress
 * runs, for every daemon rendering it), its statistics, and the status
 * JSON clients read. cJSON prints a double with 17 digits when 15 do not
 * give it back, so a schedule read back is the schedule written. */
#include <cJSON.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "error_map.h"
#include "farm_internal.h"
#include "json_text.h"

char *farm_schedule_text(const rd_job_schedule *sc, int64_t opened_ms, int max_samples)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "max_samples", max_samples);
    cJSON_AddNumberToObject(o, "pass", sc->pass);
    cJSON_AddNumberToObject(o, "pass_samples", sc->pass_samples);
    cJSON_AddNumberToObject(o, "mean_weight", sc->mean_weight);
    cJSON_AddNumberToObject(o, "spp", sc->spp);
    cJSON_AddNumberToObject(o, "passes_done", sc->passes_done);
    cJSON_AddNumberToObject(o, "error", sc->error);
    cJSON_AddNumberToObject(o, "last_pass_ms", sc->last_pass_ms);
    cJSON_AddNumberToObject(o, "stopped_by", sc->stopped_by);
    cJSON_AddNumberToObject(o, "opened_ms", (double)opened_ms);
    cJSON_AddItemToObject(o, "curve", rd_json_curve(sc->curve, sc->curve_len));
    char *t = cJSON_PrintUnformatted(o);
    cJSON_Delete(o);
    return t;
}

static int num(const cJSON *o, const char *key, double *out)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    if (!cJSON_IsNumber(v) || !isfinite(v->valuedouble))
        return 0;
    *out = v->valuedouble;
    return 1;
}

static int int_of(const cJSON *o, const char *key, int *out)
{
    double d;
    if (!num(o, key, &d) || d < -1e9 || d > 1e9 || d != floor(d))
        return 0;
    *out = (int)d;
    return 1;
}

static int read_curve(const cJSON *o, rd_job_schedule *sc)
{
    const cJSON *curve = cJSON_GetObjectItemCaseSensitive(o, "curve");
    if (!cJSON_IsArray(curve) || cJSON_GetArraySize(curve) > RD_CURVE_MAX)
        return 0;
    sc->curve_len = 0;
    const cJSON *pt;
    cJSON_ArrayForEach(pt, curve)
    {
        double v[3];
        for (int k = 0; k < 3; k++) {
            const cJSON *x = cJSON_GetArrayItem(pt, k);
            if (!cJSON_IsNumber(x) || !isfinite(x->valuedouble))
                return 0;
            v[k] = x->valuedouble;
        }
        sc->curve[sc->curve_len++] = (rd_curve_point){v[0], v[1], v[2]};
    }
    return 1;
}

/* The store's bytes are read as hostile as any: a schedule that does not
 * parse, or whose values are out of range (rd_job_schedule_set checks
 * those), is an error, never a guess. */
rd_error_code farm_schedule_parse(const char *text, rd_job_schedule *sc, int64_t *opened_ms, rd_error *err)
{
    memset(sc, 0, sizeof *sc);
    cJSON *o = cJSON_Parse(text);
    int stopped = 0;
    double opened = 0;
    int ok = o && int_of(o, "pass", &sc->pass) && int_of(o, "pass_samples", &sc->pass_samples) &&
             num(o, "mean_weight", &sc->mean_weight) && int_of(o, "spp", &sc->spp) &&
             int_of(o, "passes_done", &sc->passes_done) && num(o, "error", &sc->error) &&
             num(o, "last_pass_ms", &sc->last_pass_ms) && int_of(o, "stopped_by", &stopped) &&
             num(o, "opened_ms", &opened) && read_curve(o, sc);
    cJSON_Delete(o);
    if (!ok)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "a stored job's schedule does not parse");
    sc->stopped_by = (rd_stop_reason)stopped;
    *opened_ms = (int64_t)opened;
    return RD_OK;
}

char *farm_stats_text(farm_ctx *c, int64_t now_ms, int final)
{
    rd_render_stats st;
    rd_job_stats(c->core, &st);
    rd_job_counts sum = {0, 0, 0, 0};
    for (int t = 0; t < c->tiles; t++) {
        sum.camera += c->tile_counts[t].camera;
        sum.shadow += c->tile_counts[t].shadow;
        sum.secondary += c->tile_counts[t].secondary;
        sum.nonfinite += c->tile_counts[t].nonfinite;
    }
    double wall = (double)(now_ms - c->started_ms);
    rd_stats_add_counts(&st, &sum, wall > 0 ? wall : 0);
    cJSON *o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "samples", st.samples);
    cJSON_AddNumberToObject(o, "error_estimate", st.error_estimate);
    cJSON_AddItemToObject(o, "curve", rd_json_curve(st.curve, st.curve_len));
    cJSON_AddNumberToObject(o, "passes", st.passes);
    if (final)
        cJSON_AddStringToObject(o, "stopped_by", rd_stop_reason_name(st.stopped_by));
    cJSON *s = cJSON_AddObjectToObject(o, "stats");
    cJSON_AddNumberToObject(s, "camera_rays", (double)st.camera_rays);
    cJSON_AddNumberToObject(s, "shadow_rays", (double)st.shadow_rays);
    cJSON_AddNumberToObject(s, "secondary_rays", (double)st.secondary_rays);
    cJSON_AddNumberToObject(s, "rays_per_second", st.rays_per_second);
    cJSON_AddNumberToObject(s, "prepare_ms", st.prepare_ms);
    cJSON_AddNumberToObject(s, "primitives", (double)st.primitives);
    char *t = cJSON_PrintUnformatted(o);
    cJSON_Delete(o);
    return t;
}

/* Tiles done of all the work the schedule plans: a completed pass counts
 * whole while its finisher opens the next, so progress never goes back. */
static double progress_of(const rd_store_job_info *in, const cJSON *sched)
{
    if (in->status == RD_STORE_DONE)
        return 1;
    if (in->tiles_total <= 0)
        return 0;
    double frac = (double)in->tiles_done / in->tiles_total;
    if (in->passes <= 1)
        return frac < 1 ? frac : 0.999;
    double spp = 0, pass_spp = 0, max = 0, pass = 0;
    if (!sched || !num(sched, "spp", &spp) || !num(sched, "pass_samples", &pass_spp) || !num(sched, "pass", &pass))
        pass_spp = 2; /* the first pass of every progressive schedule */
    num(sched, "max_samples", &max);
    if (in->pass > pass)
        frac = 1;
    double p = max > 0 ? (spp + pass_spp * frac) / max : 0;
    return p < 0.999 ? p : 0.999;
}

static void add_stats(cJSON *o, const rd_store_job_info *in)
{
    cJSON *st = in->stats ? cJSON_Parse(in->stats) : NULL;
    static const char *const keys[] = {"samples", "error_estimate", "curve", "passes", "stopped_by", "stats", NULL};
    for (int i = 0; keys[i]; i++) {
        cJSON *v = st ? cJSON_DetachItemFromObjectCaseSensitive(st, keys[i]) : NULL;
        if (v && (i != 5 || in->status == RD_STORE_DONE || in->status == RD_STORE_RUNNING))
            cJSON_AddItemToObject(o, keys[i], v);
        else if (v)
            cJSON_Delete(v);
        else if (i == 2)
            cJSON_AddArrayToObject(o, "curve");
        else if (i == 0 || i == 1 || i == 3)
            cJSON_AddNumberToObject(o, keys[i], 0);
    }
    cJSON_Delete(st);
}

/* From one wall-clock stamp to a later one. The stamps come from different
 * readings of the wall clock (and with PostgreSQL from its server's), which
 * may step back a little: a job once read queued_ms -2. */
static double span_ms(int64_t from, int64_t to) { return to > from ? (double)(to - from) : 0; }

char *farm_job_json(const rd_store_job_info *in)
{
    cJSON *o = cJSON_CreateObject();
    cJSON *sched = in->schedule ? cJSON_Parse(in->schedule) : NULL;
    int64_t now = rd_wall_ms();
    int64_t end = in->finished_ms ? in->finished_ms : now;
    cJSON_AddStringToObject(o, "id", in->id);
    cJSON_AddStringToObject(o, "status", rd_store_status_name(in->status));
    cJSON_AddNumberToObject(o, "progress", progress_of(in, sched));
    cJSON_AddNumberToObject(o, "elapsed_ms", in->started_ms ? span_ms(in->started_ms, end) : 0);
    cJSON_AddNumberToObject(o, "queued_ms", span_ms(in->submitted_ms, in->started_ms ? in->started_ms : end));
    cJSON_AddNumberToObject(o, "width", in->width);
    cJSON_AddNumberToObject(o, "height", in->height);
    add_stats(o, in);
    if (in->status == RD_STORE_FAILED) {
        cJSON *e = cJSON_AddObjectToObject(o, "error");
        cJSON_AddStringToObject(e, "code", rd_error_answer_for(in->error.code).code);
        cJSON_AddStringToObject(e, "message", in->error.message);
    }
    cJSON_Delete(sched);
    char *t = cJSON_PrintUnformatted(o);
    cJSON_Delete(o);
    return t;
}
