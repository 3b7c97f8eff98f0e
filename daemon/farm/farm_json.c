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
#include "job_status.h"
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
             num(o, "opened_ms", &opened) &&
             !rd_json_curve_read(cJSON_GetObjectItemCaseSensitive(o, "curve"), sc->curve, &sc->curve_len);
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
    /* In the job status's layout: every daemon on the store reads this
     * text, an older one by copying its keys into its answers as they are. */
    cJSON *o = cJSON_CreateObject();
    int failed = rd_stats_json(o, &st, RD_STATS_COSTS | RD_STATS_NESTED | (final ? RD_STATS_STOPPED : 0));
    char *t = failed ? NULL : cJSON_PrintUnformatted(o);
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

/* From one wall-clock stamp to a later one. The stamps come from different
 * readings of the wall clock (and with PostgreSQL from its server's), which
 * may step back a little: a job once read queued_ms -2. */
static double span_ms(int64_t from, int64_t to) { return to > from ? (double)(to - from) : 0; }

/* rd_job_status takes a stored job's status as the queue's. */
_Static_assert(RD_STORE_QUEUED == (int)RD_JQ_QUEUED && RD_STORE_RUNNING == (int)RD_JQ_RUNNING &&
                   RD_STORE_DONE == (int)RD_JQ_DONE && RD_STORE_FAILED == (int)RD_JQ_FAILED &&
                   RD_STORE_CANCELLED == (int)RD_JQ_CANCELLED,
               "rd_store_status has the order of rd_jq_status");

char *farm_job_json(const rd_store_job_info *in)
{
    cJSON *sched = in->schedule ? cJSON_Parse(in->schedule) : NULL;
    cJSON *stats = in->stats ? cJSON_Parse(in->stats) : NULL;
    int64_t end = in->finished_ms ? in->finished_ms : rd_wall_ms();
    rd_job_status s = {.id = in->id,
                       .status = (rd_jq_status)in->status,
                       .progress = progress_of(in, sched),
                       .elapsed_ms = in->started_ms ? span_ms(in->started_ms, end) : 0,
                       .queued_ms = span_ms(in->submitted_ms, in->started_ms ? in->started_ms : end),
                       .width = in->width,
                       .height = in->height};
    /* farm_stats_text's, as the last daemon to end a pass wrote it (none
     * before the first pass ends: every figure 0 then). */
    rd_stats_read(stats, &s.stats, RD_STATS_COSTS | RD_STATS_NESTED | RD_STATS_STOPPED);
    if (in->status == RD_STORE_FAILED) {
        s.error_code = rd_error_answer_for(in->error.code).code;
        s.error_message = in->error.message;
    }
    char *t = rd_job_status_json(&s);
    cJSON_Delete(sched);
    cJSON_Delete(stats);
    return t;
}
