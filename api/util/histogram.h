/* A histogram of durations in seconds, as Prometheus exposes them: fixed
 * upper bounds, a count per bucket, the sum and the total. The bounds are
 * the usual ones from 5 ms to 30 s, extended by doubling until they reach
 * the longest value worth telling apart (a job timeout), so that values up
 * to it never all land in +Inf.
 *
 * Not thread-safe: its owner serializes access. A plain value: copying it
 * copies everything, and nothing needs freeing. */
#ifndef RD_HISTOGRAM_H
#define RD_HISTOGRAM_H

#include <stdint.h>

/* 12 fixed bounds, then 28 doublings of 30 s: past 250 years. */
enum { RD_HIST_MAX = 40 };

typedef struct {
    int n;                       /* bounds in use */
    double le[RD_HIST_MAX];      /* upper bounds, increasing */
    uint64_t count[RD_HIST_MAX]; /* values in (le[b-1], le[b]]; not cumulative */
    uint64_t total;              /* every value, those above le[n-1] too */
    double sum;
} rd_hist;

/* Empties h and gives it bounds up to at least cover seconds (at most
 * RD_HIST_MAX of them); cover <= 30 keeps the fixed set alone. */
void rd_hist_init(rd_hist *h, double cover);

void rd_hist_observe(rd_hist *h, double seconds);

#endif
