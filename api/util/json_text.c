#include "json_text.h"

#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

char *rd_json_print(cJSON *root)
{
    char *text = root ? cJSON_Print(root) : NULL;
    cJSON_Delete(root);
    if (!text)
        return NULL;
    /* A copy, so free() matches whatever allocator cJSON was built with. */
    size_t n = strlen(text);
    char *copy = malloc(n + 2);
    if (copy) {
        memcpy(copy, text, n);
        copy[n] = '\n';
        copy[n + 1] = 0;
    }
    cJSON_free(text);
    return copy;
}

cJSON *rd_json_add(cJSON *parent, const char *key, cJSON *item, int *failed)
{
    if (!parent || !item || !(key ? cJSON_AddItemToObject(parent, key, item) : cJSON_AddItemToArray(parent, item))) {
        cJSON_Delete(item);
        *failed = 1;
        return NULL;
    }
    return item;
}

cJSON *rd_json_curve(const rd_curve_point *c, int n)
{
    cJSON *a = cJSON_CreateArray();
    for (int i = 0; a && i < n; i++) {
        double pt[3] = {c[i].ms, c[i].samples, c[i].error};
        cJSON *item = cJSON_CreateDoubleArray(pt, 3);
        if (!item || !cJSON_AddItemToArray(a, item)) {
            cJSON_Delete(item);
            cJSON_Delete(a);
            return NULL;
        }
    }
    return a;
}

int rd_json_curve_read(const cJSON *curve, rd_curve_point *c, int *n)
{
    *n = 0;
    if (!cJSON_IsArray(curve) || cJSON_GetArraySize(curve) > RD_CURVE_MAX)
        return -1;
    int len = 0;
    const cJSON *pt;
    cJSON_ArrayForEach(pt, curve)
    {
        double v[3];
        if (!cJSON_IsArray(pt) || cJSON_GetArraySize(pt) != 3)
            return -1;
        for (int k = 0; k < 3; k++) {
            const cJSON *x = cJSON_GetArrayItem(pt, k);
            if (!cJSON_IsNumber(x) || !isfinite(x->valuedouble))
                return -1;
            v[k] = x->valuedouble;
        }
        c[len++] = (rd_curve_point){v[0], v[1], v[2]};
    }
    *n = len;
    return 0;
}

/* ---- a render's statistics -------------------------------------------------
 *
 * Every figure's name, once: the writer and the reader both walk this
 * table. */

typedef enum { FIG_INT, FIG_DOUBLE, FIG_U64, FIG_SIZE } figure_type;

static const struct figure {
    const char *key;
    size_t offset; /* in rd_render_stats */
    figure_type type;
    unsigned needs; /* the parts that select it; RD_STATS_COSTS also says where it goes */
} figures[] = {
#define AT(field) offsetof(rd_render_stats, field)
    {"samples", AT(samples), FIG_INT, 0},
    {"mean_samples", AT(mean_samples), FIG_DOUBLE, RD_STATS_PROCESS},
    {"error_estimate", AT(error_estimate), FIG_DOUBLE, 0},
    {"passes", AT(passes), FIG_INT, 0},
    {"camera_rays", AT(camera_rays), FIG_U64, RD_STATS_COSTS},
    {"shadow_rays", AT(shadow_rays), FIG_U64, RD_STATS_COSTS},
    {"secondary_rays", AT(secondary_rays), FIG_U64, RD_STATS_COSTS},
    {"rays_per_second", AT(rays_per_second), FIG_DOUBLE, RD_STATS_COSTS},
    {"prepare_ms", AT(prepare_ms), FIG_DOUBLE, RD_STATS_COSTS},
    {"primitives", AT(primitives), FIG_SIZE, RD_STATS_COSTS},
    {"threads", AT(threads), FIG_INT, RD_STATS_COSTS | RD_STATS_PROCESS},
    {"time_ms", AT(wall_ms), FIG_DOUBLE, RD_STATS_COSTS | RD_STATS_PROCESS},
    {"nonfinite", AT(nonfinite), FIG_U64, RD_STATS_COSTS | RD_STATS_PROCESS},
    {"bvh_build_ms", AT(bvh_build_ms), FIG_DOUBLE, RD_STATS_COSTS | RD_STATS_PROCESS},
    {"bvh_nodes", AT(bvh_nodes), FIG_SIZE, RD_STATS_COSTS | RD_STATS_PROCESS},
    {"world_bytes", AT(world_bytes), FIG_SIZE, RD_STATS_COSTS | RD_STATS_PROCESS},
#undef AT
};

enum { N_FIGURES = sizeof figures / sizeof figures[0] };

/* Counts are sent as JSON numbers: doubles, whole up to 2^53 (cJSON 1.7.15
 * prints 15 significant digits where they come within about an ulp, so a
 * count beyond 10^15 may come back a few off: none comes near). */
#define COUNT_MAX 9007199254740992.0

static double figure_get(const rd_render_stats *st, const struct figure *f)
{
    const char *p = (const char *)st + f->offset;
    switch (f->type) {
    case FIG_INT: return *(const int *)p;
    case FIG_U64: return (double)*(const uint64_t *)p;
    case FIG_SIZE: return (double)*(const size_t *)p;
    default: return *(const double *)p;
    }
}

/* v into the figure when it is a value the figure can have; else 0. */
static void figure_set(rd_render_stats *st, const struct figure *f, const cJSON *v)
{
    char *p = (char *)st + f->offset;
    double x = cJSON_IsNumber(v) ? v->valuedouble : -1;
    int whole = x == floor(x);
    if (!(x >= 0 && isfinite(x)) || (f->type != FIG_DOUBLE && !whole))
        return;
    if (f->type == FIG_INT && x <= 2147483647.0)
        *(int *)p = (int)x;
    else if (f->type == FIG_U64 && x <= COUNT_MAX)
        *(uint64_t *)p = (uint64_t)x;
    else if (f->type == FIG_SIZE && x <= COUNT_MAX && x <= (double)SIZE_MAX)
        *(size_t *)p = (size_t)x;
    else if (f->type == FIG_DOUBLE)
        *(double *)p = x;
}

static int selected(const struct figure *f, unsigned parts) { return (f->needs & parts) == f->needs; }

int rd_stats_json(cJSON *into, const rd_render_stats *st, unsigned parts)
{
    int failed = !into;
    int nested = (parts & RD_STATS_COSTS) && (parts & RD_STATS_NESTED);
    cJSON *costs = nested ? cJSON_CreateObject() : into;
    for (int i = 0; i < N_FIGURES && !failed; i++)
        if (selected(&figures[i], parts))
            rd_json_add(figures[i].needs & RD_STATS_COSTS ? costs : into, figures[i].key,
                        cJSON_CreateNumber(figure_get(st, &figures[i])), &failed);
    if (parts & RD_STATS_STOPPED)
        rd_json_add(into, "stopped_by", cJSON_CreateString(rd_stop_reason_name(st->stopped_by)), &failed);
    rd_json_add(into, "curve", rd_json_curve(st->curve, st->curve_len), &failed);
    if (nested)
        rd_json_add(into, "stats", costs, &failed); /* added, or deleted */
    return failed ? -1 : 0;
}

void rd_stats_read(const cJSON *from, rd_render_stats *st, unsigned parts)
{
    memset(st, 0, sizeof *st);
    const cJSON *costs = from;
    if ((parts & RD_STATS_COSTS) && (parts & RD_STATS_NESTED))
        costs = cJSON_GetObjectItemCaseSensitive(from, "stats");
    for (int i = 0; i < N_FIGURES; i++)
        if (selected(&figures[i], parts))
            figure_set(
                st, &figures[i],
                cJSON_GetObjectItemCaseSensitive(figures[i].needs & RD_STATS_COSTS ? costs : from, figures[i].key));
    const char *why = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(from, "stopped_by"));
    /* RD_STOP_CANCELLED is the last reason (rayd/progress.h). */
    for (rd_stop_reason r = RD_STOP_NONE; (parts & RD_STATS_STOPPED) && why && r <= RD_STOP_CANCELLED; r++)
        if (strcmp(why, rd_stop_reason_name(r)) == 0)
            st->stopped_by = r;
    rd_json_curve_read(cJSON_GetObjectItemCaseSensitive(from, "curve"), st->curve, &st->curve_len);
}
