/* cJSON trees as files: pretty-printed text ending in a newline. */
#ifndef RD_JSON_TEXT_H
#define RD_JSON_TEXT_H

#include <cJSON.h>

#include "rayd/stats.h"

/* Prints root (and deletes it) into a malloc'ed, NUL-terminated text ending
 * in a newline, which the caller frees with free(); NULL when out of memory. */
char *rd_json_print(cJSON *root);

/* Adds item to parent, under key when parent is an object (key NULL: to
 * the end of an array), and returns item. When item or parent is NULL or
 * the add fails (cJSON out of memory), deletes item, sets *failed and
 * returns NULL: a tree is built without a check at every step and checked
 * once, through *failed, at the end. */
cJSON *rd_json_add(cJSON *parent, const char *key, cJSON *item, int *failed);

/* An error-against-time curve as every answer gives it: [[ms, samples,
 * error], ...] (NULL when out of memory). */
cJSON *rd_json_curve(const rd_curve_point *c, int n);

/* Reads such a curve back into c[RD_CURVE_MAX] and *n: 0, or -1 (*n = 0)
 * when curve is not an array of at most RD_CURVE_MAX arrays of three
 * finite numbers. */
int rd_json_curve_read(const cJSON *curve, rd_curve_point *c, int *n);

/* A render's statistics as JSON: the one vocabulary of `rayd render
 * --stats-format json`, of GET /v1/jobs/{id} (a job in memory and a
 * stored one) and of the statistics text the job store keeps. The names
 * are the HTTP contract's (../shared/spec/http-api.md, docs/openapi.json):
 *   samples, error_estimate, passes, curve (rd_json_curve's shape), and
 *   with RD_STATS_STOPPED stopped_by;
 *   with RD_STATS_COSTS camera_rays, shadow_rays, secondary_rays,
 *   rays_per_second, prepare_ms, primitives;
 *   with RD_STATS_PROCESS mean_samples, and with both threads, time_ms
 *   (rd_render_stats.wall_ms), nonfinite, bvh_build_ms, bvh_nodes,
 *   world_bytes.
 * RD_STATS_NESTED puts the costs in an object "stats", as a job status
 * has them; without it they stand beside the others (rayd render's one
 * flat object). */
enum {
    RD_STATS_STOPPED = 1, /* the render has ended: why */
    RD_STATS_COSTS = 2,   /* rays and times spent */
    RD_STATS_NESTED = 4,  /* the costs under "stats" */
    /* The figures of a render that one process ran whole (rayd render).
     * A job status leaves them out: a stored job's passes and tiles run in
     * several daemons, each with its own threads and clock. */
    RD_STATS_PROCESS = 8
};

/* Adds st's figures that parts selects to into: 0, or -1 when out of
 * memory (into is then incomplete, and the caller drops it). */
int rd_stats_json(cJSON *into, const rd_render_stats *st, unsigned parts);

/* Reads back what rd_stats_json wrote with the same parts (from may be
 * NULL): *st is zeroed, then each figure that is there as a number in its
 * range (finite, not negative, whole where it counts) is read; one that is
 * not stays 0, and a curve that is not rd_json_curve's stays empty. For
 * texts that outlive the process that wrote them (the job store's), read
 * as hostile as any input. */
void rd_stats_read(const cJSON *from, rd_render_stats *st, unsigned parts);

#endif
