/* GET /metrics (Prometheus text format 0.0.4) and what the HTTP side
 * records for it: requests by route and exact status, their durations,
 * grades by verdict. The job queue, the farm and the grading service keep
 * their own figures (rd_jq_metrics, ...: reference cache hits), read at
 * each scrape.
 *
 * Route labels are the route table's paths (router.c), "other" when no
 * route matched, so the number of series is bounded by the table.
 *
 * Thread safety: every function may be called from any thread at once. */
#ifndef RD_METRICS_H
#define RD_METRICS_H

#include "server.h"

struct rd_req;
typedef struct rd_metrics rd_metrics;

/* cover_seconds: how far the request-duration buckets reach (see
 * rd_hist_init). NULL when out of memory; the caller frees it with
 * rd_metrics_free (NULL is a no-op). */
rd_metrics *rd_metrics_new(double cover_seconds);
void rd_metrics_free(rd_metrics *m);

/* A request has completed after ms milliseconds; one that got no answer
 * (status 0: its client went away first) is not counted. */
void rd_metrics_request_done(rd_server *srv, const struct rd_req *r, double ms);

/* A request answered 431 before it was parsed: no route, no duration. */
void rd_metrics_refused(rd_server *srv);

typedef enum { RD_VERDICT_PASS, RD_VERDICT_FAIL, RD_VERDICT_ERROR } rd_verdict;

/* A grade was answered: with a verdict, or with an error of its pipeline. */
void rd_metrics_grade(rd_server *srv, rd_verdict v);
void rd_metrics_code_grade(rd_server *srv, rd_verdict v);

#endif
